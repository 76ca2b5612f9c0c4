//! A bounded cache of discretised linear systems.
//!
//! The hybrid integrator needs the exact zero-order-hold matrices for every combination of
//! discrete mode, step length and parameter-grid cell it meets. Computing one costs a matrix
//! exponential (tens of microseconds), so they are kept; but a master that varies its step
//! size, or an event localisation that visits many dyadic lengths, must not make the cache
//! grow without limit. Two generations bound it: entries live in the young map; when it is
//! full it becomes the old map (the previous old map is dropped), and an old entry that is used
//! again moves back to the young map. At most `2 * capacity` entries are held, and the working
//! set of a steady simulation (a handful of modes at one step size) always stays resident.

use std::collections::HashMap;
use std::hash::{BuildHasherDefault, Hasher};
use std::sync::Arc;

/// What a discretisation depends on besides the plant's fixed parameters.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub(crate) struct DiscretisationKey {
    /// Bit set of the discrete mode: which bodies stick, which pinions are in the gap.
    pub mode: u32,
    /// Index of the parameter-grid cell.
    pub cell: i64,
    /// The step length's bit pattern; lengths are compared exactly.
    pub step_bits: u64,
}

/// A small multiplicative hasher: the keys are a few machine words, and the default SipHash
/// would cost more than the matrix-vector product the lookup serves.
#[derive(Default, Clone, Copy)]
pub(crate) struct WordHasher(u64);

impl Hasher for WordHasher {
    fn write(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.write_u64(u64::from(b));
        }
    }

    fn write_u64(&mut self, word: u64) {
        self.0 = (self.0.rotate_left(5) ^ word).wrapping_mul(0x51_7c_c1_b7_27_22_0a_95);
    }

    fn write_u32(&mut self, word: u32) {
        self.write_u64(u64::from(word));
    }

    fn write_i64(&mut self, word: i64) {
        self.write_u64(word as u64);
    }

    fn finish(&self) -> u64 {
        self.0
    }
}

type Map<V> = HashMap<DiscretisationKey, Arc<V>, BuildHasherDefault<WordHasher>>;

/// The two-generation bounded cache described in the module documentation.
#[derive(Debug, Clone)]
pub(crate) struct BoundedCache<V> {
    capacity: usize,
    young: Map<V>,
    old: Map<V>,
}

impl<V> BoundedCache<V> {
    pub fn new(capacity: usize) -> Self {
        Self { capacity: capacity.max(1), young: Map::default(), old: Map::default() }
    }

    /// The cached value for `key`, computing it with `make` on a miss.
    pub fn get_or_insert_with(&mut self, key: DiscretisationKey, make: impl FnOnce() -> V) -> Arc<V> {
        if let Some(value) = self.young.get(&key) {
            return Arc::clone(value);
        }
        let value = self.old.remove(&key).unwrap_or_else(|| Arc::new(make()));
        if self.young.len() >= self.capacity {
            self.old = std::mem::take(&mut self.young);
        }
        self.young.insert(key, Arc::clone(&value));
        value
    }

    /// Replaces (or inserts) the value for `key`.
    pub fn replace(&mut self, key: DiscretisationKey, value: Arc<V>) {
        self.old.remove(&key);
        if !self.young.contains_key(&key) && self.young.len() >= self.capacity {
            self.old = std::mem::take(&mut self.young);
        }
        self.young.insert(key, value);
    }

    /// Number of entries held in both generations.
    pub fn len(&self) -> usize {
        self.young.len() + self.old.len()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn key(step: f64) -> DiscretisationKey {
        DiscretisationKey { mode: 3, cell: -2, step_bits: step.to_bits() }
    }

    #[test]
    fn many_distinct_step_sizes_never_hold_more_than_twice_the_capacity() {
        let mut cache = BoundedCache::new(16);
        for i in 0..10_000 {
            cache.get_or_insert_with(key(1e-3 + i as f64 * 1e-9), || i);
            assert!(cache.len() <= 32, "cache holds {} entries", cache.len());
        }
    }

    #[test]
    fn an_entry_in_steady_use_survives_generation_turnover() {
        let mut cache = BoundedCache::new(4);
        let mut computed = 0;
        for i in 0..1000 {
            cache.get_or_insert_with(key(1e-3), || {
                computed += 1;
                0
            });
            cache.get_or_insert_with(key(2e-3 + i as f64 * 1e-9), || 1);
        }
        assert_eq!(computed, 1, "the steadily used entry was recomputed");
    }
}
