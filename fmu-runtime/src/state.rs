//! A small, versioned, portable byte format for FMU states.
//!
//! `fmi2SerializeFMUstate` must produce bytes that another instance (possibly another process
//! or machine) can read back. Everything is written little-endian with explicit lengths, so the
//! format does not depend on the platform, the Rust version or a serialisation crate's layout.
//! Models write their internal state with [`StateWriter`] and read it back with [`StateReader`]
//! in the same order; the runtime wraps it in a header that names the model and the format
//! version.

use std::fmt;

/// Why a byte string could not be read back as a state.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct StateError(pub String);

impl fmt::Display for StateError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for StateError {}

/// Appends values to a state buffer.
#[derive(Default, Debug, Clone)]
pub struct StateWriter {
    bytes: Vec<u8>,
}

impl StateWriter {
    pub fn new() -> Self {
        Self::default()
    }

    pub fn into_bytes(self) -> Vec<u8> {
        self.bytes
    }

    pub fn f64(&mut self, value: f64) {
        self.bytes.extend_from_slice(&value.to_bits().to_le_bytes());
    }

    pub fn u64(&mut self, value: u64) {
        self.bytes.extend_from_slice(&value.to_le_bytes());
    }

    pub fn u128(&mut self, value: u128) {
        self.bytes.extend_from_slice(&value.to_le_bytes());
    }

    pub fn i64(&mut self, value: i64) {
        self.bytes.extend_from_slice(&value.to_le_bytes());
    }

    pub fn bool(&mut self, value: bool) {
        self.bytes.push(u8::from(value));
    }

    pub fn u8(&mut self, value: u8) {
        self.bytes.push(value);
    }

    /// A length-prefixed run of raw bytes.
    pub fn bytes(&mut self, value: &[u8]) {
        self.u64(value.len() as u64);
        self.bytes.extend_from_slice(value);
    }

    pub fn str(&mut self, value: &str) {
        self.bytes(value.as_bytes());
    }

    /// A length-prefixed run of `f64`.
    pub fn f64s(&mut self, values: &[f64]) {
        self.u64(values.len() as u64);
        for &v in values {
            self.f64(v);
        }
    }
}

/// Reads values back in the order they were written; every read checks the length.
#[derive(Debug, Clone)]
pub struct StateReader<'a> {
    bytes: &'a [u8],
    position: usize,
}

impl<'a> StateReader<'a> {
    pub fn new(bytes: &'a [u8]) -> Self {
        Self { bytes, position: 0 }
    }

    /// Bytes not read yet; a complete read leaves none.
    pub fn remaining(&self) -> usize {
        self.bytes.len() - self.position
    }

    fn take(&mut self, n: usize) -> Result<&'a [u8], StateError> {
        if self.remaining() < n {
            return Err(StateError(format!(
                "state is truncated: needed {n} more bytes at offset {}, {} left",
                self.position,
                self.remaining()
            )));
        }
        let slice = &self.bytes[self.position..self.position + n];
        self.position += n;
        Ok(slice)
    }

    fn array<const N: usize>(&mut self) -> Result<[u8; N], StateError> {
        let mut out = [0u8; N];
        out.copy_from_slice(self.take(N)?);
        Ok(out)
    }

    pub fn f64(&mut self) -> Result<f64, StateError> {
        Ok(f64::from_bits(u64::from_le_bytes(self.array()?)))
    }

    pub fn u64(&mut self) -> Result<u64, StateError> {
        Ok(u64::from_le_bytes(self.array()?))
    }

    pub fn u128(&mut self) -> Result<u128, StateError> {
        Ok(u128::from_le_bytes(self.array()?))
    }

    pub fn i64(&mut self) -> Result<i64, StateError> {
        Ok(i64::from_le_bytes(self.array()?))
    }

    pub fn u8(&mut self) -> Result<u8, StateError> {
        Ok(self.take(1)?[0])
    }

    pub fn bool(&mut self) -> Result<bool, StateError> {
        match self.u8()? {
            0 => Ok(false),
            1 => Ok(true),
            other => Err(StateError(format!("invalid boolean byte {other} at offset {}", self.position - 1))),
        }
    }

    /// A length-prefixed run of bytes; the length is checked against what is left before
    /// anything is allocated, so a corrupt length cannot exhaust memory.
    pub fn bytes(&mut self) -> Result<&'a [u8], StateError> {
        let n = self.u64()?;
        let n = usize::try_from(n).map_err(|_| StateError(format!("length {n} does not fit in memory")))?;
        self.take(n)
    }

    pub fn str(&mut self) -> Result<String, StateError> {
        let raw = self.bytes()?;
        String::from_utf8(raw.to_vec()).map_err(|_| StateError("string in state is not UTF-8".into()))
    }

    /// A length-prefixed run of `f64`, which must have exactly `expected` elements when given.
    pub fn f64s(&mut self, expected: Option<usize>) -> Result<Vec<f64>, StateError> {
        let n = self.u64()? as usize;
        if let Some(e) = expected {
            if n != e {
                return Err(StateError(format!("expected {e} values, state has {n}")));
            }
        }
        if n.saturating_mul(8) > self.remaining() {
            return Err(StateError(format!("state claims {n} values but only {} bytes are left", self.remaining())));
        }
        (0..n).map(|_| self.f64()).collect()
    }

    /// Fails unless every byte was consumed: trailing bytes mean the writer and reader disagree.
    pub fn finish(&self) -> Result<(), StateError> {
        if self.remaining() == 0 {
            Ok(())
        } else {
            Err(StateError(format!("{} unexpected trailing bytes in state", self.remaining())))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn values_read_back_in_the_order_written() {
        let mut w = StateWriter::new();
        w.f64(-1.5);
        w.u64(42);
        w.bool(true);
        w.str("az");
        w.f64s(&[1.0, f64::NAN]);
        w.u128(1 << 100);
        let bytes = w.into_bytes();
        let mut r = StateReader::new(&bytes);
        assert_eq!(r.f64().unwrap(), -1.5);
        assert_eq!(r.u64().unwrap(), 42);
        assert!(r.bool().unwrap());
        assert_eq!(r.str().unwrap(), "az");
        let v = r.f64s(Some(2)).unwrap();
        assert_eq!(v[0], 1.0);
        assert!(v[1].is_nan());
        assert_eq!(r.u128().unwrap(), 1 << 100);
        r.finish().unwrap();
    }

    #[test]
    fn truncated_or_corrupt_states_are_errors_not_panics() {
        let mut w = StateWriter::new();
        w.f64s(&[1.0, 2.0, 3.0]);
        let bytes = w.into_bytes();
        for cut in 0..bytes.len() {
            assert!(StateReader::new(&bytes[..cut]).f64s(None).is_err());
        }
        let huge = u64::MAX.to_le_bytes();
        assert!(StateReader::new(&huge).bytes().is_err());
        assert!(StateReader::new(&huge).f64s(None).is_err());
    }
}
