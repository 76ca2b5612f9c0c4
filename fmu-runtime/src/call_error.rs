//! Why an `fmi2*` call was refused: the errors of the exported functions' bodies, whose
//! `Display` text the runtime logs with `fmi2Error` ("fmi2DoStep: ..."). Each says what was
//! wrong with the call and, where there is one, what to do instead.

use crate::instance::InstanceError;
use crate::phase::{Phase, LOG_CATEGORIES};
use crate::state_error::StateError;

/// An argument of a call that breaks the FMI 2.0 calling convention.
#[derive(Debug, thiserror::Error)]
pub enum ArgumentError {
    #[error("{what} is NULL but {n} elements were announced")]
    NullArray { what: &'static str, n: usize },
    #[error("{what} is NULL")]
    NullString { what: String },
    #[error("{what} is not valid UTF-8")]
    NotUtf8 { what: String },
    #[error("{what} = {value} is not an fmi2Boolean: only fmi2False (0) and fmi2True (1) are accepted")]
    NotBoolean { what: String, value: i32 },
}

/// Why the resource location given to fmi2Instantiate is not a folder this library can use.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum UriError {
    #[error("resource location '{uri}' is not a local file URI")]
    NotAFileUri { uri: String },
    #[error("resource location '{uri}' has a malformed percent escape")]
    MalformedEscape { uri: String },
    #[error("resource location '{uri}' is not UTF-8 once decoded")]
    NotUtf8 { uri: String },
}

/// Why fmi2Instantiate returned NULL (logged as "fmi2Instantiate: ...").
#[derive(Debug, thiserror::Error)]
pub enum InstantiateError {
    #[error("instanceName is empty")]
    EmptyName,
    #[error("fmuType {0} requested, but this FMU supports co-simulation (fmi2CoSimulation = 1) only")]
    NotCoSimulation(i32),
    #[error("GUID {guid} does not match this binary's model description(s) ({}); the modelDescription.xml and the binary come from different builds", .known.join("; "))]
    UnknownGuid { guid: String, known: Vec<String> },
    #[error(transparent)]
    Argument(#[from] ArgumentError),
    #[error(transparent)]
    Uri(#[from] UriError),
    #[error(transparent)]
    Instance(#[from] InstanceError),
}

/// Why `fmi2DoStep` refused its arguments before anything changed.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
pub enum StepError {
    #[error("communicationStepSize must be positive and finite, got {step}")]
    StepNotPositive { step: f64 },
    /// The step is longer than `max` ([`crate::exports::MAX_STEP_SIZE`]).
    #[error("communicationStepSize {step} s is longer than the longest step this FMU takes, {max} s (one day): a step is computed in pieces of about a millisecond, so a longer one would keep the call busy for minutes or for ever; take several steps")]
    StepTooLong { step: f64, max: f64 },
    #[error("currentCommunicationPoint {current} is not finite")]
    PointNotFinite { current: f64 },
    #[error("currentCommunicationPoint {current} is not where the instance is ({time}); steps must be contiguous (use fmi2SetFMUstate to go back)")]
    NotContiguous { current: f64, time: f64 },
    #[error(
        "the step from {current} by {step} s ends at {end}, after the stopTime {stop} given in fmi2SetupExperiment"
    )]
    AfterStopTime { current: f64, step: f64, end: f64, stop: f64 },
}

/// Why the body of an exported function that takes an instance failed.
#[derive(Debug, thiserror::Error)]
pub enum CallError {
    #[error(transparent)]
    Argument(#[from] ArgumentError),
    #[error(transparent)]
    Instance(#[from] InstanceError),
    #[error(transparent)]
    Step(#[from] StepError),
    /// Taking or restoring an FMU state failed.
    #[error(transparent)]
    State(#[from] StateError),
    /// Bytes given to fmi2DeSerializeFMUstate are not a state of this model.
    #[error("serialized state rejected: {0}")]
    StateRejected(StateError),
    #[error("values cannot be set in phase {}", .0.name())]
    NotSettableIn(Phase),
    #[error("unknown log category '{name}' (known: {})", LOG_CATEGORIES.iter().map(|(n, _)| *n).collect::<Vec<_>>().join(", "))]
    UnknownCategory { name: String },
    #[error("startTime {start} is not finite")]
    StartNotFinite { start: f64 },
    #[error("stopTime {stop} must be finite and not before startTime {start}")]
    BadStopTime { start: f64, stop: f64 },
    #[error("FMUstate is NULL")]
    NullState,
    #[error("FMUstate does not point to a state of this FMU")]
    ForeignState,
    #[error("FMUstate pointer is NULL")]
    NullStatePointer,
    #[error("size is NULL")]
    NullSize,
    /// A status function's output pointer is NULL.
    #[error("value is NULL")]
    NullValue,
    #[error("buffer has {size} bytes, the state needs exactly {needed} (fmi2SerializedFMUstateSize)")]
    BufferSize { size: usize, needed: usize },
}
