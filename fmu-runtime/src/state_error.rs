//! Why bytes could not be read back as an FMU state: the error both the state format and the
//! models' own `load_state` report.

use std::sync::Arc;

use crate::checks::{CheckError, NumberError};

/// Why bytes could not be read back as a state of this model.
#[derive(Debug, Clone, thiserror::Error)]
pub enum StateError {
    #[error("not an FMU state of this project (its first bytes are not the state tag)")]
    NotAState,
    #[error("state format version {found} is not supported (this FMU reads version {supported})")]
    Version { found: u32, supported: u32 },
    #[error("state belongs to model '{found_identifier}' {found_guid}, not to '{identifier}' {guid}")]
    OtherModel { found_identifier: String, found_guid: String, identifier: String, guid: String },
    #[error("state is damaged: its checksum is {stored:#018x}, its bytes give {computed:#018x}")]
    Checksum { stored: u64, computed: u64 },
    #[error("state is truncated or corrupt in its {part}: {cause}")]
    Corrupt { part: &'static str, cause: postcard::Error },
    #[error("{0} unexpected trailing bytes in state")]
    TrailingBytes(usize),
    #[error("state could not be written: {0}")]
    Encode(postcard::Error),
    /// The header decoded, but its times or its phase are not those of a state.
    #[error("state header: {0}")]
    Header(HeaderError),
    /// The state holds a part of another size than this instance's parameters give it (a
    /// filter's order, a drive's number of states or paths).
    #[error("the state and the parameters disagree about the {part}: {in_state} in the state, {expected} for these parameters")]
    Size { part: &'static str, in_state: usize, expected: usize },
    /// The state holds a part this instance's parameters leave out, or lacks one they ask for.
    #[error("the state and the parameters disagree about {part}")]
    Parts { part: &'static str },
    /// A drive path's part that the state and the parameters disagree about.
    #[error("path {path}: the state and the parameters disagree about {part}")]
    PathParts { path: usize, part: &'static str },
    /// A controller's sample clock that no run could have left.
    #[error("controller sample clock: {0}")]
    SampleClock(SampleClockError),
    /// The variable values decoded, but one is not finite or not what a master could set.
    #[error(transparent)]
    Values(#[from] CheckError),
    /// The model's part decoded, but holds a number that is not finite.
    #[error("model state: {0}")]
    ModelNumbers(NumberError),
    /// The model refused to be built from the restored values, or refused its restored part
    /// (its own error).
    #[error(transparent)]
    Model(Arc<dyn std::error::Error + Send + Sync + 'static>),
}

/// Why a state's header is not one a run could have written.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum HeaderError {
    #[error("{name} = {value} is not finite")]
    NotFinite { name: &'static str, value: f64 },
    #[error("time {time} is before the start time {start}")]
    BeforeStart { time: f64, start: f64 },
    #[error("the times are out of order (start {start}, now {time}, stop {stop})")]
    OutOfOrder { start: f64, time: f64, stop: f64 },
    #[error("a state cannot be taken in the Fatal phase")]
    FatalPhase,
}

/// Why a controller's saved sample clock is not one a run could have left.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SampleClockError {
    #[error("the clock starts at {0} s")]
    StartNotFinite(f64),
    #[error("the state holds pending outputs of samples not yet executed")]
    PendingAhead,
    #[error("the state holds {pending} pending outputs, more than the delay's {allowed}")]
    TooManyPending { pending: usize, allowed: usize },
}

impl StateError {
    /// A model's own error met while restoring a state ([`StateError::Model`]).
    pub fn model(error: impl std::error::Error + Send + Sync + 'static) -> StateError {
        StateError::Model(Arc::new(error))
    }
}
