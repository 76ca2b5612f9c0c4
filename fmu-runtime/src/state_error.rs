//! Why bytes could not be read back as an FMU state: the error both the state format and the
//! models' own `load_state` report.

/// Why bytes could not be read back as a state of this model.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
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
}
