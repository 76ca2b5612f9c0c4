//! How a model's seed parameter becomes a random generator's key, the same in every model, so
//! that the stochastic parts (wind gusts, sensor noise) are reproducible from a seed and two
//! models never depend on each other for it.

/// The 32-byte ChaCha key for a `u64` seed.
///
/// Four successive outputs of SplitMix64 (Steele, Lea and Flood 2014) started at `seed`,
/// each written little-endian: a fixed, documented expansion that does not depend on any
/// crate's `seed_from_u64`, and maps distinct seeds to unrelated keys.
pub fn seed_key(seed: u64) -> [u8; 32] {
    let mut state = seed;
    let mut key = [0u8; 32];
    for chunk in key.chunks_exact_mut(8) {
        state = state.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = state;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^= z >> 31;
        chunk.copy_from_slice(&z.to_le_bytes());
    }
    key
}

/// The `u64` seed for an FMI `Integer` seed parameter: its two's-complement bits, zero-extended
/// (so -1 becomes 4294967295, and every `i32` gives a distinct seed).
pub fn seed_from_fmi_integer(seed: i32) -> u64 {
    u64::from(seed as u32)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn seed_keys_differ_for_neighbouring_seeds_and_fmi_integers_map_one_to_one() {
        assert_ne!(seed_key(0), seed_key(1));
        assert_eq!(seed_from_fmi_integer(-1), u64::from(u32::MAX));
        assert_ne!(seed_from_fmi_integer(-1), seed_from_fmi_integer(1));
    }
}
