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
//! The last eight bytes are a checksum of all bytes before them (64-bit FNV-1a, little-endian),
//! so that a damaged state (a flipped bit, a truncated file) is refused before any of it is
//! believed. Reading checks the tag and the format version first (so that a state of another
//! version is named as such), then the checksum, then the model (identifier and GUID), so a
//! state of another FMU is refused with the reason; then every value: the header's times and
//! phase, every variable's finiteness and declared range, and every floating-point number of
//! the model's own part (all must be finite). Truncated or corrupt bytes are an error, never a
//! panic; a length read from corrupt bytes fails when the bytes run out (serde allocates at
//! most about a megabyte ahead for it). docs/fmu-robustness.md describes the format.

use serde::de::DeserializeOwned;
use serde::{Deserialize, Serialize};

use crate::model::Model;
use crate::phase::Phase;
use crate::state_error::HeaderError;
pub use crate::state_error::StateError;
use crate::variables::Values;

/// The first bytes of every state of this project.
pub const STATE_TAG: [u8; 8] = *b"MKATSTAT";

/// The version of the state layout; a state of another version is refused. Version 1 was the
/// hand-written field-by-field format before the states became serde types; version 2 had no
/// checksum.
pub const STATE_FORMAT_VERSION: u32 = 3;

/// Bytes of the checksum at the end of a state.
const CHECKSUM_BYTES: usize = 8;

/// The 64-bit FNV-1a hash of `bytes`: the states' checksum. Written here rather than taken from
/// a crate because it is six lines and every FMU links it. It detects every change of a single
/// byte (each step is a bijection of the running hash, so two inputs that differ in one byte
/// never meet again) and other damage with a probability of about 1 - 2^-64; it is a check
/// against accidents, not against forgery, which an FMU state need not resist: every value is
/// checked on its own as well.
pub fn fnv1a64(bytes: &[u8]) -> u64 {
    let mut hash: u64 = 0xcbf2_9ce4_8422_2325;
    for &b in bytes {
        hash ^= u64::from(b);
        hash = hash.wrapping_mul(0x0000_0100_0000_01b3);
    }
    hash
}

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
    let mut bytes = postcard::to_allocvec(&(tag, header, values, model)).map_err(StateError::Encode)?;
    let checksum = fnv1a64(&bytes);
    bytes.extend_from_slice(&checksum.to_le_bytes());
    Ok(bytes)
}

/// Reads a state of model `M` whose identifier and GUID are given, part by part, so that the
/// first part that does not fit names the reason.
pub(crate) fn decode<M: Model>(bytes: &[u8], identifier: &str, guid: &str) -> Result<InstanceState<M>, StateError> {
    if !bytes.starts_with(&STATE_TAG) {
        return Err(StateError::NotAState);
    }
    let (tag, _) = take::<FormatTag>(bytes, "format tag")?;
    if tag.version != STATE_FORMAT_VERSION {
        return Err(StateError::Version { found: tag.version, supported: STATE_FORMAT_VERSION });
    }
    let Some(split) = bytes.len().checked_sub(CHECKSUM_BYTES) else { return Err(StateError::NotAState) };
    let (body, stored) = bytes.split_at(split);
    let stored = u64::from_le_bytes(stored.try_into().expect("eight bytes"));
    let computed = fnv1a64(body);
    if stored != computed {
        return Err(StateError::Checksum { stored, computed });
    }
    let (_, rest) = take::<FormatTag>(body, "format tag")?;
    let (header, rest) = take::<StateHeader>(rest, "header")?;
    if header.model_identifier != identifier || header.guid != guid {
        return Err(StateError::OtherModel {
            found_identifier: header.model_identifier,
            found_guid: header.guid,
            identifier: identifier.to_string(),
            guid: guid.to_string(),
        });
    }
    check_header(&header)?;
    let (values, rest) = take::<Values<M::Var>>(rest, "variable values")?;
    crate::checks::check_values::<M::Var>(&values)?;
    let (model, rest) = take::<M::State>(rest, "model state")?;
    if !rest.is_empty() {
        return Err(StateError::TrailingBytes(rest.len()));
    }
    crate::checks::check_finite_numbers(&model).map_err(StateError::ModelNumbers)?;
    Ok(InstanceState { header, values, model })
}

/// The header's values: finite times in order (start, last successful, now, stop) and a phase
/// a state can be taken in.
fn check_header(header: &StateHeader) -> Result<(), StateError> {
    let invalid = |why: HeaderError| Err(StateError::Header(why));
    let times = [
        ("time", header.time),
        ("start_time", header.start_time),
        ("last_successful_time", header.last_successful_time),
    ];
    for (name, value) in times.into_iter().chain(header.stop_time.map(|t| ("stop_time", t))) {
        if !value.is_finite() {
            return invalid(HeaderError::NotFinite { name, value });
        }
    }
    // The same relative tolerance as the communication points (exports::TIME_TOLERANCE).
    let slack = |t: f64| 1e-9 * t.abs().max(1.0);
    if header.time < header.start_time - slack(header.start_time) {
        return invalid(HeaderError::BeforeStart { time: header.time, start: header.start_time });
    }
    if let Some(stop) = header.stop_time {
        if stop < header.start_time || header.time > stop + slack(stop) {
            return invalid(HeaderError::OutOfOrder { start: header.start_time, time: header.time, stop });
        }
    }
    if header.phase == Phase::Fatal {
        return invalid(HeaderError::FatalPhase);
    }
    Ok(())
}

fn take<'a, T: DeserializeOwned>(bytes: &'a [u8], part: &'static str) -> Result<(T, &'a [u8]), StateError> {
    postcard::take_from_bytes(bytes).map_err(|cause| StateError::Corrupt { part, cause })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn header(time: f64, start_time: f64, stop_time: Option<f64>, phase: Phase) -> StateHeader {
        StateHeader {
            model_identifier: "m".into(),
            guid: "{g}".into(),
            phase,
            time,
            start_time,
            stop_time,
            last_successful_time: time,
            needs_initialize: false,
        }
    }

    #[test]
    fn a_header_no_run_could_have_written_is_refused_with_the_reason() {
        let step = Phase::StepComplete;
        assert!(check_header(&header(1.0, 0.0, Some(2.0), step)).is_ok());
        let refused = |h| match check_header(&h) {
            Err(StateError::Header(why)) => why,
            other => panic!("{other:?}"),
        };
        assert_eq!(refused(header(f64::NAN, 0.0, None, step)).to_string(), "time = NaN is not finite");
        assert_eq!(refused(header(-1.0, 0.0, None, step)), HeaderError::BeforeStart { time: -1.0, start: 0.0 });
        assert_eq!(
            refused(header(3.0, 0.0, Some(2.0), step)),
            HeaderError::OutOfOrder { start: 0.0, time: 3.0, stop: 2.0 }
        );
        assert_eq!(refused(header(1.0, 0.0, None, Phase::Fatal)), HeaderError::FatalPhase);
    }
}
