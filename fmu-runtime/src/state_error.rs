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
    /// The bytes decoded, but do not fit the model (a length, a mode or a parameter disagrees).
    #[error("{0}")]
    Invalid(String),
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

impl StateError {
    /// A model's own error met while restoring a state ([`StateError::Model`]).
    pub fn model(error: impl std::error::Error + Send + Sync + 'static) -> StateError {
        StateError::Model(Arc::new(error))
    }
}
