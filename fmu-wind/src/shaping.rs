//! Shaping filters that turn white noise into the along-wind gust: the Davenport filter derived
//! for the given mean speed, and the seed paper's H3 and H10.
//!
//! # Noise convention
//!
//! The filter input is continuous white noise `w` with a one-sided spectrum of 1 per hertz:
//! two-sided 1/2 per hertz, so its Wiener increments have `E[dW^2] = dt / 2`
//! ([`NOISE_INTENSITY`]). The output's one-sided spectrum per hertz is then exactly
//! `|H(j 2 pi n)|^2`, and its variance is `integral_0^inf |H(j 2 pi n)|^2 dn`, the Lyapunov
//! variance `C P C'` with `A P + P A' + B B' / 2 = 0`. The paper's H3 and H10 are driven by the
//! same noise, so that `|H3(j omega)|^2` is read directly as a spectrum on Eq. 2's axes, the way
//! the paper compares its fits with Eq. 2.
//!
//! # Realisation
//!
//! Every filter here has real, distinct, negative poles, so it is realised in modal form:
//! `A = diag(-p_i)`, `B = 1`, `C = r_i` (the residues of `H(s) = sum r_i / (s + p_i)`). The
//! Davenport filter's time constants span eight decades; the modal form keeps that harmless
//! (the Lyapunov and discretisation formulas are closed-form per mode pair) where a companion
//! form would be hopelessly ill-conditioned.

use crate::davenport::Davenport;
use crate::error::WindError;
use crate::prototype::{Prototype, PROTOTYPE};
use nalgebra::DMatrix;
use std::f64::consts::PI;

/// Intensity of the driving Wiener process: `E[dW^2] = NOISE_INTENSITY dt`.
pub const NOISE_INTENSITY: f64 = 0.5;

/// The seed paper's H3(s) for v_m = 3 m/s: numerator and denominator, highest power first.
pub const PAPER_H3: ([f64; 4], [f64; 5]) = ([2.93, 203.5, 978.0, 3.616], [0.662, 76.6, 1056.0, 38.7, 0.248]);
/// The seed paper's H10(s) for v_m = 9.5 m/s: numerator and denominator, highest power first.
pub const PAPER_H10: ([f64; 4], [f64; 5]) = ([3.95, 370.8, 947.1, 5.12], [0.333, 38.4, 229.0, 23.6, 0.346]);

/// The reference height the paper's H3 and H10 were fitted for, m.
pub const PAPER_REFERENCE_HEIGHT: f64 = crate::site::REFERENCE_HEIGHT;
/// The roughness length the paper's H3 and H10 were fitted for, m.
pub const PAPER_ROUGHNESS_LENGTH: f64 = crate::site::PAPER_ROUGHNESS;

/// How the filter's transfer function is evaluated independently of the modal form.
#[derive(Debug, Clone, PartialEq)]
enum Response {
    /// `gain * s * prod(s + zeros) / prod(s + poles)`.
    Factored { gain: f64, zeros: Vec<f64>, poles: Vec<f64> },
    /// `num(s) / den(s)`, coefficients highest power first.
    Polynomial { num: Vec<f64>, den: Vec<f64> },
}

/// Which spectrum the filter implements.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum FilterKind {
    /// The Davenport filter derived at initialisation for these parameters.
    Davenport(Davenport),
    /// The paper's H3 (`v_mean` = 3) or H10 (`v_mean` = 9.5).
    Paper { v_mean: f64 },
}

/// A strictly proper, stable shaping filter in modal state-space form.
#[derive(Debug, Clone, PartialEq)]
pub struct ShapingFilter {
    kind: FilterKind,
    rates: Vec<f64>,
    residues: Vec<f64>,
    response: Response,
    level_correction_db: f64,
}

impl ShapingFilter {
    /// The Davenport filter for `d`: the stored prototype scaled to `beta` and `kappa`, with its
    /// gain set so that the exact stationary variance equals `6 kappa v_m^2`.
    ///
    /// With `H(s) = k G(beta s)` and `k^2 = 4800 v_m kappa`, `|H(j omega)|^2` follows Eq. 2 as
    /// closely as `|G|^2` follows `F`. The variance normalisation multiplies the gain by
    /// `sqrt(6 kappa v_m^2 / var)`; because Eq. 2 is self-similar this factor is the same for
    /// every `v_m`, and [`ShapingFilter::level_correction_db`] reports it (a few thousandths of
    /// a dB for the stored prototype).
    pub fn davenport(d: &Davenport) -> Self {
        Self::davenport_from_prototype(d, &PROTOTYPE.to_prototype())
    }

    /// [`ShapingFilter::davenport`] with another prototype (for studies of the design).
    pub fn davenport_from_prototype(d: &Davenport, prototype: &Prototype) -> Self {
        let beta = d.beta();
        // G(beta s) = K beta s prod(beta s + z) / prod(beta s + p)
        //           = K beta^(1 + m - n) s prod(s + z / beta) / prod(s + p / beta).
        let m = prototype.zeros.len() as i32;
        let n = prototype.poles.len() as i32;
        let zeros: Vec<f64> = prototype.zeros.iter().map(|z| z / beta).collect();
        let poles: Vec<f64> = prototype.poles.iter().map(|p| p / beta).collect();
        let gain = (4.0 * crate::davenport::LENGTH_SCALE_M * d.v_mean * d.kappa()).sqrt()
            * prototype.gain
            * beta.powi(1 + m - n);
        let residues = factored_residues(gain, &zeros, &poles);
        let mut filter = Self {
            kind: FilterKind::Davenport(*d),
            rates: poles.clone(),
            residues,
            response: Response::Factored { gain, zeros, poles },
            level_correction_db: 0.0,
        };
        let scale = (d.variance() / filter.stationary_variance()).sqrt();
        filter.scale_gain(scale);
        filter.level_correction_db = 20.0 * scale.log10();
        filter
    }

    /// The seed paper's filter for `v_mean` at a site of reference height `z` and roughness
    /// length `z0`: [`ShapingFilter::paper`], refused unless the site is the one the paper
    /// fitted H3 and H10 for (z = 10 m, z0 = 0.4 m).
    ///
    /// The filters themselves do not depend on `z` and `z0`, but everything the wind unit
    /// derives from kappa does (the normalised gust dv0, the linearised torque gain k_t, the
    /// comparison with Eq. 2), so another site would pair the paper's spectrum with a kappa it
    /// was never fitted to, silently.
    pub fn paper_at_site(v_mean: f64, z: f64, z0: f64) -> Result<Self, WindError> {
        let filter = Self::paper(v_mean)?;
        if z != PAPER_REFERENCE_HEIGHT || z0 != PAPER_ROUGHNESS_LENGTH {
            return Err(WindError::PaperSite {
                z,
                z0,
                paper_z: PAPER_REFERENCE_HEIGHT,
                paper_z0: PAPER_ROUGHNESS_LENGTH,
            });
        }
        Ok(filter)
    }

    /// The seed paper's filter for `v_mean`: H3 for 3 m/s, H10 for 9.5 m/s, an error otherwise.
    pub fn paper(v_mean: f64) -> Result<Self, WindError> {
        let (num, den) = if v_mean == 3.0 {
            (PAPER_H3.0.to_vec(), PAPER_H3.1.to_vec())
        } else if v_mean == 9.5 {
            (PAPER_H10.0.to_vec(), PAPER_H10.1.to_vec())
        } else {
            return Err(WindError::PaperSpeed { v_mean });
        };
        let rates = real_pole_rates(&den)?;
        let residues = rates.iter().map(|&p| polyval(&num, -p) / polyval(&polyder(&den), -p)).collect();
        Ok(Self {
            kind: FilterKind::Paper { v_mean },
            rates,
            residues,
            response: Response::Polynomial { num, den },
            level_correction_db: 0.0,
        })
    }

    fn scale_gain(&mut self, scale: f64) {
        self.residues.iter_mut().for_each(|r| *r *= scale);
        if let Response::Factored { gain, .. } = &mut self.response {
            *gain *= scale;
        }
    }

    pub fn kind(&self) -> FilterKind {
        self.kind
    }

    /// Number of states.
    pub fn order(&self) -> usize {
        self.rates.len()
    }

    /// The decay rates `p_i > 0` (the poles are `-p_i`), in rad/s.
    pub fn rates(&self) -> &[f64] {
        &self.rates
    }

    /// The residues `r_i` of `H(s) = sum r_i / (s + p_i)`: the output row `C`.
    pub fn residues(&self) -> &[f64] {
        &self.residues
    }

    /// `A = diag(-p_i)`.
    pub fn a(&self) -> DMatrix<f64> {
        DMatrix::from_diagonal(&nalgebra::DVector::from_iterator(self.order(), self.rates.iter().map(|p| -p)))
    }

    /// `B`: a column of ones (the noise drives every mode).
    pub fn b(&self) -> DMatrix<f64> {
        DMatrix::from_element(self.order(), 1, 1.0)
    }

    /// `C`: the residues as a row.
    pub fn c(&self) -> DMatrix<f64> {
        DMatrix::from_row_slice(1, self.order(), &self.residues)
    }

    /// How much the variance normalisation moved the level, in dB (0 for the paper's filters).
    pub fn level_correction_db(&self) -> f64 {
        self.level_correction_db
    }

    /// `|H(j omega)|^2`, evaluated from the factored or polynomial transfer function (not from
    /// the modal form, so that the two can check each other).
    pub fn magnitude_squared(&self, omega: f64) -> f64 {
        match &self.response {
            Response::Factored { gain, zeros, poles } => {
                let w2 = omega * omega;
                let mut log = 2.0 * gain.abs().ln() + w2.ln();
                log += zeros.iter().map(|z| (w2 + z * z).ln()).sum::<f64>();
                log -= poles.iter().map(|p| (w2 + p * p).ln()).sum::<f64>();
                log.exp()
            }
            Response::Polynomial { num, den } => {
                let (nr, ni) = polyval_jw(num, omega);
                let (dr, di) = polyval_jw(den, omega);
                (nr * nr + ni * ni) / (dr * dr + di * di)
            }
        }
    }

    /// The output's one-sided spectrum per hertz at `n_hz`: `|H(j 2 pi n)|^2` in the convention
    /// of [`NOISE_INTENSITY`].
    pub fn psd_one_sided_per_hz(&self, n_hz: f64) -> f64 {
        self.magnitude_squared(2.0 * PI * n_hz)
    }

    /// The same spectrum indexed by angular frequency, on Eq. 2's axes.
    pub fn psd_at_omega(&self, omega: f64) -> f64 {
        self.magnitude_squared(omega)
    }

    /// The stationary state covariance: `lti::lyapunov_continuous` of
    /// `(A, B B' / 2)`.
    pub fn stationary_covariance(&self) -> DMatrix<f64> {
        let w = self.b() * self.b().transpose() * NOISE_INTENSITY;
        lti::lyapunov_continuous(&self.a(), &w).expect("a stable modal A has a unique Lyapunov solution")
    }

    /// The exact stationary output variance `C P C'`, in (m/s)^2.
    pub fn stationary_variance(&self) -> f64 {
        (self.c() * self.stationary_covariance() * self.c().transpose())[(0, 0)]
    }

    /// The impulse response `h(t) = sum r_i exp(-p_i t)`.
    pub fn impulse_response(&self, t: f64) -> f64 {
        self.rates.iter().zip(&self.residues).map(|(p, r)| r * (-p * t).exp()).sum()
    }
}

/// Residues of `gain * s * prod(s + z) / prod(s + p)` at `s = -p_i`.
fn factored_residues(gain: f64, zeros: &[f64], poles: &[f64]) -> Vec<f64> {
    poles
        .iter()
        .enumerate()
        .map(|(i, &pi)| {
            let s = -pi;
            let num: f64 = zeros.iter().map(|z| s + z).product::<f64>() * s;
            let den: f64 = poles.iter().enumerate().filter(|(k, _)| *k != i).map(|(_, pk)| s + pk).product();
            gain * num / den
        })
        .collect()
}

/// Polynomial value, coefficients highest power first.
fn polyval(coefficients: &[f64], s: f64) -> f64 {
    coefficients.iter().fold(0.0, |acc, c| acc * s + c)
}

/// Polynomial value at `s = j omega`, as (real, imaginary).
fn polyval_jw(coefficients: &[f64], omega: f64) -> (f64, f64) {
    coefficients.iter().fold((0.0, 0.0), |(re, im), c| (-im * omega + c, re * omega))
}

/// Derivative coefficients, highest power first.
fn polyder(coefficients: &[f64]) -> Vec<f64> {
    let degree = coefficients.len() - 1;
    coefficients[..degree].iter().enumerate().map(|(k, c)| c * (degree - k) as f64).collect()
}

/// The decay rates of a denominator with real, distinct, negative roots.
///
/// Roots from the companion matrix's eigenvalues, polished by Newton's method on the
/// polynomial itself; anything else (complex, repeated or unstable roots) is an error.
fn real_pole_rates(den: &[f64]) -> Result<Vec<f64>, WindError> {
    let degree = den.len() - 1;
    let lead = den[0];
    let mut companion = DMatrix::<f64>::zeros(degree, degree);
    for k in 0..degree {
        companion[(0, k)] = -den[k + 1] / lead;
        if k + 1 < degree {
            companion[(k + 1, k)] = 1.0;
        }
    }
    let roots = companion.eigenvalues().ok_or(WindError::ComplexPoles)?;
    let derivative = polyder(den);
    let mut rates = Vec::with_capacity(degree);
    for &root in roots.iter() {
        let mut s = root;
        for _ in 0..50 {
            let step = polyval(den, s) / polyval(&derivative, s);
            s -= step;
            if step.abs() <= 1e-15 * s.abs() {
                break;
            }
        }
        if s >= 0.0 {
            return Err(WindError::UnstablePole { root: s });
        }
        rates.push(-s);
    }
    rates.sort_by(f64::total_cmp);
    if rates.windows(2).any(|w| w[1] - w[0] <= 1e-9 * w[1]) {
        return Err(WindError::RepeatedPoles);
    }
    Ok(rates)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn dav(v: f64) -> Davenport {
        Davenport::new(v, 10.0, 0.4).unwrap()
    }

    #[test]
    fn davenport_filter_variance_equals_davenports_variance() {
        for v in [3.0, 9.5, 20.0] {
            let f = ShapingFilter::davenport(&dav(v));
            let ratio = f.stationary_variance() / dav(v).variance();
            assert!((ratio - 1.0).abs() < 1e-9, "v = {v}: ratio {ratio}");
        }
    }

    #[test]
    fn lyapunov_variance_agrees_with_the_residue_formula() {
        // Independent closed form: var = q sum_ij r_i r_j / (p_i + p_j).
        for f in [ShapingFilter::davenport(&dav(3.0)), ShapingFilter::paper(9.5).unwrap()] {
            let (p, r) = (f.rates(), f.residues());
            let mut closed = 0.0;
            for i in 0..p.len() {
                for j in 0..p.len() {
                    closed += NOISE_INTENSITY * r[i] * r[j] / (p[i] + p[j]);
                }
            }
            assert!((f.stationary_variance() / closed - 1.0).abs() < 1e-9);
        }
    }

    #[test]
    fn modal_form_reproduces_the_transfer_function() {
        for f in [
            ShapingFilter::davenport(&dav(0.5)),
            ShapingFilter::davenport(&dav(25.0)),
            ShapingFilter::paper(3.0).unwrap(),
        ] {
            for omega in [1e-4, 1e-2, 0.3, 2.0, 30.0, 500.0] {
                let (mut re, mut im) = (0.0, 0.0);
                for (p, r) in f.rates().iter().zip(f.residues()) {
                    let d = p * p + omega * omega;
                    re += r * p / d;
                    im -= r * omega / d;
                }
                let modal = re * re + im * im;
                let direct = f.magnitude_squared(omega);
                assert!((modal / direct - 1.0).abs() < 1e-8, "omega {omega}: {modal} vs {direct}");
            }
        }
    }

    #[test]
    fn davenport_filter_follows_eq2_within_half_a_db_from_1e_3_to_30_rad_per_s() {
        let mut worst: f64 = 0.0;
        for k in 0..=49 {
            let v = 0.5 + 24.5 * k as f64 / 49.0;
            let d = dav(v);
            let f = ShapingFilter::davenport(&d);
            for omega in crate::prototype::log_grid(1e-3, 30.0, 400) {
                let err = 10.0 * (f.psd_at_omega(omega) / d.psd_at_omega(omega)).log10();
                worst = worst.max(err.abs());
            }
        }
        assert!(worst < 0.5, "worst error {worst} dB");
        // The design target is far tighter than the requirement; guard it too.
        assert!(worst < 0.1, "worst error {worst} dB");
    }

    #[test]
    fn level_correction_is_the_same_small_number_for_every_speed() {
        let a = ShapingFilter::davenport(&dav(1.0)).level_correction_db();
        let b = ShapingFilter::davenport(&dav(20.0)).level_correction_db();
        assert!((a - b).abs() < 1e-9);
        assert!(a.abs() < 0.05, "level correction {a} dB");
    }

    #[test]
    fn paper_mode_rejects_other_speeds_with_a_clear_message() {
        let err = ShapingFilter::paper(5.0).unwrap_err().to_string();
        assert!(err.contains("3 m/s") && err.contains("9.5 m/s") && err.contains("5"));
        assert!(ShapingFilter::paper(3.0).is_ok() && ShapingFilter::paper(9.5).is_ok());
    }

    #[test]
    fn paper_mode_rejects_a_site_other_than_the_papers_naming_z_and_z0() {
        for (z, z0) in [(15.0, 0.4), (10.0, 0.026), (2.0, 0.1)] {
            let err = ShapingFilter::paper_at_site(3.0, z, z0).unwrap_err().to_string();
            assert!(
                err.contains("z = 10 m")
                    && err.contains("z0 = 0.4 m")
                    && err.contains(&format!("got z = {z} m, z0 = {z0} m")),
                "{err}"
            );
        }
        // The speed check still comes first, and the paper's own site is accepted.
        assert!(ShapingFilter::paper_at_site(5.0, 15.0, 0.4).unwrap_err().to_string().contains("9.5 m/s"));
        assert_eq!(ShapingFilter::paper_at_site(9.5, 10.0, 0.4).unwrap(), ShapingFilter::paper(9.5).unwrap());
    }

    /// `C exp(A t) B` of the controllable canonical form built from the printed polynomials:
    /// an evaluation that shares nothing with the modal realisation (no roots, no residues).
    fn companion_impulse_response(num: &[f64], den: &[f64], t: f64) -> f64 {
        let n = den.len() - 1;
        let lead = den[0];
        let mut a = DMatrix::<f64>::zeros(n, n);
        for k in 0..n - 1 {
            a[(k, k + 1)] = 1.0;
        }
        for k in 0..n {
            a[(n - 1, k)] = -den[n - k] / lead;
        }
        let mut b = DMatrix::<f64>::zeros(n, 1);
        b[(n - 1, 0)] = 1.0;
        // C holds the numerator coefficients, lowest power first (numerator degree < n).
        let c = DMatrix::from_fn(1, n, |_, k| if k < num.len() { num[num.len() - 1 - k] / lead } else { 0.0 });
        ((&c * (a * t).exp()) * b)[(0, 0)]
    }

    #[test]
    fn paper_mode_impulse_responses_match_the_printed_transfer_functions() {
        for (v, (num, den)) in [(3.0, PAPER_H3), (9.5, PAPER_H10)] {
            let f = ShapingFilter::paper(v).unwrap();
            for t in [0.0, 0.01, 0.1, 1.0, 10.0, 100.0, 1000.0] {
                let modal = f.impulse_response(t);
                let independent = companion_impulse_response(&num, &den, t);
                assert!(
                    (modal - independent).abs() < 1e-8 * (1.0 + independent.abs()),
                    "v = {v}, t = {t}: {modal} vs {independent}"
                );
            }
            // h(0+) is the ratio of the leading coefficients for a relative degree of one.
            assert!((f.impulse_response(0.0) - num[0] / den[0]).abs() < 1e-9);
        }
    }

    #[test]
    fn paper_filters_keep_their_printed_dc_gain() {
        let h3 = ShapingFilter::paper(3.0).unwrap();
        assert!((h3.magnitude_squared(0.0).sqrt() - 3.616 / 0.248).abs() < 1e-9);
        let dc_modal: f64 = h3.rates().iter().zip(h3.residues()).map(|(p, r)| r / p).sum();
        assert!((dc_modal - 3.616 / 0.248).abs() < 1e-9);
    }

    #[test]
    fn davenport_filter_vanishes_at_dc_like_eq2() {
        let f = ShapingFilter::davenport(&dav(9.5));
        let dc_modal: f64 = f.rates().iter().zip(f.residues()).map(|(p, r)| r / p).sum();
        let scale: f64 = f.residues().iter().map(|r| (r / f.rates()[0]).abs()).fold(0.0, f64::max);
        assert!(dc_modal.abs() < 1e-9 * scale);
    }
}
