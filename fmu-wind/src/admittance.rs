//! Aerodynamic admittance: the filter that turns the point gust into the gust that loads the
//! dish, because eddies smaller than the dish do not act on all of it at once.
//!
//! # Vickery's admittance
//!
//! The load spectrum of a bluff plate of area `A` in a mean wind `U` is the point-gust spectrum
//! times `chi^2(n)`; Vickery's fit to Davenport's square-plate data, as given by J. D. Holmes,
//! *Wind Loading of Structures* (section on aerodynamic admittance), is
//!
//! `chi^2(n) = 1 / [1 + (2 n sqrt(A) / U)^(4/3)]^2`,
//!
//! a function of the normalised frequency `x = n sqrt(A) / U` only. `chi(x)` is 1 for eddies
//! much larger than the dish and falls as `x^(-4/3)` above `x = 1/2`.
//!
//! # Rational fit
//!
//! `chi` is realised as a minimum-phase rational filter `G(p)` in the normalised Laplace
//! variable `p = s sqrt(A) / U` (so `p = j 2 pi x` on the frequency axis), with unit gain at DC
//! (`chi(0) = 1` exactly) and real poles and zeros: a pole/zero pair a decade below the corner
//! (the `x^(4/3)` onset of the fall, which a rational function alone would start as `x^2`), two
//! poles at the corner, then zero/pole pairs a decade apart with the zero a third of a decade
//! above the preceding pole, which alternates the slope between -2 and -1 (average -4/3). [`design_vickery`] refines all break frequencies
//! by Levenberg-Marquardt on the dB error of `|G|^2` against `chi^2` followed by Lawson
//! re-weighting towards the minimax solution, as [`crate::prototype`] does for Eq. 2; the stored
//! constants ([`VICKERY`]) are its output (`cargo run --release -p fmu-wind --example
//! design_admittance` prints them, a test checks it still does). For a mean speed `U` and dish
//! area `A` the poles and zeros scale by `U / sqrt(A)` ([`AdmittanceFilter::vickery`]).
//!
//! # Davenport's size factor
//!
//! The alternative ([`davenport_size_chi`]): with the exponential coherence
//! `exp(-C n r / U)` of two points `r` apart, the mean coherence over a line of length `l` is
//! `J^2(xi) = 2/xi - 2 (1 - e^(-xi)) / xi^2`, `xi = C n l / U` (A. G. Davenport, 1961), and over
//! a square plate of side `l` `chi^2 = J^2(xi)^2`. The dish is taken as the square of equal area,
//! `l = sqrt(A)`; `C` is 7-10 (the survey's range). Fitted the same way ([`DAVENPORT_SIZE`]: 4
//! poles, 3 zeros, 0.053 dB over `xi` in [1e-3, 3e4]), scaled by `U / (C sqrt(A))`.
//!
//! The admittance is a statement about magnitudes; giving it the minimum phase is a modelling
//! choice (the one with the shortest memory), not a measured property.

use nalgebra::{DMatrix, DVector};

use crate::error::WindError;
use crate::prototype::{damped_update, Update};
use std::f64::consts::{LN_10, PI};

/// Vickery's admittance `chi(x) = 1 / (1 + (2 x)^(4/3))`, `x = n sqrt(A) / U`.
pub fn vickery_chi(x: f64) -> f64 {
    1.0 / (1.0 + (2.0 * x).powf(4.0 / 3.0))
}

/// `10 log10 chi^2(x)` of Vickery's admittance, formed without underflow.
pub fn vickery_chi_squared_db(x: f64) -> f64 {
    -20.0 * (2.0 * x).powf(4.0 / 3.0).ln_1p() / LN_10
}

/// Davenport's size factor for a line of length `l` in a gust with exponential coherence
/// `exp(-C n r / U)`: `J^2(xi) = 2/xi - 2 (1 - e^(-xi)) / xi^2`, `xi = C n l / U` (the mean of
/// the coherence over every pair of points of the line). For a square plate of side `l`,
/// `chi^2 = J^2(xi)^2`, so `chi = J^2(xi)`; the dish is taken as the square of equal area,
/// `l = sqrt(A)`.
pub fn davenport_size_chi(xi: f64) -> f64 {
    if xi < 1e-4 {
        // The series 1 - xi/3 + xi^2/12: the closed form cancels catastrophically here.
        1.0 - xi / 3.0 + xi * xi / 12.0
    } else {
        2.0 * (xi + (-xi).exp_m1()) / (xi * xi)
    }
}

/// `10 log10 chi^2(xi)` of Davenport's square-plate size factor.
pub fn davenport_size_chi_squared_db(xi: f64) -> f64 {
    20.0 * davenport_size_chi(xi).log10()
}

/// A rational admittance prototype `G(p) = prod(1 + p / z_i) / prod(1 + p / p_j)`: unit gain
/// at DC, real negative poles and zeros (given here by their positive magnitudes, in units of
/// the normalised variable `p = s sqrt(A) / U`).
#[derive(Debug, Clone, PartialEq)]
pub struct AdmittancePrototype {
    pub zeros: Vec<f64>,
    pub poles: Vec<f64>,
}

/// A prototype in `const` form (the stored coefficients).
#[derive(Debug, Clone, Copy)]
pub struct StoredAdmittance {
    pub zeros: &'static [f64],
    pub poles: &'static [f64],
}

impl StoredAdmittance {
    pub fn to_prototype(&self) -> AdmittancePrototype {
        AdmittancePrototype { zeros: self.zeros.to_vec(), poles: self.poles.to_vec() }
    }
}

/// The stored fit of Vickery's admittance: 7 poles, 5 zeros (relative degree 2), largest dB
/// error 0.0599 over `x` in [1e-3, 3e3], from [`design_vickery`] with
/// [`AdmittanceSpec::default`].
pub const VICKERY: StoredAdmittance = StoredAdmittance { zeros: &VICKERY_ZEROS, poles: &VICKERY_POLES };

/// The stored fit of Davenport's square-plate size factor `J^2(xi)` in `xi = C n sqrt(A) / U`:
/// 4 poles, 3 zeros (relative degree 1), largest dB error 0.0529 over `xi` in [1e-3, 3e4], from
/// [`design_davenport_size`] with [`AdmittanceSpec::davenport_size`].
pub const DAVENPORT_SIZE: StoredAdmittance =
    StoredAdmittance { zeros: &DAVENPORT_SIZE_ZEROS, poles: &DAVENPORT_SIZE_POLES };

/// The stored Davenport fit's largest dB error over its band (0.0529), rounded up.
pub const DAVENPORT_SIZE_MAX_ERROR_DB: f64 = 0.055;

// Generated by `cargo run --release -p fmu-wind --example design_admittance`; do not edit by hand.
const DAVENPORT_SIZE_ZEROS: [f64; 3] = [8.884672419889352e-1, 8.903652190035569e0, 1.0869518598313975e2];
const DAVENPORT_SIZE_POLES: [f64; 4] =
    [8.179194795997907e-1, 5.95598565914053e0, 1.855998064350232e1, 1.1924038190800613e2];

// Generated by `cargo run --release -p fmu-wind --example design_admittance`; do not edit by hand.
const VICKERY_ZEROS: [f64; 5] =
    [6.416698713738704e-1, 3.317015965329023e1, 1.9683734995477693e2, 1.1270594388563295e3, 6.388726498126781e3];
const VICKERY_POLES: [f64; 7] = [
    5.529611449430918e-1,
    2.2534428377359452e0,
    1.9843153467612858e1,
    1.1011025614794531e2,
    6.329371718162414e2,
    3.5594536762425687e3,
    2.64262300063443e4,
];

/// The stored fit's largest dB error over [`AdmittanceSpec::default`]'s band (0.0599), rounded up.
pub const VICKERY_MAX_ERROR_DB: f64 = 0.06;

impl AdmittancePrototype {
    /// `10 log10 |G(j 2 pi x)|^2`.
    pub fn magnitude_squared_db(&self, x: f64) -> f64 {
        let w = 2.0 * PI * x;
        let term = |b: &f64| (w / b).powi(2).ln_1p();
        let log = self.zeros.iter().map(term).sum::<f64>() - self.poles.iter().map(term).sum::<f64>();
        10.0 * log / LN_10
    }

    /// Largest absolute dB error of `|G|^2` against Vickery's `chi^2` on `points` log-spaced
    /// normalised frequencies in `[x_lo, x_hi]`.
    pub fn max_error_db(&self, x_lo: f64, x_hi: f64, points: usize) -> f64 {
        crate::prototype::log_grid(x_lo, x_hi, points)
            .iter()
            .map(|&x| (self.magnitude_squared_db(x) - vickery_chi_squared_db(x)).abs())
            .fold(0.0, f64::max)
    }
}

/// What [`design_vickery`] fits.
#[derive(Debug, Clone, PartialEq)]
pub struct AdmittanceSpec {
    /// Lower end of the fitted band in `x = n sqrt(A) / U`.
    pub x_lo: f64,
    /// Upper end.
    pub x_hi: f64,
    pub points_per_decade: usize,
    /// Pole/zero pairs below the corner, for the `x^(4/3)` onset of the fall (a rational
    /// function alone would start as `x^2`).
    pub onset_pairs: usize,
    /// Zero/pole pairs on the `-4/3` slope after the two corner poles.
    pub fall_pairs: usize,
    pub lawson_passes: usize,
}

impl Default for AdmittanceSpec {
    /// `x` from 1e-3 to 3e3. The band that matters: 0.001-30 Hz at 0.5-25 m/s on the 13.5 m dish
    /// (`sqrt(A)` = 11.96 m) is `x` in [4.8e-4, 718]; below 1e-3 `chi^2` differs from 1 by less
    /// than 0.002 dB and the fit, fixed to 1 at DC, follows it; above 718 `chi^2` is below
    /// -75 dB.
    fn default() -> Self {
        Self { x_lo: 1e-3, x_hi: 3e3, points_per_decade: 50, onset_pairs: 1, fall_pairs: 4, lawson_passes: 6 }
    }
}

impl AdmittanceSpec {
    /// The Davenport size factor's fit: `xi` from 1e-3 to 3e4. The band that matters, `xi = C x`
    /// for `x` in [4.8e-4, 718] and C = 7-10, is [3.4e-3, 7180].
    pub fn davenport_size() -> Self {
        Self { x_lo: 1e-3, x_hi: 3e4, points_per_decade: 50, onset_pairs: 3, fall_pairs: 0, lawson_passes: 6 }
    }
}

/// Designs the rational fit of Vickery's admittance (deterministic, a few milliseconds).
pub fn design_vickery(spec: &AdmittanceSpec) -> AdmittancePrototype {
    // Starting placement in log10 of the normalised angular frequency: the corner of chi is at
    // x = 1/2, i.e. |p| = pi.
    let corner = PI.log10();
    let mut poles = Vec::new();
    let mut zeros = Vec::new();
    for k in (1..=spec.onset_pairs).rev() {
        poles.push(corner - k as f64);
        zeros.push(corner - k as f64 + 0.1);
    }
    poles.extend([corner - 0.1, corner + 0.25]);
    let mut last = corner + 0.25;
    for _ in 0..spec.fall_pairs {
        zeros.push(last + 1.0 / 3.0);
        last += 1.0;
        poles.push(last);
    }
    fit(spec, vickery_chi_squared_db, &poles, &zeros)
}

/// Designs the rational fit of Davenport's size factor for a square plate,
/// `chi(xi) = J^2(xi)`, in `xi = C n sqrt(A) / U` (see [`davenport_size_chi`]). `spec.x_lo`,
/// `spec.x_hi` bound `xi`; `spec.onset_pairs` pole/zero pairs a decade apart below the corner
/// give the linear onset `1 - xi/3`, one pole at the corner the `2 / xi` fall (relative degree 1).
pub fn design_davenport_size(spec: &AdmittanceSpec) -> AdmittancePrototype {
    // J^2(xi) = 1/2 near xi = 3.2, i.e. |p| = 2 pi 3.2 = 20.
    let corner = 20f64.log10();
    let mut poles = Vec::new();
    let mut zeros = Vec::new();
    for k in (1..=spec.onset_pairs).rev() {
        poles.push(corner - k as f64);
        zeros.push(corner - k as f64 + 0.5);
    }
    poles.push(corner);
    fit(spec, davenport_size_chi_squared_db, &poles, &zeros)
}

/// Levenberg-Marquardt from the given placement (log10 of the break frequencies), then Lawson
/// re-weighting towards the minimax fit, keeping the best iterate (see prototype.rs).
fn fit(spec: &AdmittanceSpec, target: fn(f64) -> f64, poles: &[f64], zeros: &[f64]) -> AdmittancePrototype {
    let decades = (spec.x_hi / spec.x_lo).log10();
    let points = (decades * spec.points_per_decade as f64).round() as usize + 1;
    let grid = crate::prototype::log_grid(spec.x_lo, spec.x_hi, points);
    let n_p = poles.len();
    let mut theta: Vec<f64> = poles.iter().chain(zeros).map(|l| l * LN_10).collect();
    let mut weights = vec![1.0 / grid.len() as f64; grid.len()];
    theta = levenberg_marquardt(theta, n_p, &grid, &weights, target);
    let max_error = |t: &[f64]| grid.iter().map(|&x| residual_db(t, n_p, x, target).abs()).fold(0.0, f64::max);
    let mut best = (max_error(&theta), theta.clone());
    for _ in 0..spec.lawson_passes {
        let errors: Vec<f64> = grid.iter().map(|&x| residual_db(&theta, n_p, x, target)).collect();
        let floor = 1e-3 * errors.iter().fold(0.0f64, |m, e| m.max(e.abs()));
        for (w, e) in weights.iter_mut().zip(&errors) {
            *w *= e.abs().max(floor);
        }
        let total: f64 = weights.iter().sum();
        weights.iter_mut().for_each(|w| *w /= total);
        theta = levenberg_marquardt(theta, n_p, &grid, &weights, target);
        let err = max_error(&theta);
        if err < best.0 {
            best = (err, theta.clone());
        }
    }
    let theta = best.1;
    let mut poles: Vec<f64> = theta[..n_p].iter().map(|l| l.exp()).collect();
    let mut zeros: Vec<f64> = theta[n_p..].iter().map(|l| l.exp()).collect();
    poles.sort_by(f64::total_cmp);
    zeros.sort_by(f64::total_cmp);
    AdmittancePrototype { zeros, poles }
}

/// The fit's dB error at `x` for parameters `theta = [ln poles, ln zeros]`.
fn residual_db(theta: &[f64], n_p: usize, x: f64, target: fn(f64) -> f64) -> f64 {
    let w2 = (2.0 * PI * x).powi(2);
    let term = |l: &f64| (w2 * (-2.0 * l).exp()).ln_1p();
    let log = theta[n_p..].iter().map(term).sum::<f64>() - theta[..n_p].iter().map(term).sum::<f64>();
    10.0 * log / LN_10 - target(x)
}

/// Weighted Levenberg-Marquardt on the dB residuals with an analytic Jacobian.
fn levenberg_marquardt(
    mut theta: Vec<f64>,
    n_p: usize,
    grid: &[f64],
    weights: &[f64],
    target: fn(f64) -> f64,
) -> Vec<f64> {
    let n = theta.len();
    let m = grid.len();
    let db = 10.0 / LN_10;
    let cost = |t: &[f64]| -> f64 {
        grid.iter().zip(weights).map(|(&x, &w)| w * residual_db(t, n_p, x, target).powi(2)).sum()
    };
    let mut current = cost(&theta);
    let mut lambda = 1e-3;
    for _ in 0..500 {
        let mut jac = DMatrix::<f64>::zeros(m, n);
        let mut res = DVector::<f64>::zeros(m);
        for (k, &x) in grid.iter().enumerate() {
            let w2 = (2.0 * PI * x).powi(2);
            let sw = weights[k].sqrt();
            res[k] = sw * residual_db(&theta, n_p, x, target);
            for (i, &l) in theta.iter().enumerate() {
                // d/dl ln(1 + w^2 e^(-2l)) = -2 w^2 / (w^2 + e^(2l)); poles enter with a minus.
                let d = -db * 2.0 * w2 / (w2 + (2.0 * l).exp());
                jac[(k, i)] = sw * if i < n_p { -d } else { d };
            }
        }
        let jtj = jac.transpose() * &jac;
        let jtr = jac.transpose() * &res;
        match damped_update(&jtj, &jtr, &mut theta, &mut current, &mut lambda, &cost) {
            Update::Converged => return theta,
            Update::Improved => {}
            Update::Stuck => break,
        }
    }
    theta
}

/// The admittance filter for one mean speed and dish, in modal form: the load gust is
/// `u_a = sum a_j y_j` with `y_j' = -q_j y_j + v_t` driven by the point gust `v_t`.
#[derive(Debug, Clone, PartialEq)]
pub struct AdmittanceFilter {
    /// Decay rates `q_j > 0`, rad/s.
    rates: Vec<f64>,
    /// Residues `a_j` of `G(s) = sum a_j / (s + q_j)`.
    residues: Vec<f64>,
    /// `U / L`, 1/s, with `L` the prototype's length scale: the frequency scale.
    scale: f64,
    prototype: AdmittancePrototype,
}

impl AdmittanceFilter {
    /// The filter for mean speed `v_mean` (m/s) and the prototype's length scale `length` (m):
    /// the prototype's normalised frequency is `n length / v_mean`.
    pub fn with_length_scale(prototype: &AdmittancePrototype, v_mean: f64, length: f64) -> Result<Self, WindError> {
        if !(v_mean.is_finite() && v_mean > 0.0 && length.is_finite() && length > 0.0) {
            return Err(WindError::AdmittanceScale { v_mean, length });
        }
        if prototype.poles.len() <= prototype.zeros.len() {
            return Err(WindError::AdmittanceNotProper { poles: prototype.poles.len(), zeros: prototype.zeros.len() });
        }
        if prototype.poles.len() > MAX_ORDER {
            return Err(WindError::AdmittanceOrder { poles: prototype.poles.len(), max: MAX_ORDER });
        }
        let scale = v_mean / length;
        let rates: Vec<f64> = prototype.poles.iter().map(|p| p * scale).collect();
        let zeros: Vec<f64> = prototype.zeros.iter().map(|z| z * scale).collect();
        // G(s) = K prod(s + z) / prod(s + q) with K = prod q / prod z (unit DC gain); residue
        // at s = -q_j: K prod(z_i - q_j) / prod_{l != j}(q_l - q_j).
        let gain = rates.iter().product::<f64>() / zeros.iter().product::<f64>();
        let residues = rates
            .iter()
            .enumerate()
            .map(|(j, &q)| {
                let num: f64 = zeros.iter().map(|z| z - q).product();
                let den: f64 = rates.iter().enumerate().filter(|&(l, _)| l != j).map(|(_, r)| r - q).product();
                gain * num / den
            })
            .collect();
        Ok(Self { rates, residues, scale, prototype: prototype.clone() })
    }

    /// Vickery's admittance (the stored fit) for `v_mean` and a dish of diameter `diameter`:
    /// length scale `sqrt(A)`, `A = pi D^2 / 4`.
    pub fn vickery(v_mean: f64, diameter: f64) -> Result<Self, WindError> {
        Self::with_length_scale(&VICKERY.to_prototype(), v_mean, aperture_root(diameter))
    }

    /// Davenport's square-plate size factor (the stored fit) for `v_mean`, a dish of diameter
    /// `diameter` (the square of equal area) and the coherence decay constant `decay` (`C`):
    /// length scale `C sqrt(A)`.
    pub fn davenport_size(v_mean: f64, diameter: f64, decay: f64) -> Result<Self, WindError> {
        if !(decay.is_finite() && decay > 0.0) {
            return Err(WindError::CoherenceDecay { decay });
        }
        Self::with_length_scale(&DAVENPORT_SIZE.to_prototype(), v_mean, decay * aperture_root(diameter))
    }

    pub fn order(&self) -> usize {
        self.rates.len()
    }

    /// The decay rates `q_j`, rad/s.
    pub fn rates(&self) -> &[f64] {
        &self.rates
    }

    /// The residues `a_j`: the output row.
    pub fn residues(&self) -> &[f64] {
        &self.residues
    }

    /// `|G(j 2 pi n)|^2` at `n` Hz, from the factored prototype (independent of the residues).
    pub fn magnitude_squared(&self, n_hz: f64) -> f64 {
        10f64.powf(self.prototype.magnitude_squared_db(n_hz / self.scale) / 10.0)
    }

    /// The prototype's normalised frequency of `n` Hz: `x = n sqrt(A) / U` (Vickery),
    /// `xi = C n sqrt(A) / U` (Davenport).
    pub fn normalised_frequency(&self, n_hz: f64) -> f64 {
        n_hz / self.scale
    }
}

/// The largest order of an admittance filter (the gust generator's step keeps its state in a
/// fixed array of this length).
pub const MAX_ORDER: usize = 16;

/// `sqrt(A)` of a dish of diameter `diameter`, `A = pi D^2 / 4`.
fn aperture_root(diameter: f64) -> f64 {
    (PI * diameter * diameter / 4.0).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn vickery_formula_in_db_matches_the_direct_formula() {
        for x in [1e-4, 0.1, 0.5, 3.0, 1e3] {
            let direct = 10.0 * vickery_chi(x).powi(2).log10();
            assert!((vickery_chi_squared_db(x) - direct).abs() < 1e-10, "x = {x}");
        }
        // The corner: (2 x)^(4/3) = 1 at x = 1/2, chi = 1/2.
        assert!((vickery_chi(0.5) - 0.5).abs() < 1e-15);
    }

    #[test]
    fn stored_fit_is_what_the_generator_produces() {
        let designed = design_vickery(&AdmittanceSpec::default());
        let stored = VICKERY.to_prototype();
        for (a, b) in designed.poles.iter().zip(&stored.poles).chain(designed.zeros.iter().zip(&stored.zeros)) {
            assert!((a / b - 1.0).abs() < 1e-6, "{a} vs stored {b}");
        }
    }

    #[test]
    fn stored_fit_follows_vickery_within_its_documented_error() {
        let spec = AdmittanceSpec::default();
        let error = VICKERY.to_prototype().max_error_db(spec.x_lo, spec.x_hi, 20001);
        assert!(error < VICKERY_MAX_ERROR_DB, "{error} dB");
        // Below the band the fit and the formula both tend to 0 dB.
        assert!(VICKERY.to_prototype().magnitude_squared_db(1e-5).abs() < 1e-3);
    }

    #[test]
    fn modal_form_equals_the_factored_transfer_function() {
        let filter = AdmittanceFilter::vickery(9.8, 13.5).unwrap();
        for n in [1e-3, 0.05, 0.3, 2.0, 30.0] {
            let s = nalgebra::Complex::new(0.0, 2.0 * PI * n);
            let h: nalgebra::Complex<f64> =
                filter.rates().iter().zip(filter.residues()).map(|(q, a)| *a / (s + *q)).sum();
            let exact = filter.magnitude_squared(n);
            assert!((h.norm_sqr() / exact - 1.0).abs() < 1e-9, "n = {n}: {} vs {exact}", h.norm_sqr());
        }
        // Unit DC gain: sum a_j / q_j = 1.
        let dc: f64 = filter.rates().iter().zip(filter.residues()).map(|(q, a)| a / q).sum();
        assert!((dc - 1.0).abs() < 1e-12);
    }

    #[test]
    fn the_filter_scales_with_speed_over_the_square_root_of_the_area() {
        // Survey values for D = 13.5 m at 9.8 m/s: chi^2 = 0.75 / 0.36 / 0.054 at 0.1 / 0.3 / 1 Hz.
        let filter = AdmittanceFilter::vickery(9.8, 13.5).unwrap();
        for (n, survey) in [(0.1, 0.75), (0.3, 0.36), (1.0, 0.054)] {
            let formula = vickery_chi(filter.normalised_frequency(n)).powi(2);
            assert!((formula - survey).abs() < 0.006, "{n} Hz: {formula}");
            let fit_db = 10.0 * filter.magnitude_squared(n).log10();
            assert!((fit_db - 10.0 * formula.log10()).abs() < VICKERY_MAX_ERROR_DB);
        }
    }

    #[test]
    fn invalid_speed_or_diameter_is_an_error() {
        assert!(AdmittanceFilter::vickery(0.0, 13.5).is_err());
        assert!(AdmittanceFilter::vickery(9.8, f64::INFINITY).is_err());
        assert!(AdmittanceFilter::davenport_size(9.8, 13.5, 0.0).is_err());
    }

    #[test]
    fn davenport_size_factor_is_the_mean_coherence_over_a_line() {
        // J^2(xi) = int_0^1 int_0^1 exp(-xi |u - v|) du dv, by the midpoint rule.
        let points = 2000;
        for xi in [1e-3, 0.1, 1.0, 3.2, 10.0, 100.0] {
            let h = 1.0 / points as f64;
            let mut sum = 0.0;
            for i in 0..points {
                for j in 0..points {
                    sum += (-xi * ((i as f64 - j as f64) * h).abs()).exp();
                }
            }
            let numeric = sum * h * h;
            // The midpoint rule's error grows with xi (the kernel's kink on the diagonal).
            assert!((numeric / davenport_size_chi(xi) - 1.0).abs() < 1e-3 * (1.0 + xi / 10.0), "xi = {xi}");
        }
        // The series and the closed form meet.
        let (below, above) = (davenport_size_chi(0.99999e-4), davenport_size_chi(1.00001e-4));
        assert!((below - above).abs() < 1e-9);
    }

    #[test]
    fn stored_davenport_fit_is_what_the_generator_produces_and_within_its_error() {
        let spec = AdmittanceSpec::davenport_size();
        let designed = design_davenport_size(&spec);
        let stored = DAVENPORT_SIZE.to_prototype();
        for (a, b) in designed.poles.iter().zip(&stored.poles).chain(designed.zeros.iter().zip(&stored.zeros)) {
            assert!((a / b - 1.0).abs() < 1e-6, "{a} vs stored {b}");
        }
        let error = crate::prototype::log_grid(spec.x_lo, spec.x_hi, 20001)
            .iter()
            .map(|&xi| (stored.magnitude_squared_db(xi) - davenport_size_chi_squared_db(xi)).abs())
            .fold(0.0, f64::max);
        assert!(error < DAVENPORT_SIZE_MAX_ERROR_DB, "{error} dB");
        let filter = AdmittanceFilter::davenport_size(9.8, 13.5, 8.0).unwrap();
        let dc: f64 = filter.rates().iter().zip(filter.residues()).map(|(q, a)| a / q).sum();
        assert!((dc - 1.0).abs() < 1e-12);
        // xi = C n sqrt(A) / U.
        let xi = filter.normalised_frequency(0.1);
        assert!((xi - 8.0 * 0.1 * (PI * 13.5f64.powi(2) / 4.0).sqrt() / 9.8).abs() < 1e-12);
    }
}
