//! Points of the unit cube, one per sample, by plain random sampling, a Latin hypercube, a
//! scrambled Sobol sequence or a grid. Every point is a pure function of (method, seed, number
//! of samples, sample index, dimension): no generator state is carried from one sample to the
//! next, so a sample's values do not depend on which thread, batch or machine drew it, nor on
//! the order the samples were run in.

use std::sync::OnceLock;

use super::joe_kuo::DIRECTIONS;

/// How the samples spread over the ranges.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Method {
    /// Latin hypercube: each parameter's range cut into N equal strata, each stratum hit once,
    /// the strata of the parameters paired at random.
    Lhs,
    /// A Sobol sequence (Joe-Kuo direction numbers) with Owen's nested scrambling: converges
    /// faster than random sampling for smooth figures; best with N a power of two.
    Sobol,
    /// Independent uniform draws.
    Random,
    /// A regular grid over one or two parameters, `samples` points per axis, ends included.
    Grid,
}

impl Method {
    /// The name on the command line.
    pub fn name(self) -> &'static str {
        match self {
            Method::Lhs => "lhs",
            Method::Sobol => "sobol",
            Method::Random => "random",
            Method::Grid => "grid",
        }
    }
}

/// Why a point cannot be drawn.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum SamplingError {
    #[error("a grid spans one or two parameters, not {0} (choose them with --vary)")]
    GridDimensions(usize),
    #[error("the Sobol sequence has direction numbers for {max} parameters, not {0}", max = MAX_SOBOL_DIMENSIONS)]
    SobolDimensions(usize),
    #[error("the Sobol sequence is defined for at most 2^32 samples")]
    SobolLength,
    #[error("a sweep needs at least one sample")]
    NoSamples,
}

/// Dimensions the compiled-in Sobol direction numbers cover.
pub const MAX_SOBOL_DIMENSIONS: usize = DIRECTIONS.len() + 1;

/// A sampling plan: the method, its seed, and its size.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Plan {
    pub method: Method,
    pub seed: u64,
    /// Samples drawn (for a grid: points per axis).
    pub samples: u64,
    pub dimensions: usize,
}

impl Plan {
    /// Checks that the plan can be drawn.
    pub fn new(method: Method, seed: u64, samples: u64, dimensions: usize) -> Result<Plan, SamplingError> {
        if samples == 0 {
            return Err(SamplingError::NoSamples);
        }
        match method {
            Method::Grid if !(1..=2).contains(&dimensions) => return Err(SamplingError::GridDimensions(dimensions)),
            Method::Sobol if dimensions > MAX_SOBOL_DIMENSIONS => {
                return Err(SamplingError::SobolDimensions(dimensions))
            }
            Method::Sobol if samples > 1 << 32 => return Err(SamplingError::SobolLength),
            _ => {}
        }
        Ok(Plan { method, seed, samples, dimensions })
    }

    /// How many points the plan has (a grid: points per axis to the power of its dimensions).
    pub fn len(&self) -> u64 {
        match self.method {
            Method::Grid => self.samples.pow(self.dimensions as u32),
            _ => self.samples,
        }
    }

    /// Whether the plan has no points (never, once built).
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The point of sample `index`, each coordinate in [0, 1].
    pub fn point(&self, index: u64) -> Vec<f64> {
        (0..self.dimensions).map(|d| self.coordinate(index, d)).collect()
    }

    fn coordinate(&self, index: u64, dimension: usize) -> f64 {
        let d = dimension as u64;
        match self.method {
            Method::Random => uniform(&[self.seed, RANDOM, index, d]),
            Method::Lhs => {
                let stratum = permute(index, self.samples, &[self.seed, LHS_PERMUTATION, d]);
                (stratum as f64 + uniform(&[self.seed, LHS_JITTER, index, d])) / self.samples as f64
            }
            Method::Sobol => {
                let bits = sobol_bits(index as u32, dimension);
                let scrambled = owen_scramble(bits, hash(&[self.seed, SOBOL_SCRAMBLE, d]) as u32);
                // The low bits below the sequence's 32 are filled at random, so values never
                // repeat on a 2^-32 lattice.
                (scrambled as f64 + uniform(&[self.seed, SOBOL_FRACTION, index, d])) / 4_294_967_296.0
            }
            Method::Grid => {
                let axis = (index / self.samples.pow(dimension as u32)) % self.samples;
                if self.samples == 1 {
                    0.5
                } else {
                    axis as f64 / (self.samples - 1) as f64
                }
            }
        }
    }
}

// Domain separators: each use of the counter-based generator hashes its own constant, so the
// streams never overlap.
const RANDOM: u64 = 0x5241_4e44;
const LHS_PERMUTATION: u64 = 0x4c48_5350;
const LHS_JITTER: u64 = 0x4c48_534a;
const SOBOL_SCRAMBLE: u64 = 0x534f_4253;
const SOBOL_FRACTION: u64 = 0x534f_4246;

/// SplitMix64's finaliser (Steele, Lea and Flood 2014): a bijection of u64 whose output bits
/// each depend on every input bit.
fn mix(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// A counter-based random number: the hash of a tuple of words.
fn hash(words: &[u64]) -> u64 {
    words.iter().fold(0x9E37_79B9_7F4A_7C15, |h, &w| mix(h ^ mix(w.wrapping_add(0x9E37_79B9_7F4A_7C15))))
}

/// A uniform number in [0, 1) from the hash of a tuple, 53 random bits.
fn uniform(words: &[u64]) -> f64 {
    (hash(words) >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
}

/// A pseudo-random permutation of `0..n` evaluated at `index`, without storing it: a four-round
/// Feistel network on the smallest even number of bits that holds `n`, walked along its cycle
/// until the value falls below `n` (Black and Rogaway 2002). Memory is constant at any `n`.
fn permute(index: u64, n: u64, key: &[u64]) -> u64 {
    let bits = (64 - (n.max(2) - 1).leading_zeros()).max(2);
    let half = bits.div_ceil(2);
    let mask = (1u64 << half) - 1;
    let mut value = index;
    loop {
        let (mut left, mut right) = (value >> half, value & mask);
        for round in 0..4u64 {
            let f = hash(&[key[0], key[1], key[2], round, right]) & mask;
            (left, right) = (right, left ^ f);
        }
        value = (left << half) | right;
        if value < n {
            return value;
        }
    }
}

/// The direction integers of every dimension, 32 bits each (Joe and Kuo's recurrence).
fn directions() -> &'static Vec<[u32; 32]> {
    static TABLE: OnceLock<Vec<[u32; 32]>> = OnceLock::new();
    TABLE.get_or_init(|| {
        let mut table = vec![std::array::from_fn(|k| 1u32 << (31 - k))];
        for &(s, a, m) in DIRECTIONS.iter() {
            let s = s as usize;
            let mut v = [0u32; 32];
            for k in 0..32 {
                v[k] = if k < s {
                    m[k] << (31 - k)
                } else {
                    let mut x = v[k - s] ^ (v[k - s] >> s);
                    for l in 1..s {
                        if (a >> (s - 1 - l)) & 1 == 1 {
                            x ^= v[k - l];
                        }
                    }
                    x
                };
            }
            table.push(v);
        }
        table
    })
}

/// The unscrambled Sobol point `index` in `dimension`, as 32 bits of a binary fraction: the
/// XOR of the direction integers picked by the Gray code of the index.
fn sobol_bits(index: u32, dimension: usize) -> u32 {
    let v = &directions()[dimension];
    let gray = index ^ (index >> 1);
    (0..32).filter(|k| gray >> k & 1 == 1).fold(0, |x, k| x ^ v[k])
}

/// Owen's nested uniform scrambling of a 32-bit fraction by Laine and Karras's hash on the
/// bit-reversed value, with Burley's (2020) constants: each bit flips depending on the bits
/// above it only, so the net properties of the sequence survive.
fn owen_scramble(x: u32, seed: u32) -> u32 {
    let mut v = x.reverse_bits().wrapping_add(seed);
    v ^= v.wrapping_mul(0x6c50_b47c);
    v ^= v.wrapping_mul(0xb82f_1e52);
    v ^= v.wrapping_mul(0xc7af_e638);
    v ^= v.wrapping_mul(0x8d22_f6e6);
    v.reverse_bits()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_sobol_sequence_starts_as_joe_and_kuo_publish_it() {
        // Joe and Kuo's own example output (new-joe-kuo-6.21201, first points, dimensions 1-3).
        let expected =
            [[0.0, 0.0, 0.0], [0.5, 0.5, 0.5], [0.75, 0.25, 0.25], [0.25, 0.75, 0.75], [0.375, 0.375, 0.625]];
        for (i, row) in expected.iter().enumerate() {
            for (d, &x) in row.iter().enumerate() {
                assert_eq!(sobol_bits(i as u32, d) as f64 / 4_294_967_296.0, x, "point {i}, dimension {d}");
            }
        }
    }

    #[test]
    fn scrambled_sobol_points_are_stratified_in_every_dimension() {
        let plan = Plan::new(Method::Sobol, 7, 64, 40).unwrap();
        for d in 0..40 {
            let mut hits = [0; 64];
            for i in 0..64 {
                hits[(plan.point(i)[d] * 64.0) as usize] += 1;
            }
            assert!(hits.iter().all(|&h| h == 1), "dimension {d}: {hits:?}");
        }
    }

    #[test]
    fn a_latin_hypercube_hits_every_stratum_once_per_parameter() {
        for n in [1, 2, 7, 100, 1000] {
            let plan = Plan::new(Method::Lhs, 3, n, 5).unwrap();
            for d in 0..5 {
                let mut hits = vec![0; n as usize];
                for i in 0..n {
                    let u = plan.point(i)[d];
                    assert!((0.0..1.0).contains(&u));
                    hits[(u * n as f64) as usize] += 1;
                }
                assert!(hits.iter().all(|&h| h == 1), "n {n}, dimension {d}");
            }
        }
    }

    #[test]
    fn different_seeds_give_different_points_and_the_same_seed_the_same() {
        for method in [Method::Lhs, Method::Sobol, Method::Random] {
            let a = Plan::new(method, 1, 10, 3).unwrap();
            let b = Plan::new(method, 2, 10, 3).unwrap();
            assert_eq!(a.point(4), a.point(4));
            assert_ne!(a.point(4), b.point(4), "{method:?}");
        }
    }

    #[test]
    fn random_points_do_not_depend_on_the_number_of_samples() {
        let short = Plan::new(Method::Random, 5, 10, 4).unwrap();
        let long = Plan::new(Method::Random, 5, 1000, 4).unwrap();
        assert_eq!(short.point(9), long.point(9));
    }

    #[test]
    fn a_grid_covers_its_axes_ends_included() {
        let plan = Plan::new(Method::Grid, 0, 3, 2).unwrap();
        assert_eq!(plan.len(), 9);
        let points: Vec<Vec<f64>> = (0..9).map(|i| plan.point(i)).collect();
        assert_eq!(points[0], vec![0.0, 0.0]);
        assert_eq!(points[1], vec![0.5, 0.0]);
        assert_eq!(points[5], vec![1.0, 0.5]);
        assert_eq!(points[8], vec![1.0, 1.0]);
        assert_eq!(Plan::new(Method::Grid, 0, 3, 3), Err(SamplingError::GridDimensions(3)));
    }

    #[test]
    fn random_and_latin_hypercube_means_are_near_one_half() {
        for method in [Method::Random, Method::Lhs, Method::Sobol] {
            let plan = Plan::new(method, 11, 4000, 3).unwrap();
            let mean = (0..4000).map(|i| plan.point(i)[2]).sum::<f64>() / 4000.0;
            // The standard error of a mean of 4000 uniforms is 0.0046.
            assert!((mean - 0.5).abs() < 0.02, "{method:?}: {mean}");
        }
    }
}
