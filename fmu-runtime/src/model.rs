//! What a model provides to the runtime: its variables, its facts for the model description,
//! and its behaviour at initialisation and at each communication step. Models are plain safe
//! Rust; everything that touches C lives in the runtime.

use std::path::PathBuf;

use serde::de::DeserializeOwned;
use serde::Serialize;

use crate::state_error::StateError;
use crate::variables::{Values, VariableSet};

/// The `<DefaultExperiment>` of the model description.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DefaultExperiment {
    pub start_time: f64,
    pub stop_time: f64,
    pub step_size: f64,
}

/// Facts about a model that go into its `modelDescription.xml`.
#[derive(Debug, Clone, Copy)]
pub struct ModelInfo {
    /// Also the shared library's file name and the prefix of nothing: functions are not
    /// prefixed, each FMU is its own shared object.
    pub model_identifier: &'static str,
    pub model_name: &'static str,
    pub description: &'static str,
    pub author: &'static str,
    pub version: &'static str,
    pub default_experiment: DefaultExperiment,
}

/// What an instance knows about where it runs.
#[derive(Debug, Clone, Default)]
pub struct Context {
    pub instance_name: String,
    /// The unpacked `resources/` folder of the FMU, decoded from the URI the master passed.
    pub resource_dir: Option<PathBuf>,
}

/// Messages a model wants to report from a call, logged by the runtime under the category
/// `logEvents` (notes) or `logStatusWarning` (warnings) when the master has enabled them.
#[derive(Debug, Default)]
pub struct Notes {
    events_enabled: bool,
    pub(crate) events: Vec<String>,
    pub(crate) warnings: Vec<String>,
}

impl Notes {
    pub(crate) fn new(events_enabled: bool) -> Self {
        Notes { events_enabled, events: Vec::new(), warnings: Vec::new() }
    }

    /// Whether event messages will be kept from now on (an instance keeps one `Notes` for its
    /// steps, so that a step builds and drops none).
    #[inline]
    pub(crate) fn enable_events(&mut self, events_enabled: bool) {
        self.events_enabled = events_enabled;
    }

    /// Whether there is nothing to log.
    #[inline]
    pub(crate) fn is_empty(&self) -> bool {
        self.events.is_empty() && self.warnings.is_empty()
    }

    /// Whether event messages will be logged; check it before formatting one in a hot path.
    pub fn events_enabled(&self) -> bool {
        self.events_enabled
    }

    pub fn event(&mut self, message: impl Into<String>) {
        if self.events_enabled {
            self.events.push(message.into());
        }
    }

    /// A warning makes the call return fmi2Warning.
    pub fn warning(&mut self, message: impl Into<String>) {
        self.warnings.push(message.into());
    }
}

/// A co-simulation model.
///
/// Contract: when a method returns `Err`, it must not have changed the model's data, so that
/// the instance can be recovered by restoring a saved FMU state. The runtime has already
/// checked every value a master set (type, causality, phase, range, finiteness, and
/// [`Model::check_real`]) before a method sees it.
pub trait Model: Sized + Send + 'static {
    /// The variables, declared with [`crate::declare_variables!`].
    type Var: VariableSet;

    /// Why the model refuses a value, a parameter set or a step. The runtime logs its
    /// `Display` text with the call's `fmi2Error`, so the message should say what is wrong and
    /// how to fix it.
    type Error: std::error::Error + Send + Sync + 'static;

    fn info() -> ModelInfo;

    /// A new instance; the values are at their start values.
    fn new(values: &Values<Self::Var>, context: &Context) -> Result<Self, Self::Error>;

    /// Parameters are final (or the master asked for initial values during initialisation):
    /// build what depends on them and compute the initial outputs and calculated parameters.
    /// It may be called more than once before the first step.
    fn initialize(
        &mut self,
        values: &mut Values<Self::Var>,
        context: &Context,
        notes: &mut Notes,
    ) -> Result<(), Self::Error>;

    /// Advances the model from `time` to `time + step`, inputs held constant over the step,
    /// and writes the outputs at `time + step`.
    fn do_step(
        &mut self,
        values: &mut Values<Self::Var>,
        time: f64,
        step: f64,
        notes: &mut Notes,
    ) -> Result<(), Self::Error>;

    /// The work of a step of `step` seconds with these values, in the model's internal pieces
    /// (sub-steps, controller samples), and what sets the length of a piece, so that the runtime
    /// refuses up front a step that would take longer than [`crate::exports::MAX_STEP_PIECES`]
    /// pieces instead of keeping the call busy for minutes. Models whose work does not grow
    /// with the step keep the default (no pieces).
    fn step_pieces(_values: &Values<Self::Var>, _step: f64) -> (f64, &'static str) {
        (0.0, "")
    }

    /// Recomputes all the outputs that depend directly on inputs (those declared with
    /// `depends_on`) so that a get sees the current inputs as the standard requires. The
    /// runtime calls it, through [`Model::update_feedthrough_groups`], before the first get that
    /// reads one of them after a set of inputs or a step, so `do_step` need not compute them.
    /// Models without direct feedthrough keep the default.
    fn update_feedthrough(&mut self, _values: &mut Values<Self::Var>) {}

    /// The group (0 to 15) of an output with direct feedthrough. A get brings up to date only
    /// the groups of the outputs it reads ([`Model::update_feedthrough_groups`]), so that a
    /// master that reads some of a model's feedthrough outputs at every step does not pay for
    /// the others. Models keep the default, one group, unless their feedthrough outputs fall
    /// into parts that cost something apart.
    fn feedthrough_group(_var: Self::Var) -> u32 {
        0
    }

    /// Recomputes the feedthrough outputs of `groups` (bit `g` for group `g`); it may compute
    /// more. The default recomputes them all ([`Model::update_feedthrough`]).
    fn update_feedthrough_groups(&mut self, values: &mut Values<Self::Var>, _groups: u32) {
        self.update_feedthrough(values);
    }

    /// Extra checks on a Real value a master wants to set, beyond range and finiteness.
    fn check_real(_var: Self::Var, _value: f64, _values: &Values<Self::Var>) -> Result<(), Self::Error> {
        Ok(())
    }

    /// Extra checks on an Integer value (enumerations included), beyond the declared range.
    fn check_integer(_var: Self::Var, _value: i32, _values: &Values<Self::Var>) -> Result<(), Self::Error> {
        Ok(())
    }

    /// Called after a String variable was set; the model may read a file it names and set
    /// further values. On `Err` the runtime restores all values as they were before the call.
    fn string_changed(
        &mut self,
        _var: Self::Var,
        _values: &mut Values<Self::Var>,
        _context: &Context,
    ) -> Result<(), Self::Error> {
        Ok(())
    }

    /// Everything that determines the model's future beyond its variable values (not caches),
    /// as FMU states keep it ([`crate::state`] encodes it).
    type State: Serialize + DeserializeOwned + Send;

    /// The model's part of an FMU state.
    fn save_state(&self) -> Self::State;

    /// [`Model::save_state`] written over `state`, which holds an earlier one. The runtime
    /// keeps the model's state before every step to undo a step that fails; models whose state
    /// holds vectors override this to reuse their storage, so that a step does not allocate.
    fn save_state_into(&self, state: &mut Self::State) {
        *state = self.save_state();
    }

    /// Restores what [`Model::save_state`] returned (possibly in another instance or process)
    /// into a model just created by [`Model::new`] from `values`, which are already restored.
    /// A state that does not fit the model (its parameters) is an error.
    fn load_state(&mut self, state: Self::State, values: &Values<Self::Var>) -> Result<(), StateError>;
}
