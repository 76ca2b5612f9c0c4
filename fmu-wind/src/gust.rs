//! The gust generator: a shaping filter driven by white noise, sampled exactly at the ends of
//! whatever communication steps the master chooses, reproducible from a seed.
//!
//! # Exact discretisation
//!
//! Over a step `h` the modal state evolves as `x_i(t+h) = exp(-p_i h) x_i(t) + w_i` where the
//! noise accumulated over the step has the exact covariance
//! `Qd_ij = q (1 - exp(-(p_i + p_j) h)) / (p_i + p_j)` (`q` = [`NOISE_INTENSITY`]). Sampling
//! `w = L xi` with `L L' = Qd` and `xi` standard normal reproduces the continuous process at the
//! sample instants whatever `h` is, so the statistics do not depend on the step size. This is
//! the closed form of Van Loan's integral for a diagonal `A`; the generic
//! `lti::van_loan` gives the same matrices for moderate `p h` (a test checks
//! it), but it exponentiates `+p h` internally: for the fastest Davenport mode at 25 m/s and a
//! 100 ms step `p h` is about 275, so its block exponential holds `e^275` and the cross terms
//! lose every digit (and overflow beyond 0.25 s steps), where the closed form stays exact.
//!
//! `Qd` is positive semi-definite and, for modes much slower than the step, nearly singular
//! (they all receive the same noise). `L` comes from a diagonally pivoted Cholesky
//! factorisation that stops at pivots below `1e-14` of the largest diagonal: robust for
//! semi-definite matrices, and it draws only as many normals per step as `Qd` has numerical
//! rank. `(exp(-p h), L)` is cached per step size in a small LRU cache, so masters that vary the
//! step pay for a factorisation only when they use a new one.
//!
//! # Start-up
//!
//! The slowest Davenport modes have time constants of hours, so a filter started at rest would
//! need hours to reach its stationary variance. The generator therefore draws its initial state
//! from the stationary distribution `N(0, P)` (Lyapunov covariance): the record is stationary
//! from its first sample.
//!
//! # Random numbers and state
//!
//! `rand_chacha::ChaCha12Rng`, keyed by [`seed_key`](fmu_runtime::seed::seed_key), stream 0, drives
//! `rand_distr::StandardNormal`. The generator's whole future is fixed by the filter state and
//! the ChaCha key, stream and word position; [`GustGenerator::save_state`] writes exactly those,
//! so a restored state replays the same gusts bit for bit.

use crate::shaping::{ShapingFilter, NOISE_INTENSITY};
use fmu_runtime::seed::seed_key;
use fmu_runtime::state::StateError;
use nalgebra::DMatrix;
use rand::SeedableRng;
use rand_chacha::ChaCha12Rng;
use rand_distr::{Distribution, StandardNormal};
use serde::{Deserialize, Serialize};

/// How many step sizes the discretisation cache keeps.
const CACHE_CAPACITY: usize = 8;
/// Pivots below this fraction of the largest diagonal end the pivoted Cholesky factorisation.
const PIVOT_TOLERANCE: f64 = 1e-14;

/// One cached discretisation: the modal decay factors and the noise factor for a step size.
#[derive(Debug, Clone)]
struct Discretisation {
    step_bits: u64,
    decay: Vec<f64>,
    /// The noise factor `L` (`n x rank`) stored column after column: column `k` is
    /// `columns[k * n..(k + 1) * n]`. Adding one scaled column at a time to the noise vector
    /// touches contiguous memory with no index checks in the loop, and every `w_i` still sums
    /// its terms in the order `k = 0, 1, ..`, so the gusts are the same bits as a row-by-row
    /// dot product gives.
    columns: Vec<f64>,
    rank: usize,
    last_used: u64,
}

/// Generates the along-wind gust `v_t` (m/s) from a shaping filter and a seed.
#[derive(Debug, Clone)]
pub struct GustGenerator {
    filter: ShapingFilter,
    seed: u64,
    rng: ChaCha12Rng,
    state: Vec<f64>,
    cache: Vec<Discretisation>,
    clock: u64,
    normals: Vec<f64>,
    /// Scratch for the noise increment `w = L xi` of one step.
    noise: Vec<f64>,
    /// `C x` of the current state, computed whenever the state changes (the FMU reads it
    /// twice a step).
    gust: f64,
}

impl GustGenerator {
    /// A generator for `filter`, seeded with `seed`, started in the stationary distribution.
    pub fn new(filter: ShapingFilter, seed: u64) -> Self {
        let n = filter.order();
        let mut rng = ChaCha12Rng::from_seed(seed_key(seed));
        let (factor, rank) = pivoted_cholesky(&filter.stationary_covariance());
        let xi: Vec<f64> = (0..rank).map(|_| StandardNormal.sample(&mut rng)).collect();
        let state = (0..n).map(|i| (0..rank).map(|k| factor[i * rank + k] * xi[k]).sum()).collect();
        let mut generator = Self {
            filter,
            seed,
            rng,
            state,
            cache: Vec::new(),
            clock: 0,
            normals: vec![0.0; n],
            noise: vec![0.0; n],
            gust: 0.0,
        };
        generator.gust = generator.output();
        generator
    }

    pub fn filter(&self) -> &ShapingFilter {
        &self.filter
    }

    pub fn seed(&self) -> u64 {
        self.seed
    }

    /// The current gust `v_t = C x`, m/s.
    pub fn gust(&self) -> f64 {
        self.gust
    }

    /// `C x`, computed.
    fn output(&self) -> f64 {
        self.state.iter().zip(self.filter.residues()).map(|(x, r)| x * r).sum()
    }

    /// Advances by `h` seconds and returns the gust at the end of the step.
    ///
    /// A step that is not positive and finite leaves the state unchanged and returns the
    /// current gust (the FMI wrapper rejects such steps before they get here).
    pub fn step(&mut self, h: f64) -> f64 {
        if !(h > 0.0 && h.is_finite()) {
            return self.gust();
        }
        let index = self.cached_discretisation(h);
        let entry = &self.cache[index];
        let n = self.state.len();
        debug_assert_eq!(entry.columns.len(), n * entry.rank);
        let normals = &mut self.normals[..entry.rank];
        for xi in normals.iter_mut() {
            *xi = StandardNormal.sample(&mut self.rng);
        }
        match n {
            // The Davenport filter's order: with the length known to the compiler the loops
            // are unrolled and use both lanes of the vector registers.
            DAVENPORT_ORDER => advance_fixed::<DAVENPORT_ORDER>(&mut self.state, &entry.decay, &entry.columns, normals),
            _ => advance(&mut self.state, &entry.decay, &entry.columns, normals, &mut self.noise[..n]),
        }
        self.gust = self.output();
        self.gust
    }

    /// Index of the discretisation for `h`, computing it (and evicting the least recently
    /// used one when the cache is full) if needed.
    fn cached_discretisation(&mut self, h: f64) -> usize {
        self.clock += 1;
        let bits = h.to_bits();
        if let Some(i) = self.cache.iter().position(|d| d.step_bits == bits) {
            self.cache[i].last_used = self.clock;
            return i;
        }
        let (decay, qd) = modal_discretisation(&self.filter, h);
        let (factor, rank) = pivoted_cholesky(&qd);
        let n = decay.len();
        let columns = (0..rank).flat_map(|k| (0..n).map(move |i| (k, i))).map(|(k, i)| factor[i * rank + k]).collect();
        let entry = Discretisation { step_bits: bits, decay, columns, rank, last_used: self.clock };
        if self.cache.len() < CACHE_CAPACITY {
            self.cache.push(entry);
            self.cache.len() - 1
        } else {
            let oldest = (0..self.cache.len()).min_by_key(|&i| self.cache[i].last_used).unwrap_or(0);
            self.cache[oldest] = entry;
            oldest
        }
    }

    /// The exact discrete model for a step `h`: `(Ad, Qd)` as matrices.
    pub fn discretise(&self, h: f64) -> (DMatrix<f64>, DMatrix<f64>) {
        let (decay, qd) = modal_discretisation(&self.filter, h);
        (DMatrix::from_diagonal(&nalgebra::DVector::from_vec(decay)), qd)
    }

    /// The stationary variance of the sampled model at step `h`, from the discrete Lyapunov
    /// equation with the noise covariance actually sampled (`L L'`, after pivot truncation).
    pub fn discrete_stationary_variance(&self, h: f64) -> f64 {
        let n = self.filter.order();
        let (decay, qd) = modal_discretisation(&self.filter, h);
        let (factor, rank) = pivoted_cholesky(&qd);
        let l = DMatrix::from_row_slice(n, rank, &factor);
        let ad = DMatrix::from_diagonal(&nalgebra::DVector::from_vec(decay));
        let p = lti::lyapunov_discrete(&ad, &(&l * l.transpose()))
            .expect("a stable discrete A has a unique Lyapunov solution");
        let c = self.filter.c();
        (&c * p * c.transpose())[(0, 0)]
    }

    /// The generator's state: filter state and the ChaCha key, stream and position.
    pub fn save_state(&self) -> GustState {
        GustState {
            seed: self.seed,
            filter: self.state.clone(),
            key: self.rng.get_seed(),
            stream: self.rng.get_stream(),
            word_pos: self.rng.get_word_pos(),
        }
    }

    /// Restores a state written by [`GustGenerator::save_state`] for a filter of the same order.
    ///
    /// Nothing is changed unless the whole state reads back correctly.
    pub fn load_state(&mut self, saved: GustState) -> Result<(), StateError> {
        let GustState { seed, filter: state, key, stream, word_pos } = saved;
        if state.len() != self.filter.order() {
            return Err(StateError::Invalid(format!(
                "wind gust state: {} filter states for a filter of order {}",
                state.len(),
                self.filter.order()
            )));
        }
        let mut rng = ChaCha12Rng::from_seed(key);
        rng.set_stream(stream);
        rng.set_word_pos(word_pos);
        self.seed = seed;
        self.state = state;
        self.rng = rng;
        self.gust = self.output();
        Ok(())
    }
}

/// What an FMU state holds of a [`GustGenerator`]: all that determines its future gusts.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct GustState {
    pub seed: u64,
    /// The shaping filter's state, one number per order.
    pub filter: Vec<f64>,
    /// The ChaCha12 generator: key, stream and word position.
    pub key: [u8; 32],
    pub stream: u64,
    pub word_pos: u128,
}

/// The order of the Davenport shaping filter (the stored prototype's), for which the step
/// has a version with fixed-size loops; any other order takes the general one.
const DAVENPORT_ORDER: usize = 10;

/// `x <- decay x + L xi`, with `L` given column after column (`columns`, `n` numbers each) and
/// `noise` as scratch. `w = L xi` is accumulated one column at a time from -0.0, the identity
/// of addition, so each `w_i` is the same left-to-right sum over `k` as a row-by-row dot
/// product: the gusts do not depend on which of the two versions ran.
fn advance(state: &mut [f64], decay: &[f64], columns: &[f64], normals: &[f64], noise: &mut [f64]) {
    noise.fill(-0.0);
    for (column, &xi) in columns.chunks_exact(state.len()).zip(normals) {
        for (w, &l) in noise.iter_mut().zip(column) {
            *w += l * xi;
        }
    }
    for ((x, &d), &w) in state.iter_mut().zip(decay).zip(noise.iter()) {
        *x = d * *x + w;
    }
}

/// [`advance`] for a state of `N` numbers, the same operations in the same order.
// Index loops over three arrays of one fixed length say this more plainly than zips.
#[allow(clippy::needless_range_loop)]
fn advance_fixed<const N: usize>(state: &mut [f64], decay: &[f64], columns: &[f64], normals: &[f64]) {
    let (Ok(state), Ok(decay)) = (<&mut [f64; N]>::try_from(state), <&[f64; N]>::try_from(decay)) else {
        unreachable!("the caller checked the order");
    };
    let mut noise = [-0.0; N];
    for (column, &xi) in columns.chunks_exact(N).zip(normals) {
        let Ok(column) = <&[f64; N]>::try_from(column) else { unreachable!("chunks of N") };
        for i in 0..N {
            noise[i] += column[i] * xi;
        }
    }
    for i in 0..N {
        state[i] = decay[i] * state[i] + noise[i];
    }
}

/// `(exp(-p_i h), Qd)` for the modal filter: the closed form of Van Loan's integral.
fn modal_discretisation(filter: &ShapingFilter, h: f64) -> (Vec<f64>, DMatrix<f64>) {
    let p = filter.rates();
    let n = p.len();
    let decay = p.iter().map(|pi| (-pi * h).exp()).collect();
    // -expm1 keeps (1 - exp(-a h)) accurate for the slow modes, where a h is ~1e-9.
    let qd = DMatrix::from_fn(n, n, |i, j| {
        let a = p[i] + p[j];
        -NOISE_INTENSITY * (-a * h).exp_m1() / a
    });
    (decay, qd)
}

/// Diagonally pivoted Cholesky factor of a symmetric positive semi-definite matrix.
///
/// Returns `L` (`n x rank`, row-major, rows in the original order) with `L L' = Q` up to the
/// dropped Schur complement, whose diagonal is below [`PIVOT_TOLERANCE`] times `Q`'s largest
/// diagonal. Negative or tiny pivots from rounding never produce NaN: they end the
/// factorisation.
fn pivoted_cholesky(q: &DMatrix<f64>) -> (Vec<f64>, usize) {
    let n = q.nrows();
    let mut a = q.clone();
    let mut order: Vec<usize> = (0..n).collect();
    let mut columns: Vec<Vec<f64>> = Vec::new();
    let largest = (0..n).map(|i| q[(i, i)]).fold(0.0, f64::max);
    for k in 0..n {
        // Bring the largest remaining diagonal to position k.
        let (offset, pivot) = order[k..]
            .iter()
            .map(|&i| a[(i, i)])
            .enumerate()
            .fold((0, f64::NEG_INFINITY), |best, (j, d)| if d > best.1 { (j, d) } else { best });
        if pivot.is_nan() || pivot <= PIVOT_TOLERANCE * largest {
            break;
        }
        order.swap(k, k + offset);
        let pk = order[k];
        let root = pivot.sqrt();
        let mut column = vec![0.0; n];
        column[pk] = root;
        for &i in &order[k + 1..] {
            column[i] = a[(i, pk)] / root;
        }
        for &i in &order[k + 1..] {
            for &j in &order[k + 1..] {
                a[(i, j)] -= column[i] * column[j];
            }
        }
        columns.push(column);
    }
    let rank = columns.len();
    let mut factor = vec![0.0; n * rank];
    for (k, column) in columns.iter().enumerate() {
        for i in 0..n {
            factor[i * rank + k] = column[i];
        }
    }
    (factor, rank)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::davenport::Davenport;

    fn generator(v: f64, seed: u64) -> GustGenerator {
        GustGenerator::new(ShapingFilter::davenport(&Davenport::new(v, 10.0, 0.4).unwrap()), seed)
    }

    #[test]
    fn pivoted_cholesky_reproduces_a_semidefinite_matrix() {
        // Rank 2 in 3 dimensions: the third pivot is zero up to rounding.
        let v1 = [1.0, 2.0, 3.0];
        let v2 = [0.5, -1.0, 0.25];
        let q = DMatrix::from_fn(3, 3, |i, j| v1[i] * v1[j] + v2[i] * v2[j]);
        let (factor, rank) = pivoted_cholesky(&q);
        assert_eq!(rank, 2);
        let l = DMatrix::from_row_slice(3, rank, &factor);
        assert!((&l * l.transpose() - &q).abs().max() < 1e-12);
    }

    #[test]
    fn exact_discretisation_matches_fmu_runtime_van_loan_where_that_is_accurate() {
        let g = generator(9.5, 1);
        let f = g.filter();
        let q = DMatrix::from_element(1, 1, NOISE_INTENSITY);
        for h in [1e-3, 1e-2] {
            let (ad, qd) = g.discretise(h);
            let (ad_vl, qd_vl) = lti::van_loan(&f.a(), &f.b(), &q, h);
            assert!((&ad - &ad_vl).abs().max() < 1e-10, "Ad at h = {h}");
            let scale = qd.abs().max();
            assert!((&qd - &qd_vl).abs().max() < 1e-8 * scale, "Qd at h = {h}");
        }
    }

    #[test]
    fn discrete_stationary_variance_equals_the_continuous_one_at_any_step() {
        for v in [3.0, 9.5, 20.0] {
            let g = generator(v, 7);
            let target = Davenport::new(v, 10.0, 0.4).unwrap().variance();
            for h in [1e-3, 1e-2, 1e-1] {
                let ratio = g.discrete_stationary_variance(h) / target;
                assert!((ratio - 1.0).abs() < 1e-6, "v = {v}, h = {h}: ratio {ratio}");
            }
        }
    }

    #[test]
    fn same_seed_gives_an_identical_record() {
        let (mut a, mut b) = (generator(3.0, 42), generator(3.0, 42));
        for _ in 0..1000 {
            assert_eq!(a.step(0.01).to_bits(), b.step(0.01).to_bits());
        }
    }

    #[test]
    fn different_seeds_give_different_records() {
        let (mut a, mut b) = (generator(3.0, 1), generator(3.0, 2));
        let differing = (0..100).filter(|_| a.step(0.1) != b.step(0.1)).count();
        assert_eq!(differing, 100);
    }

    #[test]
    fn restoring_a_saved_state_replays_the_same_gusts() {
        let mut g = generator(9.5, 3);
        for _ in 0..137 {
            g.step(0.01);
        }
        let saved = g.save_state();
        // Mixed step sizes also exercise the cache, which is not part of the state.
        let steps = [0.01, 0.1, 0.001, 0.01, 0.05];
        let first: Vec<u64> = (0..500).map(|k| g.step(steps[k % steps.len()]).to_bits()).collect();
        let mut restored = generator(9.5, 999);
        restored.load_state(saved).unwrap();
        let replay: Vec<u64> = (0..500).map(|k| restored.step(steps[k % steps.len()]).to_bits()).collect();
        assert_eq!(first, replay);
    }

    #[test]
    fn a_state_of_another_filter_order_is_rejected_and_changes_nothing() {
        let g = generator(3.0, 5);
        let saved = g.save_state();
        // A paper filter has 4 states, the Davenport filter 10: the state does not fit.
        let mut paper = GustGenerator::new(ShapingFilter::paper(3.0).unwrap(), 1);
        let before = paper.save_state();
        assert!(paper.load_state(saved).is_err());
        assert_eq!(paper.save_state(), before);
    }

    #[test]
    fn the_discretisation_cache_stays_bounded() {
        let mut g = generator(3.0, 8);
        for k in 1..=50 {
            g.step(k as f64 * 1e-3);
        }
        assert!(g.cache.len() <= CACHE_CAPACITY);
    }

    #[test]
    fn non_positive_steps_leave_the_gust_unchanged() {
        let mut g = generator(3.0, 9);
        let before = g.gust();
        assert_eq!(g.step(0.0), before);
        assert_eq!(g.step(-1.0), before);
        assert_eq!(g.step(f64::NAN), before);
    }
}
