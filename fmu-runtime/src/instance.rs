//! One FMU instance: its phase in the FMI 2.0 co-simulation state machine, its logger, its
//! time, and the type-erased model with its variable values.
//!
//! Everything here is safe Rust; the raw pointers of the C API are turned into references in
//! `exports` before they reach this module.

use std::ffi::CString;

use crate::ffi::{fmi2CallbackFunctions, Status};
use crate::model::{Context, Model, Notes};
use crate::phase::{Phase, CAT_ERROR, LOG_CATEGORIES};
use crate::state::{InstanceState, StateError, StateHeader};
use crate::variables::{
    all_finite, is_subnormal, BaseType, Kind, ModelRefusal, SetPhase, Values, Var, VariableError, VariableSet,
    WrittenIndices,
};

/// Guards against a stray or freed pointer being used as an instance.
pub const INSTANCE_MAGIC: u64 = 0x4D4B_4154_5F46_4D55; // "MKAT_FMU"
pub const STATE_MAGIC: u64 = 0x4D4B_4154_5354_4154; // "MKATSTAT"

/// A saved FMU state, handed to the master as an opaque pointer.
pub struct SavedState {
    pub magic: u64,
    pub bytes: Vec<u8>,
}

/// Why a call on an instance's model failed; the runtime logs its text with `fmi2Error`.
#[derive(Debug, thiserror::Error)]
pub enum InstanceError {
    /// A value reference or value the variable table refuses.
    #[error(transparent)]
    Variable(#[from] VariableError),
    /// The model's own error ([`Model::Error`]) from creating, initialising or stepping it or
    /// from a String set.
    #[error(transparent)]
    Model(ModelRefusal),
    /// A get would hand out a value that is not finite.
    #[error("'{name}' (value reference {vr}) would be {value}, which the model cannot give; the inputs or parameters are outside what it can compute")]
    NonFiniteRead { name: &'static str, vr: u32, value: f64 },
    /// Initialisation computed a value that is not finite; it was undone.
    #[error("initialisation gives {name} = {value}: the parameters do not describe a model that can run")]
    InitialisationNotFinite { name: &'static str, value: f64 },
    /// A step computed a value that is not finite; it was undone.
    #[error("the step from {time} s by {step} s would give {name} = {value}; it was undone and the instance is as before the step (a parameter or input outside what the model can compute, or a step too long for it)")]
    StepNotFinite { time: f64, step: f64, name: &'static str, value: f64 },
    /// A step would take too many internal pieces ([`Model::step_pieces`]).
    #[error("the step of {step} s would be computed in {pieces:.3e} pieces ({what}), more than the {max_pieces:e} one call may take (about ten seconds of computing); take shorter steps or longer pieces")]
    TooManyPieces { step: f64, pieces: f64, what: &'static str, max_pieces: f64 },
    /// Undoing a failed step or initialisation could not restore the model's state before it.
    #[error(transparent)]
    Undo(StateError),
}

impl InstanceError {
    /// Boxes a model's own error.
    fn model<E: std::error::Error + Send + Sync + 'static>(error: E) -> InstanceError {
        InstanceError::Model(Box::new(error))
    }
}

/// The type-erased part of an instance: a model and its values.
pub trait DynModel: Send {
    fn model_identifier(&self) -> &'static str;
    fn guid(&self) -> &str;
    fn get(&self, vr: u32, ty: BaseType) -> Result<&'static Var, InstanceError>;
    /// Reads Reals. The feedthrough groups in `stale` (bit `g` for group `g`, see
    /// [`Model::feedthrough_group`]) are brought up to date first where one of `vrs` is an output
    /// of them; returns the groups that were.
    fn get_real(&mut self, vrs: &[u32], out: &mut [f64], stale: u32) -> Result<u32, InstanceError>;
    fn get_integer(&self, vrs: &[u32], out: &mut [i32]) -> Result<(), InstanceError>;
    fn get_boolean(&self, vrs: &[u32], out: &mut [bool]) -> Result<(), InstanceError>;
    fn get_string(&self, vrs: &[u32]) -> Result<Vec<String>, InstanceError>;
    fn set_real(&mut self, vrs: &[u32], values: &[f64], phase: SetPhase) -> Result<(), InstanceError>;
    fn set_integer(&mut self, vrs: &[u32], values: &[i32], phase: SetPhase) -> Result<(), InstanceError>;
    fn set_boolean(&mut self, vrs: &[u32], values: &[bool], phase: SetPhase) -> Result<(), InstanceError>;
    fn set_string(
        &mut self,
        vrs: &[u32],
        values: Vec<String>,
        phase: SetPhase,
        context: &Context,
    ) -> Result<(), InstanceError>;
    fn initialize(&mut self, context: &Context, notes: &mut Notes) -> Result<(), InstanceError>;
    /// Brings the feedthrough outputs of `groups` up to date.
    fn update_feedthrough(&mut self, groups: u32);
    /// The feedthrough groups of the model's outputs (0: no output depends directly on an input).
    fn feedthrough_groups(&self) -> u32;
    /// The feedthrough groups that `vrs` read (unknown references read none).
    fn feedthrough_groups_read(&self, vrs: &[u32]) -> u32;
    /// Advances the model; a step whose values would come out NaN or infinite is undone and
    /// refused. A step that would take more than `max_pieces` internal pieces
    /// ([`Model::step_pieces`]) is refused before anything changes (one call for both, as
    /// every step of every FMU of a coupled simulation pays for the call).
    fn do_step(
        &mut self,
        time: f64,
        step: f64,
        max_pieces: f64,
        context: &Context,
        notes: &mut Notes,
    ) -> Result<(), InstanceError>;
    /// The bytes of a state: `header`, then the values and the model's state.
    fn save(&self, header: &StateHeader) -> Result<Vec<u8>, StateError>;
    /// Restores a state of this model (checked by identifier and GUID) and returns its header.
    /// Nothing changes unless all of it reads back.
    fn load(&mut self, bytes: &[u8], context: &Context) -> Result<StateHeader, StateError>;
}

/// What a set of one Real value reference needs on the hot path, packed into a small entry:
/// a master exchanges a few dozen values every millisecond, and reading the whole declaration
/// (names, descriptions, units) for each costs more than the model's own step. The
/// declaration stays the one source: this is derived from it, and every failed check falls
/// back to the declaration's own checks, which word the error.
#[derive(Debug, Clone, Copy)]
struct Access {
    /// The values fmi2SetReal accepts for this variable by the declaration's checks, as
    /// `(lo, hi)`, before stepping (index 0: before and during initialisation) and while
    /// stepping (index 1). For a Real settable in that phase it is the declared range
    /// narrowed to finite numbers, so that `lo <= value && value <= hi` is the whole check
    /// (finite, in range, settable now; NaN fails every comparison); otherwise both bounds are
    /// NaN and no value passes. The model's own check comes on top.
    settable_range: [(f64, f64); 2],
}

impl Access {
    fn of(var: &Var) -> Access {
        let (min, max) = match var.kind {
            Kind::Real { min, max, .. } => {
                (min.unwrap_or(f64::MIN).max(f64::MIN), max.unwrap_or(f64::MAX).min(f64::MAX))
            }
            _ => (f64::MIN, f64::MAX),
        };
        let range = |phase: SetPhase| {
            if var.base_type() == BaseType::Real && var.settable_in(phase) {
                (min, max)
            } else {
                (f64::NAN, f64::NAN)
            }
        };
        Access { settable_range: [range(SetPhase::Initialization), range(SetPhase::Stepping)] }
    }

    /// Whether a Real passes the declaration's checks in a phase (index as `settable_range`).
    #[inline]
    fn accepts_real(&self, value: f64, phase_index: usize) -> bool {
        let (lo, hi) = self.settable_range[phase_index];
        lo <= value && value <= hi && !is_subnormal(value)
    }
}

/// The storage slot's part of a [`real_read`] entry; the bits above it are the feedthrough
/// group of an output with direct feedthrough (bit `16 + g` for group `g`).
const SLOT_BITS: u32 = 0xFFFF;
/// Where the feedthrough group bits of a [`real_read`] entry start.
const GROUP_SHIFT: u32 = 16;
/// [`real_read`]'s entry for a variable that is not a Real: no slot of [`Values`] is this high.
const NOT_A_REAL: u32 = SLOT_BITS;

/// What fmi2GetReal needs of value reference `index`, in one number, so that the hottest loop
/// of a coupled simulation does one load per value: for a Real, its storage slot in [`Values`]
/// with the bit of its feedthrough group set above [`GROUP_SHIFT`] if it is an output with
/// direct feedthrough; otherwise [`NOT_A_REAL`], which as a slot is out of bounds. Derived from
/// the declaration and [`Model::feedthrough_group`], as [`Access`].
fn real_read<M: Model>(index: usize) -> u32 {
    let var = &M::Var::TABLE[index];
    if var.base_type() != BaseType::Real {
        return NOT_A_REAL;
    }
    let slot = u32::from(M::Var::SLOTS[index]);
    assert!(slot < NOT_A_REAL, "more Real variables than a get's entries can number");
    let group = match M::Var::from_index(index) {
        Some(v) if !var.depends_on.is_empty() => M::feedthrough_group(v),
        _ => return slot,
    };
    assert!(group < 32 - GROUP_SHIFT, "{}: feedthrough group {group} is not below 16", var.name);
    slot | 1 << (GROUP_SHIFT + group)
}

/// A model with its values; implements [`DynModel`] for any [`Model`].
pub struct ModelSlot<M: Model> {
    model: M,
    values: Values<M::Var>,
    guid: String,
    /// One entry per value reference, from the variable table.
    access: Vec<Access>,
    /// One entry per value reference, for fmi2GetReal ([`real_read`]).
    real_reads: Vec<u32>,
    /// The feedthrough groups of the model's outputs (from the table, computed once).
    feedthrough_groups: u32,
    /// The values before the step in progress, to undo a step whose results are not finite
    /// (kept between steps so that taking the copy does not allocate).
    before_step: Values<M::Var>,
    /// The variables a step may write: all a step's undo needs to put back.
    written: WrittenIndices,
    /// The model's state before the step in progress (kept between steps, as `before_step`,
    /// so that [`Model::save_state_into`] can reuse its storage); `None` after an undo took it.
    model_before_step: Option<M::State>,
    /// Whether a String value changed since `before_step` was last copied whole.
    strings_changed: bool,
}

impl<M: Model> ModelSlot<M> {
    pub fn create(context: &Context, guid: String) -> Result<Self, InstanceError> {
        let values = Values::<M::Var>::at_start();
        let model = M::new(&values, context).map_err(InstanceError::model)?;
        let access = M::Var::TABLE.iter().map(Access::of).collect();
        let real_reads: Vec<u32> = (0..M::Var::TABLE.len()).map(real_read::<M>).collect();
        let feedthrough_groups = real_reads.iter().fold(0, |groups, read| groups | read >> GROUP_SHIFT);
        let before_step = values.clone();
        let written = WrittenIndices::of(M::Var::TABLE);
        Ok(ModelSlot {
            model,
            values,
            guid,
            access,
            real_reads,
            feedthrough_groups,
            before_step,
            written,
            model_before_step: None,
            strings_changed: false,
        })
    }

    fn lookup(vr: u32, ty: BaseType) -> Result<(usize, &'static Var), VariableError> {
        let index = vr as usize;
        let var = M::Var::TABLE.get(index).ok_or(VariableError::UnknownReference { vr, count: M::Var::TABLE.len() })?;
        if var.base_type() != ty {
            return Err(VariableError::WrongType { vr, name: var.name, actual: var.base_type(), requested: ty });
        }
        Ok((index, var))
    }

    /// Why `vr` cannot be read as a Real: the declaration's own check words it. Out of line
    /// and cold, so that the loops of the hot gets and sets keep few registers.
    #[cold]
    #[inline(never)]
    fn not_a_real(vr: u32) -> VariableError {
        Self::lookup(vr, BaseType::Real).err().unwrap_or(VariableError::NotAReal { vr })
    }

    /// The declaration's checks of a Real set, one by one, for a value the packed check
    /// refused (they agree with it, and word the error). Out of line and cold, as
    /// [`Self::not_a_real`].
    #[cold]
    #[inline(never)]
    fn check_real_by_declaration(&self, vr: u32, value: f64, phase: SetPhase) -> Result<(), VariableError> {
        let (_, decl) = Self::lookup(vr, BaseType::Real)?;
        Self::check_settable(decl, vr, phase)?;
        check_real_value::<M>(M::Var::from_index(vr as usize).expect("index checked"), value, &self.values)
    }

    /// Puts back the values and the model as they were before a step (or an initialisation).
    #[cold]
    fn undo_step(&mut self, model_before: M::State, context: &Context) -> Result<(), InstanceError> {
        let mut model = M::new(&self.before_step, context).map_err(InstanceError::model)?;
        model.load_state(model_before, &self.before_step).map_err(InstanceError::Undo)?;
        self.model = model;
        self.values.copy_numbers_from(&self.before_step);
        Ok(())
    }

    /// Puts back what a step wrote and the model as it was before the step. Parameters and
    /// inputs are the master's and a step does not change them, so the values are then as
    /// before the step.
    #[cold]
    fn undo_written(&mut self, model_before: M::State, context: &Context) -> Result<(), InstanceError> {
        self.values.copy_written_from(&self.before_step, &self.written);
        let mut model = M::new(&self.values, context).map_err(InstanceError::model)?;
        model.load_state(model_before, &self.values).map_err(InstanceError::Undo)?;
        self.model = model;
        Ok(())
    }

    /// Copies the values into `before_step`: numbers always, strings when one changed.
    #[inline]
    fn keep_values_before(&mut self) {
        if self.strings_changed {
            self.before_step = self.values.clone();
            self.strings_changed = false;
        } else {
            self.before_step.copy_numbers_from(&self.values);
        }
    }

    /// Why a get was refused: which value is not finite.
    #[cold]
    #[inline(never)]
    fn non_finite_read(&self, vrs: &[u32], out: &[f64]) -> InstanceError {
        let (vr, value) = vrs.iter().zip(out).find(|(_, x)| !x.is_finite()).map(|(&v, &x)| (v, x)).unwrap_or((0, 0.0));
        let name = M::Var::TABLE.get(vr as usize).map_or("?", |v| v.name);
        InstanceError::NonFiniteRead { name, vr, value }
    }

    fn check_settable(var: &Var, vr: u32, phase: SetPhase) -> Result<(), VariableError> {
        if var.settable_in(phase) {
            return Ok(());
        }
        let why = match phase {
            SetPhase::Stepping => "after initialisation only inputs and tunable parameters may be set",
            _ => "only inputs and variables with initial=\"exact\" or \"approx\" may be set",
        };
        Err(VariableError::NotSettable {
            name: var.name,
            vr,
            causality: var.causality.xml_name(),
            variability: var.variability.xml_name(),
            why,
        })
    }
}

impl<M: Model> DynModel for ModelSlot<M> {
    fn model_identifier(&self) -> &'static str {
        M::info().model_identifier
    }

    fn guid(&self) -> &str {
        &self.guid
    }

    fn get(&self, vr: u32, ty: BaseType) -> Result<&'static Var, InstanceError> {
        Ok(Self::lookup(vr, ty).map(|(_, v)| v)?)
    }

    fn get_real(&mut self, vrs: &[u32], out: &mut [f64], stale: u32) -> Result<u32, InstanceError> {
        // Copy while checking every reference (and noting the feedthrough groups read); if a
        // group read is stale (its inputs changed), bring that group up to date and copy again:
        // no value is read stale. One pass for the common get, which reads no stale group (a
        // master's get after each step is such a get whenever it reads no feedthrough output:
        // after a step of a model with feedthrough, every group is stale). A refused call may
        // have written part of `out`, which the master must not read after fmi2Error anyway;
        // the instance is unchanged.
        let mut reads = 0;
        for (slot, &vr) in out.iter_mut().zip(vrs) {
            let read = self.real_reads.get(vr as usize).copied().unwrap_or(NOT_A_REAL);
            reads |= read;
            match self.values.reals_by_slot().get((read & SLOT_BITS) as usize) {
                Some(&value) => *slot = value,
                None => return Err(Self::not_a_real(vr).into()),
            }
        }
        let refreshed = stale & reads >> GROUP_SHIFT;
        if refreshed != 0 {
            self.model.update_feedthrough_groups(&mut self.values, refreshed);
            for (slot, &vr) in out.iter_mut().zip(vrs) {
                *slot = self.values.real_at(vr as usize);
            }
        }
        // A get never hands out NaN or infinity with fmi2OK: the steps and initialisation are
        // guarded, and this catches what a feedthrough output computed just now.
        if !all_finite(out) {
            return Err(self.non_finite_read(vrs, out));
        }
        Ok(refreshed)
    }

    fn get_integer(&self, vrs: &[u32], out: &mut [i32]) -> Result<(), InstanceError> {
        for (slot, &vr) in out.iter_mut().zip(vrs) {
            let (i, _) = Self::lookup(vr, BaseType::Integer)?;
            *slot = self.values.integer_at(i);
        }
        Ok(())
    }

    fn get_boolean(&self, vrs: &[u32], out: &mut [bool]) -> Result<(), InstanceError> {
        for (slot, &vr) in out.iter_mut().zip(vrs) {
            let (i, _) = Self::lookup(vr, BaseType::Boolean)?;
            *slot = self.values.boolean_at(i);
        }
        Ok(())
    }

    fn get_string(&self, vrs: &[u32]) -> Result<Vec<String>, InstanceError> {
        vrs.iter()
            .map(|&vr| Ok(Self::lookup(vr, BaseType::String).map(|(i, _)| self.values.string_at(i).to_string())?))
            .collect()
    }

    fn set_real(&mut self, vrs: &[u32], values: &[f64], phase: SetPhase) -> Result<(), InstanceError> {
        // Check everything first, then write: a rejected call changes nothing.
        let phase_index = usize::from(phase == SetPhase::Stepping);
        for (&vr, &value) in vrs.iter().zip(values) {
            if self.access.get(vr as usize).is_some_and(|a| a.accepts_real(value, phase_index)) {
                // The access table has one entry per variable, so there is a variable (written
                // without `expect`, so that a model without a check of its own pays nothing).
                if let Some(var) = M::Var::from_index(vr as usize) {
                    check_model_real::<M>(var, value, &self.values)?;
                }
            } else {
                self.check_real_by_declaration(vr, value, phase)?;
            }
        }
        for (&vr, &value) in vrs.iter().zip(values) {
            *self.values.real_at_mut(vr as usize) = value;
        }
        Ok(())
    }

    fn set_integer(&mut self, vrs: &[u32], values: &[i32], phase: SetPhase) -> Result<(), InstanceError> {
        for (&vr, &value) in vrs.iter().zip(values) {
            let (_, var) = Self::lookup(vr, BaseType::Integer)?;
            Self::check_settable(var, vr, phase)?;
            check_integer_value::<M>(M::Var::from_index(vr as usize).expect("index checked"), value, &self.values)?;
        }
        for (&vr, &value) in vrs.iter().zip(values) {
            *self.values.integer_at_mut(vr as usize) = value;
        }
        Ok(())
    }

    fn set_boolean(&mut self, vrs: &[u32], values: &[bool], phase: SetPhase) -> Result<(), InstanceError> {
        for &vr in vrs {
            let (_, var) = Self::lookup(vr, BaseType::Boolean)?;
            Self::check_settable(var, vr, phase)?;
        }
        for (&vr, &value) in vrs.iter().zip(values) {
            *self.values.boolean_at_mut(vr as usize) = value;
        }
        Ok(())
    }

    fn set_string(
        &mut self,
        vrs: &[u32],
        values: Vec<String>,
        phase: SetPhase,
        context: &Context,
    ) -> Result<(), InstanceError> {
        for &vr in vrs {
            let (_, var) = Self::lookup(vr, BaseType::String)?;
            Self::check_settable(var, vr, phase)?;
        }
        // A string may name a file whose contents set further values; work on a copy so that a
        // failure half-way leaves everything as it was.
        let before = self.values.clone();
        self.strings_changed = true;
        for (&vr, value) in vrs.iter().zip(values) {
            *self.values.string_at_mut(vr as usize) = value;
            let typed = M::Var::from_index(vr as usize).expect("index checked");
            if let Err(e) = self.model.string_changed(typed, &mut self.values, context) {
                self.values = before;
                return Err(InstanceError::model(e));
            }
        }
        Ok(())
    }

    fn initialize(&mut self, context: &Context, notes: &mut Notes) -> Result<(), InstanceError> {
        // As a step: kept to be undone, so that a failed initialisation leaves no NaN behind
        // (a state taken afterwards must be one that can be restored).
        self.keep_values_before();
        let model_before = self.model.save_state();
        if let Err(e) = self.model.initialize(&mut self.values, context, notes) {
            self.undo_step(model_before, context)?;
            return Err(InstanceError::model(e));
        }
        let Some(index) = self.values.first_non_finite_real() else { return Ok(()) };
        let (name, value) = (M::Var::TABLE[index].name, self.values.real_at(index));
        self.undo_step(model_before, context)?;
        Err(InstanceError::InitialisationNotFinite { name, value })
    }

    fn update_feedthrough(&mut self, groups: u32) {
        self.model.update_feedthrough_groups(&mut self.values, groups);
    }

    fn feedthrough_groups(&self) -> u32 {
        self.feedthrough_groups
    }

    fn feedthrough_groups_read(&self, vrs: &[u32]) -> u32 {
        vrs.iter()
            .fold(0, |groups, &vr| groups | self.real_reads.get(vr as usize).map_or(0, |read| read >> GROUP_SHIFT))
    }

    fn do_step(
        &mut self,
        time: f64,
        step: f64,
        max_pieces: f64,
        context: &Context,
        notes: &mut Notes,
    ) -> Result<(), InstanceError> {
        let (pieces, what) = M::step_pieces(&self.values, step);
        // NaN pieces (a model's arithmetic gone wrong) are refused too.
        if pieces.is_nan() || pieces > max_pieces {
            return Err(too_many_pieces(step, pieces, what, max_pieces));
        }
        // Keep what is needed to undo the step: the values (copied into a kept buffer) and the
        // model's own state (what an FMU state holds of it).
        // Only what a step may write is kept and checked (parameters and inputs are checked by
        // the sets that change them): the first slots of each vector of the values, one block
        // copy each ([`crate::variables::storage_slots`]).
        self.before_step.copy_written_from(&self.values, &self.written);
        match &mut self.model_before_step {
            Some(state) => self.model.save_state_into(state),
            None => self.model_before_step = Some(self.model.save_state()),
        }
        if let Err(e) = self.model.do_step(&mut self.values, time, step, notes) {
            // Models leave their data untouched on an error; undoing makes sure of it.
            let model_before = self.model_before_step.take().expect("kept just above");
            self.undo_written(model_before, context)?;
            return Err(InstanceError::model(e));
        }
        let Some(index) = self.values.first_non_finite_written(&self.written) else { return Ok(()) };
        let (name, value) = (M::Var::TABLE[index].name, self.values.real_at(index));
        let model_before = self.model_before_step.take().expect("kept above");
        self.undo_written(model_before, context)?;
        Err(InstanceError::StepNotFinite { time, step, name, value })
    }

    fn save(&self, header: &StateHeader) -> Result<Vec<u8>, StateError> {
        crate::state::encode::<M>(header, &self.values, &self.model.save_state())
    }

    fn load(&mut self, bytes: &[u8], context: &Context) -> Result<StateHeader, StateError> {
        // Build the restored model aside and swap it in only when everything was read.
        let InstanceState { header, values, model: state } =
            crate::state::decode::<M>(bytes, M::info().model_identifier, &self.guid)?;
        let mut model = M::new(&values, context).map_err(StateError::model)?;
        // A state taken while parameters await initialisation (set after the model last
        // initialised) holds a model state that the next initialisation replaces, built from
        // the values: it may not fit them (a parameter the model then refuses), so it is not
        // loaded, and the restored instance initialises from its values as the saved one would.
        if !header.needs_initialize {
            model.load_state(state, &values)?;
        }
        self.values = values;
        self.model = model;
        self.strings_changed = true;
        Ok(header)
    }
}

/// Why a step is refused for its count of internal pieces.
#[cold]
#[inline(never)]
fn too_many_pieces(step: f64, pieces: f64, what: &'static str, max_pieces: f64) -> InstanceError {
    InstanceError::TooManyPieces { step, pieces, what, max_pieces }
}

/// Checks a Real value a master (or a parameter file) wants to set: finite, not subnormal,
/// within the declared range, and accepted by the model's own check.
pub fn check_real_value<M: Model>(var: M::Var, value: f64, values: &Values<M::Var>) -> Result<(), VariableError> {
    let decl = var.var();
    let (name, vr) = (decl.name, var.vr());
    if !value.is_finite() {
        return Err(VariableError::NotFinite { name, vr, value });
    }
    if is_subnormal(value) {
        return Err(VariableError::Subnormal { name, vr, value });
    }
    if let Kind::Real { min, max, unit, .. } = decl.kind {
        if let Some(min) = min {
            if value < min {
                return Err(VariableError::BelowMinimum { name, value, unit, min });
            }
        }
        if let Some(max) = max {
            if value > max {
                return Err(VariableError::AboveMaximum { name, value, unit, max });
            }
        }
    }
    check_model_real::<M>(var, value, values)
}

/// The model's own check of a Real value, after the declaration's.
fn check_model_real<M: Model>(var: M::Var, value: f64, values: &Values<M::Var>) -> Result<(), VariableError> {
    M::check_real(var, value, values).map_err(|e| VariableError::RealRefused {
        name: var.var().name,
        value,
        source: Box::new(e),
    })
}

/// Checks an Integer (or enumeration) value against its declared range or items and the
/// model's own check.
pub fn check_integer_value<M: Model>(var: M::Var, value: i32, values: &Values<M::Var>) -> Result<(), VariableError> {
    let decl = var.var();
    let name = decl.name;
    match decl.kind {
        Kind::Integer { min, max, .. } if min.is_some_and(|lo| value < lo) || max.is_some_and(|hi| value > hi) => {
            return Err(VariableError::IntegerOutOfRange { name, value, min, max });
        }
        Kind::Enumeration { declared_type, .. } if declared_type.name_of(value).is_none() => {
            return Err(VariableError::NotAnItem { name, value, declared_type });
        }
        _ => {}
    }
    M::check_integer(var, value, values).map_err(|e| VariableError::IntegerRefused { name, value, source: Box::new(e) })
}

/// An FMU instance as the C API sees it.
pub struct Instance {
    pub magic: u64,
    pub name: CString,
    pub callbacks: fmi2CallbackFunctions,
    pub logging_on: bool,
    pub categories: [bool; LOG_CATEGORIES.len()],
    pub phase: Phase,
    pub time: f64,
    pub start_time: f64,
    pub stop_time: Option<f64>,
    pub last_successful_time: f64,
    pub last_step_status: Status,
    /// Parameters changed since the model last initialised: recompute before reading outputs.
    pub needs_initialize: bool,
    /// The feedthrough groups whose inputs changed since they were last brought up to date
    /// (a set of inputs, or a step that moved what they act on mark every group): a group's
    /// outputs are recomputed before the next get that reads one of them. Only ever non-zero
    /// for a model that has such outputs.
    /// The last step a master passed, the binary exponents (with the signs) of the times it
    /// stepped from and to, and the step the models took for them (`exports::grid_step`): a
    /// master that keeps its step pays the rule once, not at every step.
    pub grid_step_cache: ((u64, u64, u64), f64),
    pub stale_feedthrough: u32,
    /// The feedthrough groups of the model's outputs (`DynModel::feedthrough_groups`, kept
    /// here because every set and step asks; 0 for a model without feedthrough).
    pub feedthrough_groups: u32,
    /// What the model notes during a step, empty between calls (kept here so that a step
    /// neither builds nor drops one).
    pub step_notes: Notes,
    pub context: Context,
    pub model: Box<dyn DynModel>,
    /// Rebuilds the model for fmi2Reset.
    pub create: fn(&Context) -> Result<Box<dyn DynModel>, InstanceError>,
    /// The model states are trial-loaded into at deserialisation ([`Instance::check_state`]),
    /// built at the first check and kept: a master that restores a state per window
    /// deserialises thousands, and building a model for each cost more than loading it.
    pub state_check_model: Option<Box<dyn DynModel>>,
    /// Strings handed out by fmi2GetString stay valid until the next call of it.
    pub returned_strings: Vec<CString>,
}

impl Instance {
    pub fn category_enabled(&self, category: usize) -> bool {
        self.categories[category]
    }

    /// Sends a message to the master's logger if its category is on. `%` is escaped because the
    /// logger treats the message as a printf format.
    pub fn log(&self, status: Status, category: usize, message: &str) {
        if !self.categories[category] {
            return;
        }
        let Some(logger) = self.callbacks.logger else { return };
        let escaped = message.replace('%', "%%").replace('\0', " ");
        let message = CString::new(escaped).unwrap_or_default();
        let category_name = CString::new(LOG_CATEGORIES[category].0).unwrap_or_default();
        // SAFETY: the master gave this logger in fmi2Instantiate for this instance; every pointer
        // passed is a valid NUL-terminated string that outlives the call, and no variadic
        // arguments are passed because the message has no conversion left after escaping.
        unsafe {
            logger(
                self.callbacks.componentEnvironment,
                self.name.as_ptr(),
                status as i32,
                category_name.as_ptr(),
                message.as_ptr(),
            );
        }
    }

    pub fn error(&self, function: &str, message: &str) {
        self.log(Status::Error, CAT_ERROR, &format!("{function}: {message}"));
    }

    /// The whole instance (phase, times, values and model) as a portable state.
    pub fn save_state(&self) -> Result<Vec<u8>, StateError> {
        let header = StateHeader {
            model_identifier: self.model.model_identifier().to_string(),
            guid: self.model.guid().to_string(),
            phase: self.phase,
            time: self.time,
            start_time: self.start_time,
            stop_time: self.stop_time,
            last_successful_time: self.last_successful_time,
            needs_initialize: self.needs_initialize,
        };
        self.model.save(&header)
    }

    /// Restores a state written by [`Instance::save_state`], from this or another instance of
    /// the same model. Nothing changes unless all of it reads back.
    pub fn load_state(&mut self, bytes: &[u8]) -> Result<(), StateError> {
        let header = self.model.load(bytes, &self.context)?;
        self.phase = header.phase;
        self.time = header.time;
        self.start_time = header.start_time;
        self.stop_time = header.stop_time;
        self.last_successful_time = header.last_successful_time;
        self.needs_initialize = header.needs_initialize;
        // Feedthrough outputs are recomputed from the restored inputs on the next get.
        self.stale_feedthrough = self.feedthrough_groups;
        Ok(())
    }

    /// Checks that bytes are a state of this model, without applying them: a trial load into a
    /// model of its own catches corrupt states at deserialisation time. A load builds the model
    /// afresh from the state's values (`ModelSlot::load`), so what that model held before
    /// never enters the check, and one model serves every check.
    pub fn check_state(&mut self, bytes: &[u8]) -> Result<(), StateError> {
        let scratch = match &mut self.state_check_model {
            Some(model) => model,
            empty => empty.insert((self.create)(&self.context).map_err(StateError::model)?),
        };
        scratch.load(bytes, &self.context).map(|_| ())
    }
}
