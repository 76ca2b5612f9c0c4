//! One declaration per model variable.
//!
//! A model lists its variables once, with [`declare_variables!`], as an enum whose variants are
//! the variables and whose table holds name, causality, variability, unit, start value, range
//! and description. That one table gives the value references (the variant's position), the
//! start values of a new instance, the checks on every get and set, and the generated
//! `modelDescription.xml`, so the three cannot drift apart.

use std::fmt;
use std::marker::PhantomData;

use serde::{Deserialize, Serialize};

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Causality {
    Parameter,
    CalculatedParameter,
    Input,
    Output,
    Local,
}

impl Causality {
    pub fn xml_name(self) -> &'static str {
        match self {
            Causality::Parameter => "parameter",
            Causality::CalculatedParameter => "calculatedParameter",
            Causality::Input => "input",
            Causality::Output => "output",
            Causality::Local => "local",
        }
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Variability {
    Constant,
    Fixed,
    Tunable,
    Discrete,
    Continuous,
}

impl Variability {
    pub fn xml_name(self) -> &'static str {
        match self {
            Variability::Constant => "constant",
            Variability::Fixed => "fixed",
            Variability::Tunable => "tunable",
            Variability::Discrete => "discrete",
            Variability::Continuous => "continuous",
        }
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Initial {
    Exact,
    Approx,
    Calculated,
}

impl Initial {
    pub fn xml_name(self) -> &'static str {
        match self {
            Initial::Exact => "exact",
            Initial::Approx => "approx",
            Initial::Calculated => "calculated",
        }
    }
}

/// The items of an enumeration type: `(name, description)`, valued 1, 2, ... in order.
#[derive(Debug)]
pub struct EnumerationType {
    pub name: &'static str,
    pub description: &'static str,
    pub items: &'static [(&'static str, &'static str)],
}

impl EnumerationType {
    /// The value of an item (1-based, as the XML declares it), by name.
    pub fn value_of(&self, item: &str) -> Option<i32> {
        self.items.iter().position(|(n, _)| *n == item).map(|i| i as i32 + 1)
    }

    pub fn name_of(&self, value: i32) -> Option<&'static str> {
        usize::try_from(value - 1).ok().and_then(|i| self.items.get(i)).map(|(n, _)| *n)
    }
}

/// The base type of a variable, with its type-specific attributes.
#[derive(Debug, Clone, Copy)]
pub enum Kind {
    Real { unit: &'static str, start: Option<f64>, min: Option<f64>, max: Option<f64>, nominal: Option<f64> },
    Integer { start: Option<i32>, min: Option<i32>, max: Option<i32> },
    Boolean { start: Option<bool> },
    String { start: Option<&'static str> },
    Enumeration { declared_type: &'static EnumerationType, start: Option<i32> },
}

/// The base type as seen through the C API (enumerations travel as integers).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BaseType {
    Real,
    Integer,
    Boolean,
    String,
}

impl fmt::Display for BaseType {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            BaseType::Real => "Real",
            BaseType::Integer => "Integer",
            BaseType::Boolean => "Boolean",
            BaseType::String => "String",
        })
    }
}

/// One model variable: everything the XML says about it.
#[derive(Debug, Clone, Copy)]
pub struct Var {
    pub name: &'static str,
    pub description: &'static str,
    pub causality: Causality,
    pub variability: Variability,
    pub initial: Option<Initial>,
    pub kind: Kind,
    /// For outputs: the value references of the inputs the output depends on within the same
    /// step (direct feedthrough). Empty means the output is a function of the state only.
    pub depends_on: &'static [u32],
    /// For outputs: the inputs the output's value at the end of initialisation depends on
    /// (the initial state may be computed from them, a structure at rest under its start loads,
    /// say). `None`: the same as [`Var::depends_on`]. The parameters are knowns of every initial
    /// unknown, declared for all of them.
    pub initial_depends_on: Option<&'static [u32]>,
}

/// A model's own reason for refusing a value ([`crate::Model::check_real`] and the like), boxed
/// so that one runtime serves models with different error types.
pub type ModelRefusal = Box<dyn std::error::Error + Send + Sync + 'static>;

/// Why a value reference cannot be read or a value cannot be set: the checks the variable
/// table drives, worded for the master's log.
#[derive(Debug, thiserror::Error)]
pub enum VariableError {
    #[error("unknown value reference {vr} (this model has {count} variables)")]
    UnknownReference { vr: u32, count: usize },
    #[error("value reference {vr} ('{name}') is of type {actual}, not {requested}")]
    WrongType { vr: u32, name: &'static str, actual: BaseType, requested: BaseType },
    #[error("value reference {vr} is not a Real")]
    NotAReal { vr: u32 },
    #[error(
        "'{name}' (value reference {vr}, causality {causality}, variability {variability}) cannot be set now: {why}"
    )]
    NotSettable { name: &'static str, vr: u32, causality: &'static str, variability: &'static str, why: &'static str },
    #[error("'{name}' (value reference {vr}) cannot be set to {value}: values must be finite")]
    NotFinite { name: &'static str, vr: u32, value: f64 },
    #[error("'{name}' (value reference {vr}) cannot be set to {value:e}: subnormal numbers are refused (give 0 or a normal number)")]
    Subnormal { name: &'static str, vr: u32, value: f64 },
    #[error("'{name}' = {value} {unit} is below its minimum {min} {unit}")]
    BelowMinimum { name: &'static str, value: f64, unit: &'static str, min: f64 },
    #[error("'{name}' = {value} {unit} is above its maximum {max} {unit}")]
    AboveMaximum { name: &'static str, value: f64, unit: &'static str, max: f64 },
    #[error("'{name}' = {value} is outside its range [{}, {}]", bound_text(*.min, "-inf"), bound_text(*.max, "inf"))]
    IntegerOutOfRange { name: &'static str, value: i32, min: Option<i32>, max: Option<i32> },
    #[error("'{name}' = {value} is not an item of {} ({})", .declared_type.name, item_list(.declared_type))]
    NotAnItem { name: &'static str, value: i32, declared_type: &'static EnumerationType },
    #[error("'{name}' = {value}: {source}")]
    RealRefused { name: &'static str, value: f64, source: ModelRefusal },
    #[error("'{name}' = {value}: {source}")]
    IntegerRefused { name: &'static str, value: i32, source: ModelRefusal },
}

/// An integer bound as the messages show it, `-inf` or `inf` when there is none.
fn bound_text(bound: Option<i32>, none: &str) -> String {
    bound.map_or(none.into(), |v| v.to_string())
}

/// The items of an enumeration as the messages list them: `1 = name, 2 = name`.
fn item_list(declared_type: &EnumerationType) -> String {
    let items: Vec<String> =
        declared_type.items.iter().enumerate().map(|(i, (n, _))| format!("{} = {n}", i + 1)).collect();
    items.join(", ")
}

impl Var {
    const fn with_kind(name: &'static str, kind: Kind) -> Var {
        Var {
            name,
            description: "",
            causality: Causality::Local,
            variability: Variability::Continuous,
            initial: None,
            kind,
            depends_on: &[],
            initial_depends_on: None,
        }
    }

    pub const fn real(name: &'static str, unit: &'static str) -> Var {
        Var::with_kind(name, Kind::Real { unit, start: None, min: None, max: None, nominal: None })
    }

    pub const fn integer(name: &'static str) -> Var {
        let mut v = Var::with_kind(name, Kind::Integer { start: None, min: None, max: None });
        v.variability = Variability::Discrete;
        v
    }

    pub const fn boolean(name: &'static str) -> Var {
        let mut v = Var::with_kind(name, Kind::Boolean { start: None });
        v.variability = Variability::Discrete;
        v
    }

    pub const fn string(name: &'static str) -> Var {
        let mut v = Var::with_kind(name, Kind::String { start: None });
        v.variability = Variability::Discrete;
        v
    }

    pub const fn enumeration(name: &'static str, declared_type: &'static EnumerationType) -> Var {
        let mut v = Var::with_kind(name, Kind::Enumeration { declared_type, start: None });
        v.variability = Variability::Discrete;
        v
    }

    /// A parameter fixed after initialisation (the default for parameters).
    pub const fn parameter(mut self) -> Var {
        self.causality = Causality::Parameter;
        self.variability = Variability::Fixed;
        self.initial = Some(Initial::Exact);
        self
    }

    /// A parameter the master may change between steps.
    pub const fn tunable(mut self) -> Var {
        assert!(matches!(self.causality, Causality::Parameter), "only parameters can be tunable");
        self.variability = Variability::Tunable;
        self
    }

    /// A parameter computed by the model from the others.
    pub const fn calculated_parameter(mut self) -> Var {
        self.causality = Causality::CalculatedParameter;
        self.variability = Variability::Fixed;
        self.initial = Some(Initial::Calculated);
        self
    }

    pub const fn input(mut self) -> Var {
        self.causality = Causality::Input;
        self.initial = None;
        self
    }

    pub const fn output(mut self) -> Var {
        self.causality = Causality::Output;
        self.initial = Some(Initial::Calculated);
        self
    }

    /// Marks a Real variable as piecewise constant (it changes only at communication points).
    pub const fn discrete(mut self) -> Var {
        self.variability = Variability::Discrete;
        self
    }

    pub const fn description(mut self, text: &'static str) -> Var {
        self.description = text;
        self
    }

    pub const fn depends_on(mut self, inputs: &'static [u32]) -> Var {
        self.depends_on = inputs;
        self
    }

    /// The inputs the output's initial value depends on, where they differ from its
    /// direct-feedthrough inputs ([`Var::depends_on`]).
    pub const fn initially_depends_on(mut self, inputs: &'static [u32]) -> Var {
        self.initial_depends_on = Some(inputs);
        self
    }

    /// The inputs the value at the end of initialisation depends on.
    pub fn initial_inputs(&self) -> &'static [u32] {
        self.initial_depends_on.unwrap_or(self.depends_on)
    }

    pub const fn start(mut self, value: f64) -> Var {
        self.kind = match self.kind {
            Kind::Real { unit, min, max, nominal, .. } => Kind::Real { unit, start: Some(value), min, max, nominal },
            _ => panic!("start(f64) is for Real variables"),
        };
        self
    }

    pub const fn min(mut self, value: f64) -> Var {
        self.kind = match self.kind {
            Kind::Real { unit, start, max, nominal, .. } => Kind::Real { unit, start, min: Some(value), max, nominal },
            _ => panic!("min(f64) is for Real variables"),
        };
        self
    }

    pub const fn max(mut self, value: f64) -> Var {
        self.kind = match self.kind {
            Kind::Real { unit, start, min, nominal, .. } => Kind::Real { unit, start, min, max: Some(value), nominal },
            _ => panic!("max(f64) is for Real variables"),
        };
        self
    }

    pub const fn nominal(mut self, value: f64) -> Var {
        self.kind = match self.kind {
            Kind::Real { unit, start, min, max, .. } => Kind::Real { unit, start, min, max, nominal: Some(value) },
            _ => panic!("nominal(f64) is for Real variables"),
        };
        self
    }

    pub const fn start_integer(mut self, value: i32) -> Var {
        self.kind = match self.kind {
            Kind::Integer { min, max, .. } => Kind::Integer { start: Some(value), min, max },
            Kind::Enumeration { declared_type, .. } => Kind::Enumeration { declared_type, start: Some(value) },
            _ => panic!("start_integer is for Integer and Enumeration variables"),
        };
        self
    }

    pub const fn range_integer(mut self, min: i32, max: i32) -> Var {
        self.kind = match self.kind {
            Kind::Integer { start, .. } => Kind::Integer { start, min: Some(min), max: Some(max) },
            _ => panic!("range_integer is for Integer variables"),
        };
        self
    }

    pub const fn start_boolean(mut self, value: bool) -> Var {
        self.kind = match self.kind {
            Kind::Boolean { .. } => Kind::Boolean { start: Some(value) },
            _ => panic!("start_boolean is for Boolean variables"),
        };
        self
    }

    pub const fn start_string(mut self, value: &'static str) -> Var {
        self.kind = match self.kind {
            Kind::String { .. } => Kind::String { start: Some(value) },
            _ => panic!("start_string is for String variables"),
        };
        self
    }

    pub const fn base_type(&self) -> BaseType {
        match self.kind {
            Kind::Real { .. } => BaseType::Real,
            Kind::Integer { .. } | Kind::Enumeration { .. } => BaseType::Integer,
            Kind::Boolean { .. } => BaseType::Boolean,
            Kind::String { .. } => BaseType::String,
        }
    }

    pub fn unit(&self) -> Option<&'static str> {
        match self.kind {
            Kind::Real { unit, .. } => Some(unit),
            _ => None,
        }
    }

    /// Whether a step may write this variable: outputs, locals and calculated parameters that
    /// are numbers or booleans. Parameters and inputs change only through the master's sets,
    /// and strings only through sets and the files they name.
    pub const fn written_by_step(&self) -> bool {
        !matches!(self.causality, Causality::Parameter | Causality::Input) && !matches!(self.kind, Kind::String { .. })
    }

    /// Whether the master may set this variable in the given phase (FMI 2.0, section 4.2.4).
    pub fn settable_in(&self, phase: SetPhase) -> bool {
        match phase {
            // Before and during initialisation: inputs and every variable with a start value
            // the master may override (initial exact or approx), except constants.
            SetPhase::BeforeInitialization | SetPhase::Initialization => {
                self.variability != Variability::Constant
                    && (self.causality == Causality::Input
                        || matches!(self.initial, Some(Initial::Exact) | Some(Initial::Approx)))
            }
            // While stepping: inputs and tunable parameters only.
            SetPhase::Stepping => {
                self.causality == Causality::Input
                    || (self.causality == Causality::Parameter && self.variability == Variability::Tunable)
            }
        }
    }
}

/// The phases that differ in what may be set.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SetPhase {
    BeforeInitialization,
    Initialization,
    Stepping,
}

/// The enum of a model's variables, generated by [`declare_variables!`].
pub trait VariableSet: Copy + Send + Sync + 'static + fmt::Debug {
    const TABLE: &'static [Var];
    /// Each variable's place in the vectors of [`Values`], by value reference
    /// ([`storage_slots`] of the table, which `declare_variables!` writes).
    #[doc(hidden)]
    const SLOTS: &'static [u16];
    fn index(self) -> usize;
    /// The variable's place in the vectors of [`Values`]; for a variable known at compile time
    /// the compiler reads it from the constant table, so a model's accessors cost no more than
    /// with the value reference as index.
    #[inline]
    fn slot(self) -> usize {
        Self::SLOTS[self.index()] as usize
    }
    fn vr(self) -> u32 {
        self.index() as u32
    }
    fn var(self) -> &'static Var {
        &Self::TABLE[self.index()]
    }
    fn from_index(index: usize) -> Option<Self>;
    fn by_name(name: &str) -> Option<Self> {
        Self::TABLE.iter().position(|v| v.name == name).and_then(Self::from_index)
    }
}

/// Where each variable's value is stored in [`Values`]: first the variables a step may write
/// ([`Var::written_by_step`]), in table order, then the others, in table order. A step then
/// writes only the first slots of each vector, so what the runtime keeps to undo a step, and
/// checks for finiteness after it, is one block per vector whatever the order of the table
/// (a plant has about 100 variables of which some 15 are written by a step).
#[doc(hidden)]
pub const fn storage_slots<const N: usize>(table: &[Var]) -> [u16; N] {
    assert!(table.len() == N, "one slot per variable");
    assert!(N <= u16::MAX as usize, "at most 65535 variables");
    let mut slots = [0u16; N];
    let mut next = 0;
    let mut pass = 0;
    while pass < 2 {
        let mut i = 0;
        while i < N {
            if table[i].written_by_step() == (pass == 0) {
                slots[i] = next;
                next += 1;
            }
            i += 1;
        }
        pass += 1;
    }
    slots
}

/// What a step may write, as storage slots ([`storage_slots`]): the first `count` of each vector
/// of [`Values`], and whether any of them is an Integer or a Boolean (most models write only
/// Reals, and need not copy the other vectors).
#[derive(Debug, Clone, Default, PartialEq)]
pub(crate) struct WrittenIndices {
    pub count: usize,
    pub integers: bool,
    pub booleans: bool,
}

impl WrittenIndices {
    pub(crate) fn of(table: &[Var]) -> WrittenIndices {
        let written = || table.iter().filter(|v| v.written_by_step());
        WrittenIndices {
            count: written().count(),
            integers: written().any(|v| v.base_type() == BaseType::Integer),
            booleans: written().any(|v| v.base_type() == BaseType::Boolean),
        }
    }
}

/// Whether any of `values` is NaN or infinite, as the sign bit of the result: a finite number's
/// exponent field is below all ones, so adding one to the field stays inside it, while NaN's
/// and infinity's carries into the sign bit. Integer operations can be reordered freely, so the
/// compiler vectorises this where a sum of floating-point numbers must stay in order.
#[inline]
fn non_finite_probe(values: &[f64]) -> u64 {
    const EXPONENT: u64 = 0x7FF0_0000_0000_0000;
    const EXPONENT_ONE: u64 = 0x0010_0000_0000_0000;
    values.iter().fold(0, |probe, x| probe | ((x.to_bits() & EXPONENT) + EXPONENT_ONE))
}

/// Whether every value is finite (neither NaN nor infinite), in one pass without branches.
#[inline]
pub(crate) fn all_finite(values: &[f64]) -> bool {
    non_finite_probe(values) >> 63 == 0
}

/// The values of all variables of one instance.
///
/// Each base type has its own vector with one slot per variable, in the order of
/// [`storage_slots`] (the variables a step writes first), so access is a plain index: a model's
/// accessors name the variable, whose slot the compiler reads from a constant table, and the
/// runtime's gets and sets translate the value reference through the same table.
/// Models read parameters and inputs and write outputs through the typed accessors; the runtime
/// does every check (type, causality, phase, range, finiteness) before a master's value lands
/// here.
#[derive(Debug, Clone, PartialEq)]
pub struct Values<V> {
    reals: Vec<f64>,
    integers: Vec<i32>,
    booleans: Vec<bool>,
    strings: Vec<String>,
    marker: PhantomData<V>,
}

impl<V: VariableSet> Values<V> {
    /// All variables at their start values (zero, false or empty where the table has none).
    pub fn at_start() -> Self {
        let n = V::TABLE.len();
        debug_assert_eq!(V::SLOTS.len(), n, "one slot per variable");
        let mut values = Values {
            reals: vec![0.0; n],
            integers: vec![0; n],
            booleans: vec![false; n],
            strings: vec![String::new(); n],
            marker: PhantomData,
        };
        for (i, var) in V::TABLE.iter().enumerate() {
            let s = Self::slot_of(i);
            match var.kind {
                Kind::Real { start, .. } => values.reals[s] = start.unwrap_or(0.0),
                Kind::Integer { start, .. } => values.integers[s] = start.unwrap_or(0),
                Kind::Enumeration { start, .. } => values.integers[s] = start.unwrap_or(1),
                Kind::Boolean { start } => values.booleans[s] = start.unwrap_or(false),
                Kind::String { start } => values.strings[s] = start.unwrap_or("").to_string(),
            }
        }
        values
    }

    /// The storage slot of the variable with value reference `index`.
    #[inline]
    fn slot_of(index: usize) -> usize {
        V::SLOTS[index] as usize
    }

    /// The value reference of the variable stored in `slot`.
    fn index_of_slot(slot: usize) -> usize {
        V::SLOTS.iter().position(|&s| s as usize == slot).expect("every slot belongs to a variable")
    }

    #[inline]
    pub fn real(&self, var: V) -> f64 {
        self.reals[var.slot()]
    }

    #[inline]
    pub fn set_real(&mut self, var: V, value: f64) {
        debug_assert_eq!(var.var().base_type(), BaseType::Real, "{var:?} is not Real");
        self.reals[var.slot()] = value;
    }

    #[inline]
    pub fn integer(&self, var: V) -> i32 {
        self.integers[var.slot()]
    }

    #[inline]
    pub fn set_integer(&mut self, var: V, value: i32) {
        self.integers[var.slot()] = value;
    }

    #[inline]
    pub fn boolean(&self, var: V) -> bool {
        self.booleans[var.slot()]
    }

    #[inline]
    pub fn set_boolean(&mut self, var: V, value: bool) {
        self.booleans[var.slot()] = value;
    }

    pub fn string(&self, var: V) -> &str {
        &self.strings[var.slot()]
    }

    pub fn set_string(&mut self, var: V, value: impl Into<String>) {
        self.strings[var.slot()] = value.into();
    }

    /// Copies the numbers and booleans of `source`, without allocating: the runtime keeps a copy
    /// of the values before every step to undo a failed one. Strings are not copied: no step
    /// changes them (they are parameters, set between calls), and comparing them on every
    /// step would cost more than the step (the caller copies them when they change).
    pub(crate) fn copy_numbers_from(&mut self, source: &Self) {
        self.reals.copy_from_slice(&source.reals);
        self.integers.copy_from_slice(&source.integers);
        self.booleans.copy_from_slice(&source.booleans);
    }

    /// Copies the numbers and booleans a step may write (`written`) from `source`: one block
    /// per vector.
    #[inline]
    pub(crate) fn copy_written_from(&mut self, source: &Self, written: &WrittenIndices) {
        let n = written.count;
        self.reals[..n].copy_from_slice(&source.reals[..n]);
        if written.integers {
            self.integers[..n].copy_from_slice(&source.integers[..n]);
        }
        if written.booleans {
            self.booleans[..n].copy_from_slice(&source.booleans[..n]);
        }
    }

    /// The first (in table order) of the variables a step may write whose value is NaN or
    /// infinite, by value reference. The slots of written Integers and Booleans hold 0.0 in
    /// the Real vector, so they pass.
    #[inline]
    pub(crate) fn first_non_finite_written(&self, written: &WrittenIndices) -> Option<usize> {
        let written = &self.reals[..written.count];
        if all_finite(written) {
            return None;
        }
        // Written slots are in table order.
        written.iter().position(|x| !x.is_finite()).map(Self::index_of_slot)
    }

    /// The first Real variable (in table order) whose value is NaN or infinite, by value
    /// reference.
    pub(crate) fn first_non_finite_real(&self) -> Option<usize> {
        if all_finite(&self.reals) {
            return None;
        }
        (0..V::TABLE.len()).find(|&i| !self.real_at(i).is_finite())
    }

    /// The Real vector in storage order ([`storage_slots`]).
    #[inline]
    pub(crate) fn reals_by_slot(&self) -> &[f64] {
        &self.reals
    }

    // By value reference (the runtime's gets and sets, which have checked the reference).
    #[inline]
    pub(crate) fn real_at(&self, index: usize) -> f64 {
        self.reals[Self::slot_of(index)]
    }
    #[inline]
    pub(crate) fn real_at_mut(&mut self, index: usize) -> &mut f64 {
        &mut self.reals[Self::slot_of(index)]
    }
    pub(crate) fn integer_at(&self, index: usize) -> i32 {
        self.integers[Self::slot_of(index)]
    }
    pub(crate) fn integer_at_mut(&mut self, index: usize) -> &mut i32 {
        &mut self.integers[Self::slot_of(index)]
    }
    pub(crate) fn boolean_at(&self, index: usize) -> bool {
        self.booleans[Self::slot_of(index)]
    }
    pub(crate) fn boolean_at_mut(&mut self, index: usize) -> &mut bool {
        &mut self.booleans[Self::slot_of(index)]
    }
    pub(crate) fn string_at(&self, index: usize) -> &str {
        &self.strings[Self::slot_of(index)]
    }
    pub(crate) fn string_at_mut(&mut self, index: usize) -> &mut String {
        &mut self.strings[Self::slot_of(index)]
    }
}

/// The values as a state holds them: per base type, the values of that type's variables in
/// table order (the vectors of [`Values`] have a slot for every variable in each type).
#[derive(Serialize, Deserialize)]
struct SavedValues<'a> {
    reals: Vec<f64>,
    integers: Vec<i32>,
    booleans: Vec<bool>,
    #[serde(borrow)]
    strings: Vec<std::borrow::Cow<'a, str>>,
}

impl<V: VariableSet> Serialize for Values<V> {
    fn serialize<S: serde::Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        let of_type =
            |ty: BaseType| V::TABLE.iter().enumerate().filter(move |(_, v)| v.base_type() == ty).map(|(i, _)| i);
        SavedValues {
            reals: of_type(BaseType::Real).map(|i| self.real_at(i)).collect(),
            integers: of_type(BaseType::Integer).map(|i| self.integer_at(i)).collect(),
            booleans: of_type(BaseType::Boolean).map(|i| self.boolean_at(i)).collect(),
            strings: of_type(BaseType::String).map(|i| self.string_at(i).into()).collect(),
        }
        .serialize(serializer)
    }
}

impl<'de, V: VariableSet> Deserialize<'de> for Values<V> {
    /// Refuses lists whose lengths are not this table's counts of each type.
    fn deserialize<D: serde::Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        let saved = SavedValues::deserialize(deserializer)?;
        let mut values = Self::at_start();
        let mut reals = saved.reals.into_iter();
        let mut integers = saved.integers.into_iter();
        let mut booleans = saved.booleans.into_iter();
        let mut strings = saved.strings.into_iter();
        let missing = |var: &Var| serde::de::Error::custom(format!("no saved value for '{}'", var.name));
        for (i, var) in V::TABLE.iter().enumerate() {
            match var.base_type() {
                BaseType::Real => *values.real_at_mut(i) = reals.next().ok_or_else(|| missing(var))?,
                BaseType::Integer => *values.integer_at_mut(i) = integers.next().ok_or_else(|| missing(var))?,
                BaseType::Boolean => *values.boolean_at_mut(i) = booleans.next().ok_or_else(|| missing(var))?,
                BaseType::String => *values.string_at_mut(i) = strings.next().ok_or_else(|| missing(var))?.into_owned(),
            }
        }
        let extra = reals.len() + integers.len() + booleans.len() + strings.len();
        if extra > 0 {
            return Err(serde::de::Error::custom(format!("{extra} saved values more than the model has variables")));
        }
        Ok(values)
    }
}

/// Declares the variables of a model: an enum (one variant per variable, the value reference
/// being its position) and its [`VariableSet`] table.
///
/// ```
/// use fmu_runtime::Var;
///
/// fmu_runtime::declare_variables! {
///     pub enum PlantVar {
///         CurrentCommand = Var::real("motor.current_command", "A").input().start(0.0)
///             .description("Current command before the current loop."),
///     }
/// }
/// ```
#[macro_export]
macro_rules! declare_variables {
    (
        $(#[$enum_meta:meta])*
        $vis:vis enum $name:ident {
            $( $variant:ident = $decl:expr ),+ $(,)?
        }
    ) => {
        $(#[$enum_meta])*
        #[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
        #[repr(u32)]
        $vis enum $name {
            $( $variant ),+
        }

        impl $crate::variables::VariableSet for $name {
            const TABLE: &'static [$crate::variables::Var] = {
                #[allow(unused_imports)]
                use $crate::variables::Var;
                &[ $( $decl ),+ ]
            };

            const SLOTS: &'static [u16] = &$crate::variables::storage_slots::<{ [$(stringify!($variant)),+].len() }>(
                <Self as $crate::variables::VariableSet>::TABLE,
            );

            #[inline]
            fn index(self) -> usize {
                self as usize
            }

            fn from_index(index: usize) -> Option<Self> {
                const ALL: &[$name] = &[ $( $name::$variant ),+ ];
                ALL.get(index).copied()
            }
        }
    };
}

/// Whether a number is subnormal (nonzero and smaller in magnitude than the smallest normal
/// double, 2.2e-308). No physical quantity of these models is one: a master that sends 4.9e-324
/// means 0 or has a bug, and dividing by one overflows.
#[inline]
pub fn is_subnormal(value: f64) -> bool {
    value != 0.0 && value.abs() < f64::MIN_POSITIVE
}
