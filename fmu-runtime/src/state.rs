//! FMU states: what fmi2GetFMUstate keeps and fmi2SerializeFMUstate hands out.
//!
//! A state is a format tag, a [`StateHeader`] that names the model (identifier and GUID) and
//! holds the instance's phase and times, the variable values and the model's own
//! [`Model::State`]. Each part is a serde type, so what is written and what is read back are
//! one declaration and cannot disagree. The bytes are postcard's encoding, which its
//! specification fixes independently of the machine and the Rust version: integers as
//! little-endian varints, floating-point numbers as their little-endian IEEE 754 bits (they
//! come back bit for bit), sequences and strings with their length first. Another instance,
//! process or machine reads them back.
//!
//! Reading checks the tag, the format version and the model before the rest, so a state of
//! another FMU or of another version is refused with the reason; truncated or corrupt bytes are
//! an error, never a panic; a length read from corrupt bytes fails when the bytes run out (serde
//! allocates at most about a megabyte ahead for it).

use serde::de::DeserializeOwned;
use serde::{Deserialize, Serialize};

use crate::model::Model;
use crate::phase::Phase;
pub use crate::state_error::StateError;
use crate::variables::Values;

/// The first bytes of every state of this project.
pub const STATE_TAG: [u8; 8] = *b"MKATSTAT";

/// The version of the state layout; a state of another version is refused. Version 1 was the
/// hand-written field-by-field format before the states became serde types.
pub const STATE_FORMAT_VERSION: u32 = 2;

/// What a state says about the instance around the model.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct StateHeader {
    pub model_identifier: String,
    pub guid: String,
    pub phase: Phase,
    pub time: f64,
    pub start_time: f64,
    pub stop_time: Option<f64>,
    pub last_successful_time: f64,
    pub needs_initialize: bool,
}

/// The tag and version, read before anything else.
#[derive(Serialize, Deserialize)]
struct FormatTag {
    tag: [u8; 8],
    version: u32,
}

/// A whole saved instance of model `M`: what the runtime writes and reads, and what a tool can
/// decode, edit and encode again (the validate tool starts its windows from edited plant
/// states).
pub struct InstanceState<M: Model> {
    pub header: StateHeader,
    pub values: Values<M::Var>,
    pub model: M::State,
}

impl<M: Model> Clone for InstanceState<M>
where
    M::State: Clone,
{
    fn clone(&self) -> Self {
        InstanceState { header: self.header.clone(), values: self.values.clone(), model: self.model.clone() }
    }
}

impl<M: Model> InstanceState<M> {
    /// The state's bytes.
    pub fn encode(&self) -> Result<Vec<u8>, StateError> {
        encode::<M>(&self.header, &self.values, &self.model)
    }

    /// Reads bytes written for model `M` (by any instance of it).
    pub fn decode(bytes: &[u8]) -> Result<Self, StateError> {
        decode::<M>(bytes, M::info().model_identifier, &crate::xml::guid::<M>())
    }
}

/// Writes a state from its parts, borrowed.
pub(crate) fn encode<M: Model>(
    header: &StateHeader,
    values: &Values<M::Var>,
    model: &M::State,
) -> Result<Vec<u8>, StateError> {
    let tag = FormatTag { tag: STATE_TAG, version: STATE_FORMAT_VERSION };
    postcard::to_allocvec(&(tag, header, values, model)).map_err(StateError::Encode)
}

/// Reads a state of model `M` whose identifier and GUID are given, part by part, so that the
/// first part that does not fit names the reason.
pub(crate) fn decode<M: Model>(bytes: &[u8], identifier: &str, guid: &str) -> Result<InstanceState<M>, StateError> {
    if !bytes.starts_with(&STATE_TAG) {
        return Err(StateError::NotAState);
    }
    let (tag, rest) = take::<FormatTag>(bytes, "format tag")?;
    if tag.version != STATE_FORMAT_VERSION {
        return Err(StateError::Version { found: tag.version, supported: STATE_FORMAT_VERSION });
    }
    let (header, rest) = take::<StateHeader>(rest, "header")?;
    if header.model_identifier != identifier || header.guid != guid {
        return Err(StateError::OtherModel {
            found_identifier: header.model_identifier,
            found_guid: header.guid,
            identifier: identifier.to_string(),
            guid: guid.to_string(),
        });
    }
    let (values, rest) = take::<Values<M::Var>>(rest, "variable values")?;
    let (model, rest) = take::<M::State>(rest, "model state")?;
    if !rest.is_empty() {
        return Err(StateError::TrailingBytes(rest.len()));
    }
    Ok(InstanceState { header, values, model })
}

fn take<'a, T: DeserializeOwned>(bytes: &'a [u8], part: &'static str) -> Result<(T, &'a [u8]), StateError> {
    postcard::take_from_bytes(bytes).map_err(|cause| StateError::Corrupt { part, cause })
}
