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

use crate::admittance::AdmittanceFilter;
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
/// The same for the admittance stage's own noise (the second block of
/// [`pivoted_cholesky_in_blocks`]): its conditional variances below 1e-10 of the stage's largest
/// noise variance are dropped, which changes the load gust's variance by less than 1e-9 (the
/// tests hold it to 1e-6) and saves a normal per step for each.
const STAGE_PIVOT_TOLERANCE: f64 = 1e-10;

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
    /// The admittance stage's part of the step, when the generator has one.
    load: Option<LoadDiscretisation>,
    last_used: u64,
}

/// One step of the admittance stage `y` (driven by the gust), from the exact discretisation of
/// the joint system `(x, y)`: `y <- coupling x + decay y + shared xi + own eta`, where `xi` are
/// the normals the gust's own step draws and `eta` the stage's own (stream 1).
///
/// The four matrices are stored side by side as one `m x (n + m + rank + own_rank)` matrix,
/// column after column, applied to the stacked sources `[x; y; xi; eta]`: each column adds to
/// all `m` rows at once, so the rows accumulate independently (and in vector registers) where
/// row-by-row dot products would wait on one long chain of additions each.
#[derive(Debug, Clone)]
struct LoadDiscretisation {
    columns: Vec<f64>,
    own_rank: usize,
}

/// The admittance stage: the load gust `u_a = sum a_j y_j` (see [`crate::admittance`]).
#[derive(Debug, Clone)]
struct LoadStage {
    filter: AdmittanceFilter,
    state: Vec<f64>,
    /// ChaCha12 with the gust's key on stream 1: the stage's own normals never shift the gust's.
    rng: ChaCha12Rng,
    /// The stage's own normals of one step.
    eta: Vec<f64>,
    gust: f64,
}

impl LoadStage {
    fn output(&self) -> f64 {
        self.state.iter().zip(self.filter.residues()).map(|(y, a)| y * a).sum()
    }

    /// `y <- coupling x + decay y + shared xi + own eta` with `x` the gust state before the step.
    fn advance(&mut self, step: &LoadDiscretisation, x: &[f64], xi: &[f64]) {
        let m = self.state.len();
        for eta in &mut self.eta[..step.own_rank] {
            *eta = StandardNormal.sample(&mut self.rng);
        }
        let sources = [x, &self.state, xi, &self.eta[..step.own_rank]];
        debug_assert_eq!(step.columns.len(), m * sources.iter().map(|s| s.len()).sum::<usize>());
        let mut y = [0.0; MAX_STAGE_ORDER];
        match m {
            // The orders of the stored fits: with the length known, the accumulators stay in
            // registers.
            7 => accumulate::<7>(&mut y, &step.columns, sources),
            4 => accumulate::<4>(&mut y, &step.columns, sources),
            _ => accumulate_any(&mut y[..m], &step.columns, sources),
        }
        self.state.copy_from_slice(&y[..m]);
        self.gust = self.output();
    }
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
    /// The admittance stage, if the loads see an admitted gust.
    load: Option<LoadStage>,
}

impl GustGenerator {
    /// A generator for `filter`, seeded with `seed`, started in the stationary distribution.
    pub fn new(filter: ShapingFilter, seed: u64) -> Self {
        Self::with_admittance(filter, None, seed)
    }

    /// A generator whose loads see the gust through `admittance` ([`GustGenerator::load_gust`]).
    ///
    /// The gust itself is the same record, bit for bit, as [`GustGenerator::new`] gives for the
    /// same filter and seed: the admittance stage is sampled jointly with it, conditionally on
    /// the gust's own random numbers, and draws what else it needs from stream 1 of the same
    /// ChaCha key.
    pub fn with_admittance(filter: ShapingFilter, admittance: Option<AdmittanceFilter>, seed: u64) -> Self {
        let n = filter.order();
        let mut rng = ChaCha12Rng::from_seed(seed_key(seed));
        let covariance = filter.stationary_covariance();
        let (factor, rank) = pivoted_cholesky(&covariance);
        let xi: Vec<f64> = (0..rank).map(|_| StandardNormal.sample(&mut rng)).collect();
        let state = (0..n).map(|i| (0..rank).map(|k| factor[i * rank + k] * xi[k]).sum()).collect();
        let load = admittance.map(|a| LoadStage::stationary(a, &filter, &covariance, &xi, seed));
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
            load,
        };
        generator.gust = generator.output();
        generator
    }

    /// The gust that drives the loads: the admitted gust, or the gust itself without an
    /// admittance stage, m/s.
    pub fn load_gust(&self) -> f64 {
        self.load.as_ref().map_or(self.gust, |l| l.gust)
    }

    /// The admittance stage's filter, if there is one.
    pub fn admittance(&self) -> Option<&AdmittanceFilter> {
        self.load.as_ref().map(|l| &l.filter)
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
        // The stage needs the gust state before the step.
        if let (Some(load), Some(step)) = (&mut self.load, &entry.load) {
            load.advance(step, &self.state, normals);
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
        let load = self.load.as_ref().map(|l| load_discretisation(&self.filter, &l.filter, h, &qd));
        let entry = Discretisation { step_bits: bits, decay, columns, rank, load, last_used: self.clock };
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
            load: self.load.as_ref().map(|l| LoadGustState { state: l.state.clone(), word_pos: l.rng.get_word_pos() }),
        }
    }

    /// [`GustGenerator::save_state`] written over `state`, reusing its vectors (the runtime
    /// keeps a state before every step: this way the step does not allocate).
    pub fn save_state_into(&self, state: &mut GustState) {
        state.seed = self.seed;
        state.filter.clone_from(&self.state);
        state.key = self.rng.get_seed();
        state.stream = self.rng.get_stream();
        state.word_pos = self.rng.get_word_pos();
        match (&self.load, &mut state.load) {
            (Some(load), Some(kept)) => {
                kept.state.clone_from(&load.state);
                kept.word_pos = load.rng.get_word_pos();
            }
            (load, kept) => {
                *kept = load.as_ref().map(|l| LoadGustState { state: l.state.clone(), word_pos: l.rng.get_word_pos() })
            }
        }
    }

    /// Restores a state written by [`GustGenerator::save_state`] for a filter of the same order.
    ///
    /// Nothing is changed unless the whole state reads back correctly.
    pub fn load_state(&mut self, saved: GustState) -> Result<(), StateError> {
        let GustState { seed, filter: state, key, stream, word_pos, load } = saved;
        if state.len() != self.filter.order() {
            return Err(StateError::Size {
                part: "wind gust filter's order",
                in_state: state.len(),
                expected: self.filter.order(),
            });
        }
        let load_order = self.load.as_ref().map(|l| l.state.len());
        if load.as_ref().map(|l| l.state.len()) != load_order {
            // A generator without the admittance stage has a stage of order 0.
            return Err(StateError::Size {
                part: "wind admittance stage's order",
                in_state: load.as_ref().map_or(0, |l| l.state.len()),
                expected: load_order.unwrap_or(0),
            });
        }
        if let (Some(stage), Some(saved)) = (&mut self.load, load) {
            let mut rng = ChaCha12Rng::from_seed(key);
            rng.set_stream(LOAD_STREAM);
            rng.set_word_pos(saved.word_pos);
            stage.state = saved.state;
            stage.rng = rng;
            stage.gust = stage.output();
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
    /// The admittance stage, if the generator has one.
    pub load: Option<LoadGustState>,
}

/// What an FMU state holds of the admittance stage: its filter state and the word position of
/// its random stream (the key is the gust's, the stream [`LOAD_STREAM`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct LoadGustState {
    pub state: Vec<f64>,
    pub word_pos: u128,
}

/// The ChaCha stream of the admittance stage's own normals (the gust uses stream 0).
pub const LOAD_STREAM: u64 = 1;

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
    let (factor, rank, _) = pivoted_cholesky_in_blocks(q, q.nrows());
    (factor, rank)
}

/// [`pivoted_cholesky`] of a matrix in two blocks: pivots are first chosen among the first
/// `first` indices only (the gust's modes), with columns that extend over every row, then among
/// the rest (the admittance stage) on what is left of it, the Schur complement.
///
/// Returns `(L, rank_first, rank_rest)`, `L` row-major `n x (rank_first + rank_rest)`. The
/// first block's rows and columns are the same numbers, computed by the same operations in the
/// same order, as [`pivoted_cholesky`] of that block alone gives (tested bit for bit): the
/// extra rows only read the first block. The second block's columns are zero on the first
/// block's rows, so `L xi` moves the first block by exactly what it would move it alone, and
/// the rest by its conditional mean plus independent conditional noise.
fn pivoted_cholesky_in_blocks(q: &DMatrix<f64>, first: usize) -> (Vec<f64>, usize, usize) {
    let n = q.nrows();
    let mut a = q.clone();
    let mut columns: Vec<Vec<f64>> = Vec::new();
    let mut rank_first = 0;
    for (index, (block, tail)) in [(0..first, first..n), (first..n, n..n)].into_iter().enumerate() {
        let mut order: Vec<usize> = block.collect();
        let tail: Vec<usize> = tail.collect();
        let largest = order.iter().map(|&i| q[(i, i)]).fold(0.0, f64::max);
        let tolerance = if index == 0 { PIVOT_TOLERANCE } else { STAGE_PIVOT_TOLERANCE };
        for k in 0..order.len() {
            // Bring the largest remaining diagonal to position k.
            let (offset, pivot) = order[k..]
                .iter()
                .map(|&i| a[(i, i)])
                .enumerate()
                .fold((0, f64::NEG_INFINITY), |best, (j, d)| if d > best.1 { (j, d) } else { best });
            if pivot.is_nan() || pivot <= tolerance * largest {
                break;
            }
            order.swap(k, k + offset);
            let pk = order[k];
            let root = pivot.sqrt();
            let mut column = vec![0.0; n];
            column[pk] = root;
            let rows: Vec<usize> = order[k + 1..].iter().chain(&tail).copied().collect();
            for &i in &rows {
                column[i] = a[(i, pk)] / root;
            }
            for &i in &rows {
                for &j in &rows {
                    a[(i, j)] -= column[i] * column[j];
                }
            }
            columns.push(column);
        }
        if index == 0 {
            rank_first = columns.len();
        }
    }
    let rank = columns.len();
    let mut factor = vec![0.0; n * rank];
    for (k, column) in columns.iter().enumerate() {
        for i in 0..n {
            factor[i * rank + k] = column[i];
        }
    }
    (factor, rank_first, rank - rank_first)
}

/// The joint system of gust modes and admittance stage: `x' = -p x + 1 w`,
/// `y' = -q y + 1 (r . x)`; returns `A` (`n + m` square) and the noise column `G`.
fn joint_system(filter: &ShapingFilter, admittance: &AdmittanceFilter) -> (DMatrix<f64>, DMatrix<f64>) {
    let (n, m) = (filter.order(), admittance.order());
    let mut a = DMatrix::<f64>::zeros(n + m, n + m);
    for (i, p) in filter.rates().iter().enumerate() {
        a[(i, i)] = -p;
    }
    for (j, q) in admittance.rates().iter().enumerate() {
        a[(n + j, n + j)] = -q;
        for (i, r) in filter.residues().iter().enumerate() {
            a[(n + j, i)] = *r;
        }
    }
    let g = DMatrix::from_fn(n + m, 1, |i, _| if i < n { 1.0 } else { 0.0 });
    (a, g)
}

/// The exact discretisation `(Ad, Qd)` of the joint system over `h`: Van Loan's formula
/// (`lti::van_loan`) over `h / 2^k` with `k` the smallest that brings `|A| h / 2^k` to 0.5 or
/// less, then `k` doublings `Qd <- Ad Qd Ad' + Qd`, `Ad <- Ad Ad`. The doublings only add
/// decaying, positive semi-definite pieces, so the fast modes that make Van Loan's block
/// exponential overflow at long steps (see the module notes) cost nothing in accuracy.
fn joint_discretisation(a: &DMatrix<f64>, g: &DMatrix<f64>, h: f64) -> (DMatrix<f64>, DMatrix<f64>) {
    let norm = a.row_iter().map(|r| r.iter().map(|v| v.abs()).sum::<f64>()).fold(0.0, f64::max);
    let mut small = h;
    let mut doublings = 0;
    while norm * small > 0.5 && doublings < 200 {
        small *= 0.5;
        doublings += 1;
    }
    let q = DMatrix::from_element(1, 1, NOISE_INTENSITY);
    let (mut ad, mut qd) = lti::van_loan(a, g, &q, small);
    for _ in 0..doublings {
        qd = &ad * &qd * ad.transpose() + &qd;
        ad = &ad * &ad;
    }
    (ad, (&qd + qd.transpose()) * 0.5)
}

/// The admittance stage's step for `h`: the joint discretisation, with the gust block of the
/// noise covariance replaced by the closed form the gust's own step uses (`qd_gust`), factored
/// gust block first ([`pivoted_cholesky_in_blocks`]).
fn load_discretisation(
    filter: &ShapingFilter,
    admittance: &AdmittanceFilter,
    h: f64,
    qd_gust: &DMatrix<f64>,
) -> LoadDiscretisation {
    let (n, m) = (filter.order(), admittance.order());
    let (a, g) = joint_system(filter, admittance);
    let (ad, mut qd) = joint_discretisation(&a, &g, h);
    qd.view_mut((0, 0), (n, n)).copy_from(qd_gust);
    let (factor, rank_first, rank_rest) = pivoted_cholesky_in_blocks(&qd, n);
    split_load_factor(&ad, &factor, n, m, rank_first, rank_rest)
}

/// The stage's columns from the joint `Ad` (its `y` rows) and noise factor (its `y` rows, the
/// gust's columns then the stage's own), in the order of the sources `[x; y; xi; eta]`.
fn split_load_factor(
    ad: &DMatrix<f64>,
    factor: &[f64],
    n: usize,
    m: usize,
    rank_first: usize,
    rank_rest: usize,
) -> LoadDiscretisation {
    let rank = rank_first + rank_rest;
    let dynamics = (0..n + m).flat_map(|k| (0..m).map(move |j| ad[(n + j, k)]));
    let noise = (0..rank).flat_map(|k| (0..m).map(move |j| factor[(n + j) * rank + k]));
    LoadDiscretisation { columns: dynamics.chain(noise).collect(), own_rank: rank_rest }
}

/// The largest admittance stage order the step handles (the stored fits have 7 and 4).
const MAX_STAGE_ORDER: usize = crate::admittance::MAX_ORDER;

/// `y = sum_k column_k source_k` over the stacked sources, for a stage of order `M`: each column
/// adds to all rows at once, in the same order as [`accumulate_any`].
// An index loop over two arrays of one fixed length says this more plainly than a zip.
#[allow(clippy::needless_range_loop)]
fn accumulate<const M: usize>(y: &mut [f64; MAX_STAGE_ORDER], columns: &[f64], sources: [&[f64]; 4]) {
    let mut acc = [0.0; M];
    let mut offset = 0;
    for segment in sources {
        let block = &columns[offset..offset + M * segment.len()];
        offset += block.len();
        for (column, &source) in block.chunks_exact(M).zip(segment) {
            let Ok(column) = <&[f64; M]>::try_from(column) else { unreachable!("chunks of M") };
            for j in 0..M {
                acc[j] += column[j] * source;
            }
        }
    }
    y[..M].copy_from_slice(&acc);
}

/// [`accumulate`] for any order.
fn accumulate_any(y: &mut [f64], columns: &[f64], sources: [&[f64]; 4]) {
    y.fill(0.0);
    let m = y.len();
    for (column, &source) in columns.chunks_exact(m).zip(sources.iter().flat_map(|s| s.iter())) {
        for (a, c) in y.iter_mut().zip(column) {
            *a += c * source;
        }
    }
}

/// The stationary covariance of the joint system in closed form, given the gust block `P`:
/// with `s_i = cov(v_t, x_i) = sum_k r_k P_ki`, `cov(y_j, x_i) = s_i / (q_j + p_i)` and, with
/// `t_j = sum_i r_i cov(y_j, x_i)`, `cov(y_j, y_l) = (t_j + t_l) / (q_j + q_l)` (the Lyapunov
/// equation block by block; every denominator is a sum of two positive rates, so coincident
/// poles of the two filters are harmless).
fn joint_stationary_covariance(
    filter: &ShapingFilter,
    admittance: &AdmittanceFilter,
    gust_block: &DMatrix<f64>,
) -> DMatrix<f64> {
    let (n, m) = (filter.order(), admittance.order());
    let (p, r, q) = (filter.rates(), filter.residues(), admittance.rates());
    let s: Vec<f64> = (0..n).map(|i| (0..n).map(|k| r[k] * gust_block[(k, i)]).sum()).collect();
    let cross = DMatrix::from_fn(m, n, |j, i| s[i] / (q[j] + p[i]));
    let t: Vec<f64> = (0..m).map(|j| (0..n).map(|i| cross[(j, i)] * r[i]).sum()).collect();
    let mut joint = DMatrix::<f64>::zeros(n + m, n + m);
    joint.view_mut((0, 0), (n, n)).copy_from(gust_block);
    joint.view_mut((n, 0), (m, n)).copy_from(&cross);
    joint.view_mut((0, n), (n, m)).copy_from(&cross.transpose());
    joint.view_mut((n, n), (m, m)).copy_from(&DMatrix::from_fn(m, m, |j, l| (t[j] + t[l]) / (q[j] + q[l])));
    joint
}

impl LoadStage {
    /// The stage drawn from its stationary distribution conditionally on the gust's initial
    /// state, which the normals `xi` drew.
    fn stationary(
        filter: AdmittanceFilter,
        gust: &ShapingFilter,
        gust_covariance: &DMatrix<f64>,
        xi: &[f64],
        seed: u64,
    ) -> Self {
        let (n, m) = (gust.order(), filter.order());
        let joint = joint_stationary_covariance(gust, &filter, gust_covariance);
        let (factor, rank_first, rank_rest) = pivoted_cholesky_in_blocks(&joint, n);
        let pieces = split_load_factor(&DMatrix::zeros(n + m, n + m), &factor, n, m, rank_first, rank_rest);
        let mut rng = ChaCha12Rng::from_seed(seed_key(seed));
        rng.set_stream(LOAD_STREAM);
        let mut stage = Self { filter, state: vec![0.0; m], rng, eta: vec![0.0; m], gust: 0.0 };
        stage.advance(&pieces, &vec![0.0; n], xi);
        stage
    }
}

impl GustGenerator {
    /// The exact stationary variance of the load gust (the admitted gust), from the joint
    /// covariance; the gust's own variance without an admittance stage.
    pub fn load_stationary_variance(&self) -> f64 {
        let Some(load) = &self.load else { return self.filter.stationary_variance() };
        let joint = joint_stationary_covariance(&self.filter, &load.filter, &self.filter.stationary_covariance());
        self.load_output_variance(&joint)
    }

    /// The stationary variance of the sampled joint model at step `h` (discrete Lyapunov
    /// equation with the noise factors the generator draws with): equal to
    /// [`GustGenerator::load_stationary_variance`] if the discretisation is exact.
    pub fn load_discrete_stationary_variance(&self, h: f64) -> f64 {
        let Some(load) = &self.load else { return self.discrete_stationary_variance(h) };
        let (n, m) = (self.filter.order(), load.filter.order());
        let (decay, qd_gust) = modal_discretisation(&self.filter, h);
        let (a, g) = joint_system(&self.filter, &load.filter);
        let (mut ad, mut qd) = joint_discretisation(&a, &g, h);
        qd.view_mut((0, 0), (n, n)).copy_from(&qd_gust);
        for i in 0..n {
            ad[(i, i)] = decay[i];
        }
        let (factor, rank_first, rank_rest) = pivoted_cholesky_in_blocks(&qd, n);
        let l = DMatrix::from_row_slice(n + m, rank_first + rank_rest, &factor);
        let p = lti::lyapunov_discrete(&ad, &(&l * l.transpose()))
            .expect("a stable discrete A has a unique Lyapunov solution");
        self.load_output_variance(&p)
    }

    fn load_output_variance(&self, joint: &DMatrix<f64>) -> f64 {
        let Some(load) = &self.load else { return f64::NAN };
        let n = self.filter.order();
        let a = load.filter.residues();
        (0..a.len())
            .flat_map(|j| (0..a.len()).map(move |l| (j, l)))
            .map(|(j, l)| a[j] * joint[(n + j, n + l)] * a[l])
            .sum()
    }
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

    fn admitted(v: f64, seed: u64) -> GustGenerator {
        let filter = ShapingFilter::davenport(&Davenport::new(v, 10.0, 0.4).unwrap());
        GustGenerator::with_admittance(filter, Some(AdmittanceFilter::vickery(v, 13.5).unwrap()), seed)
    }

    #[test]
    fn block_cholesky_gives_the_gust_block_the_same_bits_as_the_gust_alone() {
        let g = admitted(9.5, 1);
        let load = g.load.as_ref().unwrap();
        let n = g.filter.order();
        for h in [1e-3, 0.1, 2.0] {
            let (_, qd_gust) = modal_discretisation(&g.filter, h);
            let (alone, rank) = pivoted_cholesky(&qd_gust);
            let (a, noise) = joint_system(&g.filter, &load.filter);
            let (_, mut qd) = joint_discretisation(&a, &noise, h);
            qd.view_mut((0, 0), (n, n)).copy_from(&qd_gust);
            let (joint, rank_first, rank_rest) = pivoted_cholesky_in_blocks(&qd, n);
            assert_eq!(rank_first, rank, "h = {h}");
            let width = rank_first + rank_rest;
            for i in 0..n {
                for k in 0..width {
                    let expected = if k < rank { alone[i * rank + k] } else { 0.0 };
                    assert_eq!(joint[i * width + k].to_bits(), expected.to_bits(), "h = {h}, ({i}, {k})");
                }
            }
        }
    }

    #[test]
    fn the_admittance_stage_leaves_the_gust_record_bit_for_bit_unchanged() {
        let (mut plain, mut with_stage) = (generator(9.5, 4), admitted(9.5, 4));
        assert_eq!(plain.gust().to_bits(), with_stage.gust().to_bits());
        let steps = [0.01, 0.1, 0.001, 0.05, 1.0];
        for k in 0..2000 {
            let h = steps[k % steps.len()];
            assert_eq!(plain.step(h).to_bits(), with_stage.step(h).to_bits(), "step {k}");
        }
        assert_ne!(with_stage.load_gust(), with_stage.gust());
    }

    #[test]
    fn load_gust_variance_is_the_integral_of_the_admitted_spectrum_and_the_same_at_every_step() {
        for v in [3.0, 9.5, 20.0] {
            let filter = ShapingFilter::davenport(&Davenport::new(v, 10.0, 0.4).unwrap());
            let stages =
                [AdmittanceFilter::vickery(v, 13.5).unwrap(), AdmittanceFilter::davenport_size(v, 13.5, 8.0).unwrap()];
            for stage in stages {
                let g = GustGenerator::with_admittance(filter.clone(), Some(stage), 7);
                let continuous = g.load_stationary_variance();
                // Trapezoid rule in ln n over 1e-7..1e4 Hz of |H|^2 |G|^2 (one-sided, per hertz).
                let adm = g.admittance().unwrap();
                let points = 200_000;
                let (lo, hi) = (1e-7f64.ln(), 1e4f64.ln());
                let dl = (hi - lo) / points as f64;
                let integral: f64 = (0..=points)
                    .map(|k| {
                        let n = (lo + k as f64 * dl).exp();
                        let weight = if k == 0 || k == points { 0.5 } else { 1.0 };
                        weight
                            * n
                            * g.filter.magnitude_squared(2.0 * std::f64::consts::PI * n)
                            * adm.magnitude_squared(n)
                    })
                    .sum::<f64>()
                    * dl;
                let order = adm.order();
                assert!(
                    (integral / continuous - 1.0).abs() < 1e-4,
                    "v = {v}, order {order}: integral {integral}, Lyapunov {continuous}"
                );
                assert!(continuous < g.filter.stationary_variance());
                for h in [1e-3, 1e-2, 1e-1, 1.0] {
                    let ratio = g.load_discrete_stationary_variance(h) / continuous;
                    assert!((ratio - 1.0).abs() < 1e-6, "v = {v}, order {order}, h = {h}: ratio {ratio}");
                }
            }
        }
    }

    #[test]
    fn a_state_saved_over_a_kept_one_equals_a_fresh_save() {
        let mut g = admitted(9.5, 3);
        // Kept from a generator without an admittance stage: the load part must be written too.
        let plain = ShapingFilter::davenport(&Davenport::new(9.5, 10.0, 0.4).unwrap());
        let mut kept = GustGenerator::new(plain, 5).save_state();
        for k in 0..20 {
            g.step(0.01);
            g.save_state_into(&mut kept);
            assert_eq!(kept, g.save_state(), "step {k}");
        }
    }

    #[test]
    fn restoring_a_saved_state_replays_the_same_load_gusts() {
        let mut g = admitted(9.5, 3);
        for _ in 0..137 {
            g.step(0.01);
        }
        let saved = g.save_state();
        let steps = [0.01, 0.1, 0.001, 0.01, 0.05];
        let run = |g: &mut GustGenerator| -> Vec<(u64, u64)> {
            (0..500).map(|k| (g.step(steps[k % steps.len()]).to_bits(), g.load_gust().to_bits())).collect()
        };
        let first = run(&mut g);
        let mut restored = admitted(9.5, 999);
        restored.load_state(saved.clone()).unwrap();
        assert_eq!(first, run(&mut restored));
        // A state with a stage does not fit a generator without one.
        assert!(generator(9.5, 1).load_state(saved).is_err());
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
