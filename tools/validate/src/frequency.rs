//! Measured against model frequency response, torque to motor speed, where the data has
//! broadband excitation.
//!
//! The measured response is the H1 estimate (Welch cross spectrum over input spectrum,
//! `antenna_dsp`) from the logged axis torque to the motor speed, with its coherence;
//! the model's is the corrected Eq. 1 two-mass response (`fmu_plant::analytic`) with the
//! model's viscous friction, the delay and the torque-constant scale, in axis-side units.
//! The anti-resonance is the trough of the torque-to-motor-speed response: its frequency is
//! sqrt(K/J_L) (damped), so a stiffness error shows as a shift of the measured trough against
//! the model's. Coulomb friction is not in a linear response; it shows as lower coherence at
//! low frequency.

use super::equation_error::EquationData;
use super::output_error::OutputData;
use super::parameters::{names, ParameterSet};
use antenna_dsp::{transfer_function_h1, Complex64, WelchConfig};
use fmu_plant::analytic::TwoMassParameters;

/// The comparison of measured and model responses.
#[derive(Debug, Clone)]
pub struct FrequencyResponse {
    pub frequency_hz: Vec<f64>,
    /// Measured H1 (rad/s per N m) and its coherence.
    pub measured: Vec<Complex64>,
    pub coherence: Vec<f64>,
    /// The coherence two unrelated records would exceed with 5 % probability.
    pub coherence_threshold: f64,
    /// Model responses before and after.
    pub before: Vec<Complex64>,
    pub after: Vec<Complex64>,
    /// The band searched for the anti-resonance (Hz) and whether the data excites it: the
    /// coherence exceeds its threshold over at least 80 % of the band's bins.
    pub band: (f64, f64),
    pub broadband: bool,
    /// Anti-resonance frequencies (Hz): the trough of the measured response within the band
    /// (None when the band is not excited), and of the two models' responses.
    pub measured_anti_resonance: Option<f64>,
    pub before_anti_resonance: f64,
    pub after_anti_resonance: f64,
    /// The complex response error of each model (see [`response_error`]) over the coherent
    /// bins of [`RESPONSE_BAND`], and how many bins entered it; None when fewer than
    /// [`MIN_RESPONSE_BINS`] are coherent.
    pub response_error_before: Option<f64>,
    pub response_error_after: Option<f64>,
    pub response_bins: usize,
}

/// The band of the complex response error (Hz): above the closed loop and the Coulomb
/// friction, which make H1 depart from the linear plant below about 2 Hz, and below the
/// frequencies where the current loop and the encoder noise dominate. It holds the drive's
/// anti-resonance and resonance (about 4 and 7 Hz on an antenna-like drive) and the phase
/// that a delay adds (2 pi f d grows with frequency), so it sees a stiffness and a delay alike.
pub const RESPONSE_BAND: (f64, f64) = (2.0, 60.0);

/// At least this many coherent bins for a response error.
pub const MIN_RESPONSE_BINS: usize = 20;

/// The complex error of a model's torque-to-motor-speed response against the measured H1:
/// the root of the weighted mean of |H_measured - H_model|^2 / |H_measured|^2 over the bins
/// of `band` whose coherence exceeds its 95 % threshold, each weighted by g^2 / (1 - g^2)
/// (g^2 the coherence), the inverse of the relative variance of an H1 estimate. Relative, so
/// the error in the troughs counts as much as at the peaks; complex, so a phase error (a
/// delay) counts like a gain error. Returns the error and the number of bins.
pub fn response_error(
    frequency: &[f64],
    measured: &[Complex64],
    coherence: &[f64],
    threshold: f64,
    model: &[Complex64],
    band: (f64, f64),
) -> (f64, usize) {
    let (mut sum, mut weights, mut bins) = (0.0, 0.0, 0usize);
    for k in 0..frequency.len() {
        if frequency[k] < band.0
            || frequency[k] > band.1
            || coherence[k] <= threshold
            || coherence[k].is_nan()
            || coherence[k] >= 1.0
        {
            continue;
        }
        let magnitude = measured[k].norm_sqr();
        if magnitude.is_nan() || magnitude <= 0.0 {
            continue;
        }
        let weight = coherence[k] / (1.0 - coherence[k]);
        sum += weight * (measured[k] - model[k]).norm_sqr() / magnitude;
        weights += weight;
        bins += 1;
    }
    (if weights > 0.0 { (sum / weights).sqrt() } else { f64::NAN }, bins)
}

/// The model's torque-to-motor-speed response at `f` Hz, axis-side units.
pub fn model_response(params: &ParameterSet, f: f64) -> Complex64 {
    let gear = params.value(names::GEAR_RATIO);
    let two_mass = TwoMassParameters {
        motor_inertia: params.value(names::MOTOR_INERTIA) * gear * gear,
        motor_friction: params.value(names::VISCOUS),
        shaft_stiffness: params.value(names::STIFFNESS),
        cross_coupled_damping: params.value(names::DAMPING),
        load_inertia: params.value(names::LOAD_INERTIA),
    };
    let s = Complex64::new(0.0, 2.0 * std::f64::consts::PI * f);
    let delay = (-s * params.value(names::DELAY)).exp();
    two_mass.motor_speed_per_torque(s) * delay * params.value(names::TORQUE_CONSTANT_SCALE)
}

/// The frequency of the smallest |H| among `values` at `frequency` within `band`, refined
/// between bins by a parabola through the log-magnitudes of the smallest and its neighbours.
fn trough(frequency: &[f64], values: &[f64], band: (f64, f64)) -> Option<f64> {
    let k = (0..frequency.len())
        .filter(|&k| frequency[k] >= band.0 && frequency[k] <= band.1)
        .min_by(|&a, &b| values[a].total_cmp(&values[b]))?;
    if k == 0 || k + 1 >= frequency.len() {
        return Some(frequency[k]);
    }
    let (a, b, c) = (values[k - 1].ln(), values[k].ln(), values[k + 1].ln());
    let curvature = a - 2.0 * b + c;
    let shift = if curvature > 0.0 && a.is_finite() && c.is_finite() {
        (0.5 * (a - c) / curvature).clamp(-0.5, 0.5)
    } else {
        0.0
    };
    Some(frequency[k] + shift * (frequency[k + 1] - frequency[k]))
}

/// Compares the measured response with the models', when the models have a compliant drive
/// (a stiffness and a load inertia) whose anti-resonance lies below the Nyquist frequency.
pub fn compare(
    data: &EquationData,
    out: &OutputData,
    before: &ParameterSet,
    after: &ParameterSet,
) -> Option<FrequencyResponse> {
    let stiffness = before.value(names::STIFFNESS);
    let load = before.value(names::LOAD_INERTIA);
    // The trough is in the response of the motor: a log with the load encoder alone does not
    // measure it (its "motor" angle is the load's, which has a resonance there, not a trough).
    if stiffness <= 0.0 || load <= 0.0 || !out.motor_measured {
        return None;
    }
    let sample_rate = 1.0 / data.dt;
    let anti_resonance = (stiffness / load).sqrt() / (2.0 * std::f64::consts::PI);
    let band = (0.5 * anti_resonance, 2.0 * anti_resonance);
    if band.1 >= 0.5 * sample_rate {
        return None;
    }
    // Segments of an eighth of the record (15 averages with 50 % overlap): fine resolution
    // with a coherence that separates excited from unexcited bins. At least 16 bins must fall
    // in the band.
    let segment = data.len() / 8;
    if segment < 16 || (band.1 - band.0) * segment as f64 / sample_rate < 16.0 {
        return None;
    }
    let config = WelchConfig::new(segment);
    let torque = &out.axis_torque;
    // The motor speed by five-point central differences of the logged motor angle: a flat
    // response to far above the drive modes. Its encoder noise is uncorrelated with the
    // torque, which H1 tolerates (it biases only with noise on the input).
    let k0 = out.first_sample;
    let x = &out.motor_pos;
    let speed: Vec<f64> = (0..data.len())
        .map(|i| {
            let k = (k0 + i).clamp(2, x.len() - 3);
            (x[k - 2] - 8.0 * x[k - 1] + 8.0 * x[k + 1] - x[k + 2]) / (12.0 * data.dt)
        })
        .collect();
    let speed = &speed;
    let estimate = transfer_function_h1(torque, speed, sample_rate, &config).ok()?;
    let threshold = estimate.coherence_threshold(0.95);
    let in_band: Vec<usize> = (0..estimate.frequency_hz.len())
        .filter(|&k| estimate.frequency_hz[k] >= band.0 && estimate.frequency_hz[k] <= band.1)
        .collect();
    let excited = in_band.iter().filter(|&&k| estimate.coherence[k] > threshold).count();
    let broadband = !in_band.is_empty() && excited as f64 >= 0.8 * in_band.len() as f64;
    // The trough is searched among the coherent bins only: an incoherent bin's |H1| is noise
    // and can dip below the true trough.
    let magnitude: Vec<f64> = estimate
        .h1
        .iter()
        .zip(&estimate.coherence)
        .map(|(h, &c)| if c > threshold { h.norm() } else { f64::INFINITY })
        .collect();
    let model = |p: &ParameterSet| estimate.frequency_hz.iter().map(|&f| model_response(p, f)).collect::<Vec<_>>();
    let (model_before, model_after) = (model(before), model(after));
    let band_error = |m: &[Complex64]| {
        response_error(&estimate.frequency_hz, &estimate.h1, &estimate.coherence, threshold, m, RESPONSE_BAND)
    };
    let ((error_before, bins), (error_after, _)) = (band_error(&model_before), band_error(&model_after));
    let enough = bins >= MIN_RESPONSE_BINS;
    // The model troughs on a fine grid, so they do not carry the Welch resolution.
    let fine: Vec<f64> = (0..=2000).map(|k| band.0 + (band.1 - band.0) * k as f64 / 2000.0).collect();
    let fine_trough = |p: &ParameterSet| {
        let values: Vec<f64> = fine.iter().map(|&f| model_response(p, f).norm()).collect();
        trough(&fine, &values, band).unwrap_or(f64::NAN)
    };
    Some(FrequencyResponse {
        measured_anti_resonance: if broadband { trough(&estimate.frequency_hz, &magnitude, band) } else { None },
        before_anti_resonance: fine_trough(before),
        after_anti_resonance: fine_trough(after),
        response_error_before: enough.then_some(error_before),
        response_error_after: enough.then_some(error_after),
        response_bins: bins,
        frequency_hz: estimate.frequency_hz,
        measured: estimate.h1,
        coherence: estimate.coherence,
        coherence_threshold: threshold,
        before: model_before,
        after: model_after,
        band,
        broadband,
    })
}

/// Whether the drive path is one spring between two masses: the measured response from the
/// motor speed to the load speed against the two-mass path's, (D s + K) / (J_L s^2 + D s + K).
///
/// That response involves the path alone (the motor's friction, torque constant, delay and
/// current noise act before the motor speed, and the load has no input of its own above the
/// slow unbalance and offset), so a two-mass path with the right stiffness matches it at
/// every frequency. A path with an inertia between two compliances (a gearbox, a pinion
/// shaft, a structure mode) has a second mode there: above the first one its response
/// departs from the two-mass one by far more than its noise. The check looks above twice
/// the model's own load-side mode (sqrt(K/J_L)), where the two-mass response is smooth and
/// the Welch estimate carries no resolution bias from that mode, and below 0.4 times the
/// sample rate, on the bins whose coherence exceeds its 95 % threshold and whose response is
/// known to 30 % ([`MAX_PATH_BIN_VARIANCE`]). H_model is the two-mass path that fits those
/// bins best (K/J_L and D/J_L, from the corrected model's), so that a stiffness or damping the
/// search left slightly off is not read as a second mode.
#[derive(Debug, Clone)]
pub struct PathCheck {
    /// The band checked (Hz) and the coherent bins in it that entered the statistic.
    pub band: (f64, f64),
    pub bins: usize,
    /// Sum over every second coherent bin (neighbouring Hann bins correlate) of
    /// 2 n_d g^2 |H - H_model|^2 / (|H|^2 (1 - g^2)): chi-square with 2 per bin under a
    /// two-mass path (n_d the effective averages, g^2 the coherence).
    pub chi2: f64,
    pub dof: f64,
    pub p: f64,
    /// The bin that departs most for its scatter, and |H / H_model| there.
    pub peak_hz: f64,
    pub peak_ratio: f64,
    /// The RMS over the checked bins of |H - H_model| / |H|: the size of the departure.
    pub relative_misfit: f64,
    /// Significant at the level the check was asked at, and at least as large as the
    /// estimate's own scatter, the search's practical-significance rule (at least the noise):
    /// the mean of |H - H_model|^2 over its variance is then at least 1 + 1, chi-square at
    /// least twice its degrees of freedom.
    pub departs: bool,
    /// The fitted path's spring and damping over the model's ([`PathScales`]); None where
    /// their normal equations are singular.
    pub scales: Option<PathScales>,
}

/// The two-mass path fitted to the measured response against the corrected model's: its
/// K/J_L and D/J_L as fractions of the model's, each with its standard error (the inverse of
/// the fit's normal matrix over every second coherent bin, the bins the chi-square counts).
///
/// A lost motion in the path (backlash) is a dead zone in series with the spring and its
/// damper: over a small oscillation its describing function scales the element's whole force,
/// so the fitted spring and damping fall by the same fraction (on the suite's backlash logs
/// 0.84-0.95 of the model's, each within two standard errors of the other). A change of the
/// spring alone moves K/J_L and leaves D/J_L where it was (a drifting-tacho log with the
/// stiffness 0.937 of the start's: spring 0.938 +- 0.001, damping 0.997 +- 0.007).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PathScales {
    pub spring: f64,
    pub spring_sd: f64,
    pub damping: f64,
    pub damping_sd: f64,
}

impl PathScales {
    /// The z-statistic of the lost-motion reading (spring and damping scaled alike) when the
    /// spring departs from the model's at `z` standard errors or more and the damping does not
    /// follow it within `z` standard errors of their difference: the path's spring itself is
    /// then off, which a backlash cannot stand for. None otherwise.
    pub fn spring_alone(&self, z: f64) -> Option<f64> {
        let departs = (self.spring - 1.0).abs() >= z * self.spring_sd;
        let apart = (self.damping - self.spring) / self.spring_sd.hypot(self.damping_sd);
        (departs && apart.abs() >= z).then_some(apart)
    }
}

impl PathCheck {
    /// The note when the path's spring alone is off ([`PathScales::spring_alone`]) at `z`
    /// standard errors, with the effect the search named in its place, if any; None when the
    /// path is not a two-mass one (it departs) or the spring is not off alone.
    pub fn spring_alone_note(&self, z: f64, named: Option<&str>) -> Option<String> {
        let apart = self.spring_alone(z)?;
        let scales = self.scales?;
        let reading = match named {
            Some(kind) => format!(
                "{kind}: the data cannot tell it from a stiffness change (a spring of about {:.3} times the model's)",
                scales.spring
            ),
            None => {
                format!("a stiffness change (a spring of about {:.3} times the model's) is not claimed", scales.spring)
            }
        };
        Some(format!(
            "the measured motor-to-load response's spring (K/J_L) is {:.3} +- {:.3} of the corrected model's while its damping (D/J_L) is {:.3} +- {:.3} ({:.1} standard errors apart): a lost motion scales both alike (its describing function scales the whole spring-damper element), so the path's spring itself is off; {reading}",
            scales.spring, scales.spring_sd, scales.damping, scales.damping_sd, apart.abs()
        ))
    }

    /// [`PathScales::spring_alone`] of a two-mass path (None where the path departs).
    pub fn spring_alone(&self, z: f64) -> Option<f64> {
        self.scales.filter(|_| !self.departs)?.spring_alone(z)
    }

    /// One sentence for the report and the summary.
    pub fn describe(&self) -> String {
        if self.departs {
            format!(
                "the measured motor-to-load response departs from the two-mass path's over {:.1}-{:.1} Hz (chi-square {:.0} on {:.0} degrees of freedom, p {:.1e}; RMS {:.0} % of the model's response, largest at {:.1} Hz, where it is {:.2} times the model's): the drive path has a second mode (an inertia between two compliances, a structure mode) or a nonlinearity that a two-mass model does not have, so a stiffness found for it is the two-mass model's effective value for this drive (a model-form stand-in), not a change of one spring",
                self.band.0,
                self.band.1,
                self.chi2,
                self.dof,
                self.p,
                100.0 * self.relative_misfit,
                self.peak_hz,
                self.peak_ratio
            )
        } else {
            format!(
                "the measured motor-to-load response is the two-mass path's within its scatter over {:.1}-{:.1} Hz ({} coherent bins, chi-square {:.0} on {:.0} degrees of freedom, p {:.2}; RMS {:.0} % of the model's response)",
                self.band.0,
                self.band.1,
                self.bins,
                self.chi2,
                self.dof,
                self.p,
                100.0 * self.relative_misfit
            )
        }
    }
}

/// The two-mass path's response from motor speed to load speed at `f` Hz.
pub fn path_response(params: &ParameterSet, f: f64) -> Complex64 {
    let s = Complex64::new(0.0, 2.0 * std::f64::consts::PI * f);
    let spring = s * params.value(names::DAMPING) + params.value(names::STIFFNESS);
    spring / (s * s * params.value(names::LOAD_INERTIA) + spring)
}

/// The fewest coherent bins the path check is made on.
pub const MIN_PATH_BINS: usize = 16;

/// The largest relative variance (1 - g^2) / (n_d g^2) of a bin's H1 that enters the path
/// check: its response known to 30 % (standard error). Coherence is estimated with a bias
/// upward where the true one is small, and a bin of noise that passes the 95 % threshold by
/// chance (one in twenty of the incoherent ones) would count as a gross departure from any
/// model; with 15 averages this asks for a coherence of about 0.45, which an incoherent bin
/// reaches with probability 0.55^14 = 2e-4.
pub const MAX_PATH_BIN_VARIANCE: f64 = 0.09;

/// Checks whether a two-mass path, fitted from the model `params`'s, describes a log with two
/// encoders ([`PathCheck`]), at the significance level `level`. None without a compliant model, a motor measurement or
/// enough coherent bins.
pub fn check_path(data: &EquationData, out: &OutputData, params: &ParameterSet, level: f64) -> Option<PathCheck> {
    let (stiffness, load) = (params.value(names::STIFFNESS), params.value(names::LOAD_INERTIA));
    if stiffness <= 0.0 || load <= 0.0 || !out.motor_measured || !out.two_encoders {
        return None;
    }
    let speed = |x: &[f64]| -> Vec<f64> {
        let k0 = out.first_sample;
        (0..data.len())
            .map(|i| {
                let k = (k0 + i).clamp(2, x.len() - 3);
                (x[k - 2] - 8.0 * x[k - 1] + 8.0 * x[k + 1] - x[k + 2]) / (12.0 * data.dt)
            })
            .collect()
    };
    check_path_speeds(&speed(&out.motor_pos), &speed(&out.load_pos), 1.0 / data.dt, params, level)
}

/// [`check_path`] on the motor and load speeds (axis side, rad/s) sampled at `sample_rate`.
pub fn check_path_speeds(
    motor_speed: &[f64],
    load_speed: &[f64],
    sample_rate: f64,
    params: &ParameterSet,
    level: f64,
) -> Option<PathCheck> {
    let (stiffness, load) = (params.value(names::STIFFNESS), params.value(names::LOAD_INERTIA));
    let band = (2.0 * (stiffness / load).sqrt() / (2.0 * std::f64::consts::PI), 0.4 * sample_rate);
    let segment = motor_speed.len() / 8;
    if segment < 16 || band.1 <= band.0 {
        return None;
    }
    let config = WelchConfig::new(segment);
    let estimate = transfer_function_h1(motor_speed, load_speed, sample_rate, &config).ok()?;
    let threshold = estimate.coherence_threshold(0.95);
    let averages = 0.5 * estimate.dof;
    let coherent: Vec<usize> = (0..estimate.frequency_hz.len())
        .filter(|&k| {
            let (f, g) = (estimate.frequency_hz[k], estimate.coherence[k]);
            f >= band.0
                && f <= band.1
                && g > threshold
                && g < 1.0
                && (1.0 - g) / (averages * g) <= MAX_PATH_BIN_VARIANCE
                && estimate.h1[k].norm() > 0.0
        })
        .collect();
    if coherent.len() < MIN_PATH_BINS {
        return None;
    }
    let bins: Vec<(f64, Complex64, f64)> = coherent
        .iter()
        .map(|&k| {
            let g = estimate.coherence[k];
            (estimate.frequency_hz[k], estimate.h1[k], (1.0 - g) / (averages * g))
        })
        .collect();
    let (model_a, model_b) = (stiffness / load, params.value(names::DAMPING) / load);
    let (a, b) = best_two_mass_path(&bins, model_a, model_b);
    let scales = path_scales(&bins, a, b, model_a, model_b);
    let (mut chi2, mut used, mut misfit) = (0.0, 0usize, 0.0);
    let (mut largest, mut peak_hz, mut peak_ratio) = (0.0, f64::NAN, f64::NAN);
    for (n, &k) in coherent.iter().enumerate() {
        let (f, g, h) = (estimate.frequency_hz[k], estimate.coherence[k], estimate.h1[k]);
        let model = normalised_path(a, b, f);
        let relative = (h - model).norm_sqr() / h.norm_sqr();
        let variance = (1.0 - g) / (averages * g);
        misfit += relative;
        if relative / variance > largest {
            (largest, peak_hz, peak_ratio) = (relative / variance, f, h.norm() / model.norm());
        }
        if n % 2 == 0 {
            chi2 += 2.0 * relative / variance;
            used += 1;
        }
    }
    let dof = (2.0 * used as f64 - 2.0).max(1.0);
    let p = antenna_dsp::distributions::chi_squared_sf(chi2, dof);
    let relative_misfit = (misfit / coherent.len() as f64).sqrt();
    Some(PathCheck {
        band,
        bins: coherent.len(),
        chi2,
        dof,
        p,
        peak_hz,
        peak_ratio,
        relative_misfit,
        departs: p < level && chi2 >= 2.0 * dof,
        scales,
    })
}

/// The fitted path's (a, b) = (K/J_L, D/J_L) over the model's, with standard errors from the
/// normal matrix of the fit's weighted residuals (H - T) / (|H| sigma) over every second bin
/// (neighbouring Hann bins correlate), each bin's real and imaginary parts with half its
/// relative variance.
fn path_scales(bins: &[(f64, Complex64, f64)], a: f64, b: f64, model_a: f64, model_b: f64) -> Option<PathScales> {
    let mut information = [[0.0; 2]; 2];
    for &bin in bins.iter().step_by(2) {
        let (_, columns) = weighted_path_residual(bin, a, b);
        for i in 0..2 {
            for j in 0..2 {
                information[i][j] += 2.0 * (columns[i].conj() * columns[j]).re;
            }
        }
    }
    let det = information[0][0] * information[1][1] - information[0][1] * information[1][0];
    if !(det.is_finite() && det > 0.0 && model_a > 0.0 && model_b > 0.0) {
        return None;
    }
    Some(PathScales {
        spring: a / model_a,
        spring_sd: (information[1][1] / det).sqrt() / model_a,
        damping: b / model_b,
        damping_sd: (information[0][0] / det).sqrt() / model_b,
    })
}

/// The two-mass path (b s + a) / (s^2 + b s + a), a = K/J_L and b = D/J_L, at `f` Hz.
fn normalised_path(a: f64, b: f64, f: f64) -> Complex64 {
    let s = Complex64::new(0.0, 2.0 * std::f64::consts::PI * f);
    (s * b + a) / (s * s + s * b + a)
}

/// One bin's (frequency, H1, relative variance) residual against the path (a, b), weighted by
/// 1/(|H| sigma), and its derivatives by a and b: what the path's fit and its standard errors
/// are made of.
fn weighted_path_residual((f, h, v): (f64, Complex64, f64), a: f64, b: f64) -> (Complex64, [Complex64; 2]) {
    let s = Complex64::new(0.0, 2.0 * std::f64::consts::PI * f);
    let denominator = s * s + s * b + a;
    let scale = 1.0 / (h.norm() * v.sqrt());
    let residual = (h - (s * b + a) / denominator) * scale;
    let d_a = s * s / (denominator * denominator) * scale;
    let d_b = s * s * s / (denominator * denominator) * scale;
    (residual, [d_a, d_b])
}

/// The two-mass path that fits the measured bins (frequency, H1, relative variance) best:
/// Gauss-Newton on (H - T) / (|H| sigma) from the model's (a, b), a step taken only when it
/// lowers the sum of squares. The check asks whether any two-mass path describes the
/// response, not whether the corrected one does: a stiffness or damping that the search left
/// slightly off is a parameter error, not a second mode.
fn best_two_mass_path(bins: &[(f64, Complex64, f64)], a0: f64, b0: f64) -> (f64, f64) {
    let cost = |a: f64, b: f64| -> f64 {
        bins.iter().map(|&(f, h, v)| (h - normalised_path(a, b, f)).norm_sqr() / (h.norm_sqr() * v)).sum()
    };
    let (mut a, mut b) = (a0, b0);
    let mut current = cost(a, b);
    for _ in 0..20 {
        // Normal equations of the two real parameters, from the real and imaginary parts.
        let (mut jtj, mut jtr) = ([[0.0; 2]; 2], [0.0; 2]);
        for &bin in bins {
            let (residual, columns) = weighted_path_residual(bin, a, b);
            for i in 0..2 {
                jtr[i] += (columns[i].conj() * residual).re;
                for j in 0..2 {
                    jtj[i][j] += (columns[i].conj() * columns[j]).re;
                }
            }
        }
        let det = jtj[0][0] * jtj[1][1] - jtj[0][1] * jtj[1][0];
        if det.abs() <= 0.0 || !det.is_finite() {
            break;
        }
        let step_a = (jtj[1][1] * jtr[0] - jtj[0][1] * jtr[1]) / det;
        let step_b = (jtj[0][0] * jtr[1] - jtj[1][0] * jtr[0]) / det;
        let (next_a, next_b) = (a + step_a, b + step_b);
        let next = cost(next_a, next_b);
        // A step that does not lower the cost (or gives NaN) or leaves the physical range ends it.
        let lowers = next < current;
        if !lowers || next_a <= 0.0 || next_b < 0.0 {
            break;
        }
        (a, b, current) = (next_a, next_b, next);
    }
    (a, b)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Motor and load speeds of a path whose response from motor to load speed is `path`:
    /// the motor speed a sum of 400 sinusoids (random frequencies up to 120 Hz, random
    /// phases), the load speed the same sinusoids through `path` plus white sensor noise.
    fn speeds_through(path: &dyn Fn(f64) -> Complex64, sample_rate: f64, n: usize) -> (Vec<f64>, Vec<f64>) {
        use rand::SeedableRng;
        use rand_distr::Distribution;
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
        let normal = rand_distr::Normal::new(0.0, 0.2).unwrap();
        let (frequencies, phases) = (
            rand_distr::Uniform::new(0.5, 120.0).unwrap(),
            rand_distr::Uniform::new(0.0, std::f64::consts::TAU).unwrap(),
        );
        let (mut motor, mut load) = (vec![0.0; n], vec![0.0; n]);
        for _ in 0..400 {
            let (f, phase) = (frequencies.sample(&mut rng), phases.sample(&mut rng));
            let response = path(f);
            for i in 0..n {
                let x = 2.0 * std::f64::consts::PI * f * i as f64 / sample_rate + phase;
                motor[i] += x.cos();
                load[i] += response.norm() * (x + response.arg()).cos();
            }
        }
        load.iter_mut().for_each(|v| *v += normal.sample(&mut rng));
        (motor, load)
    }

    fn path_parameters() -> ParameterSet {
        let mut params = ParameterSet::default();
        params.set(names::STIFFNESS, 3.79e7);
        params.set(names::DAMPING, 1.2e5);
        params.set(names::LOAD_INERTIA, 6.0e4);
        params
    }

    #[test]
    fn a_two_mass_path_matches_and_a_second_mode_departs() {
        let (sample_rate, n) = (500.0, 30_000);
        let params = path_parameters();
        let two_mass = |f: f64| path_response(&params, f);
        let (motor, load) = speeds_through(&two_mass, sample_rate, n);
        let check = check_path_speeds(&motor, &load, sample_rate, &params, 1e-3).expect("coherent bins");
        assert!(!check.departs, "{}", check.describe());
        // The same path with a second mode at 30 Hz (damping ratio 0.04) in series.
        let w2 = 2.0 * std::f64::consts::PI * 30.0;
        let three_mass = |f: f64| {
            let s = Complex64::new(0.0, 2.0 * std::f64::consts::PI * f);
            path_response(&params, f) * w2 * w2 / (s * s + 2.0 * 0.04 * w2 * s + w2 * w2)
        };
        let (motor, load) = speeds_through(&three_mass, sample_rate, n);
        let check = check_path_speeds(&motor, &load, sample_rate, &params, 1e-3).expect("coherent bins");
        assert!(check.departs, "{}", check.describe());
        assert!((check.peak_hz - 30.0).abs() < 3.0, "{}", check.describe());
    }

    #[test]
    fn a_spring_change_is_told_from_a_lost_motion_by_the_damping() {
        let (sample_rate, n) = (500.0, 30_000);
        let params = path_parameters();
        let scaled = |spring: f64, damping: f64| {
            let mut p = params.clone();
            p.set(names::STIFFNESS, spring * params.value(names::STIFFNESS));
            p.set(names::DAMPING, damping * params.value(names::DAMPING));
            p
        };
        let check_of = |truth: ParameterSet| {
            let (motor, load) = speeds_through(&|f| path_response(&truth, f), sample_rate, n);
            check_path_speeds(&motor, &load, sample_rate, &params, 1e-3).expect("coherent bins")
        };
        // The spring 6 % softer, the damper as it was: the spring alone is off.
        let spring = check_of(scaled(0.94, 1.0));
        let scales = spring.scales.expect("scales");
        assert!((scales.spring - 0.94).abs() < 3.0 * scales.spring_sd, "{scales:?}");
        assert!(spring.spring_alone(5.0).is_some(), "{scales:?}");
        assert!(spring
            .spring_alone_note(5.0, Some("backlash"))
            .expect("note")
            .contains("backlash: the data cannot tell"));
        // A lost motion's describing function scales both alike: not the spring alone.
        let element = check_of(scaled(0.94, 0.94));
        assert!(element.spring_alone(5.0).is_none(), "{:?}", element.scales);
        // The model's own path: nothing is off.
        assert!(check_of(params.clone()).spring_alone(5.0).is_none());
    }

    #[test]
    fn response_error_of_a_delayed_model_is_the_phase_chord() {
        // A model that only lacks a delay d errs by |1 - exp(-j w d)| = 2 |sin(pi f d)| in
        // every bin; with equal coherence the weighted mean is the plain mean.
        let frequency: Vec<f64> = (0..200).map(|k| 0.5 * k as f64).collect();
        let d = 2e-3;
        let measured: Vec<Complex64> = frequency
            .iter()
            .map(|&f| Complex64::new(0.0, -2.0 * std::f64::consts::PI * f * d).exp() * (1.0 + f))
            .collect();
        let model: Vec<Complex64> = frequency.iter().map(|&f| Complex64::new(1.0 + f, 0.0)).collect();
        let coherence = vec![0.9; frequency.len()];
        let (error, bins) = response_error(&frequency, &measured, &coherence, 0.5, &model, RESPONSE_BAND);
        let inside: Vec<f64> =
            frequency.iter().copied().filter(|f| *f >= RESPONSE_BAND.0 && *f <= RESPONSE_BAND.1).collect();
        let expected = (inside.iter().map(|f| (2.0 * (std::f64::consts::PI * f * d).sin()).powi(2)).sum::<f64>()
            / inside.len() as f64)
            .sqrt();
        assert_eq!(bins, inside.len());
        assert!((error - expected).abs() < 1e-12 * expected, "{error} against {expected}");
        // The measured response itself has no error, and incoherent bins are left out.
        assert_eq!(response_error(&frequency, &measured, &coherence, 0.5, &measured, RESPONSE_BAND).0, 0.0);
        assert_eq!(response_error(&frequency, &measured, &coherence, 0.95, &model, RESPONSE_BAND).1, 0);
    }
}
