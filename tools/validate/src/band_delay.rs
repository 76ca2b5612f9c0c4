//! The delay of the applied torque estimated over the band the equation error's smoothing
//! takes away.
//!
//! The search tries delays on the smoothed torque balance, whose cut-off (about 10 Hz on the
//! suite's drives) keeps the encoder noise of the accelerations below the torque noise. A delay
//! d turns the measured torque's spectrum by a phase 2 pi f d, so below the cut-off a delay of a
//! fraction of a millisecond moves the balance by less than the torque noise, however clean the
//! current is. Above the cut-off the rest of the model (inertia, shaft) is known to the same
//! accuracy, and the acceleration's noise grows as f^2 from the encoders' quantisation: the
//! weight of a frequency bin falls off by itself where that noise takes over. This module fits
//! the torque-rate column in the frequency domain: per segment of the log, the residual
//! spectrum R (the measured torque less the model, with the fast terms taken from the
//! unsmoothed encoders) against X = i 2 pi f T (what a larger delay changes), each bin weighted
//! by the inverse of its own noise power, estimated from the residual left over all segments.
//! Only the part of R in quadrature with the torque counts, so an inertia or stiffness error,
//! which is in phase with it, does not read as a delay. The uncertainty is the scatter of the
//! estimate over the independent segments, so it needs no model of how the bins correlate.

use crate::equation_error::{
    model_channels, static_friction_curve, EquationData, Structure, RIGID_CUTOFF_FRACTION_OF_ANTI_RESONANCE,
};
use crate::parameters::{names, ParameterSet};
use antenna_dsp::spectral::{segment_spectra, WelchConfig};
use antenna_dsp::window::Window;
use std::f64::consts::PI;

/// Length of the segments (s): bins 4 Hz apart, so that a 10 s log has 40 independent
/// segments for the scatter and the band starts well below the smoothed equation's cut-off.
pub const SEGMENT_SECONDS: f64 = 0.25;

/// Neighbouring bins on each side averaged into a bin's noise power.
const NOISE_BINS: usize = 4;

/// Fewer independent segments than this leave the scatter too uncertain for a test.
const MIN_SEGMENTS: usize = 8;

/// Gauss-Newton passes on the delay at most.
const MAX_ITERATIONS: usize = 6;

/// The delay estimated over the unsmoothed band.
#[derive(Debug, Clone, PartialEq)]
pub struct BandDelay {
    /// The parameter set's delay the estimate starts from (s).
    pub start: f64,
    /// The estimated change of the delay (s) and its standard error (s).
    pub change: f64,
    pub sigma: f64,
    /// Half the difference between the delays of the band's lower and upper halves: the
    /// estimate's model-form floor on this log ([`band_halves_spread`]).
    pub form_spread: f64,
    /// The band that carries the estimate: from the frequency below which 5 % of its weight
    /// lies to the one below which 95 % lies (Hz).
    pub band_hz: (f64, f64),
    /// The highest frequency used (Hz): the Nyquist frequency, or a third of the
    /// anti-resonance on a compliant drive with one encoder.
    pub top_hz: f64,
    pub segments: usize,
    pub dt: f64,
    /// A delay within the search's range (0 to [`crate::candidates::DELAY_SEARCH_SECONDS`])
    /// that turns the measured torque onto the model with less residual power over the band
    /// than the estimate, outside the estimate's own basin: the estimate is then the wrapped
    /// remainder of that longer delay ([`longer_delay_fitting_better`]).
    pub beaten_by: Option<f64>,
}

impl BandDelay {
    /// The estimated delay (s).
    pub fn delay(&self) -> f64 {
        self.start + self.change
    }

    /// The chi-square (1 degree of freedom) of the change against no change.
    pub fn chi2(&self) -> f64 {
        if self.sigma > 0.0 {
            (self.change / self.sigma).powi(2)
        } else {
            0.0
        }
    }

    /// Whether the change is a significant increase at the one-sided p `threshold`: a delay
    /// shorter than the set's start (at the suite's neutral start, a negative one) is not a
    /// drive's.
    pub fn significant(&self, threshold: f64) -> bool {
        self.change > 0.0 && 0.5 * antenna_dsp::chi_squared_sf(self.chi2(), 1.0) < threshold
    }

    /// Whether the change is significant at the one-sided p `threshold` beyond its model-form
    /// floor: the change less the spread between the band's halves still passes the test. A
    /// delay claimed from the band needs this; a model error that reads as a delay differs
    /// between the halves.
    pub fn significant_beyond_floor(&self, threshold: f64) -> bool {
        let beyond = self.change - self.form_spread;
        beyond > 0.0
            && self.sigma > 0.0
            && 0.5 * antenna_dsp::chi_squared_sf((beyond / self.sigma).powi(2), 1.0) < threshold
    }

    /// The smallest change the test finds significant at the one-sided p `threshold` (s).
    pub fn limit(&self, threshold: f64) -> f64 {
        self.sigma * antenna_dsp::distributions::chi_squared_quantile(1.0 - 2.0 * threshold, 1.0).sqrt()
    }

    /// The method and its range in words, for a limit or a finding.
    pub fn method(&self) -> String {
        format!(
            "the band estimate (unsmoothed torque balance, {} segments of {:.2} s, weight in {:.0}-{:.0} Hz, bins up to {:.0} Hz)",
            self.segments,
            SEGMENT_SECONDS,
            self.band_hz.0,
            self.band_hz.1,
            self.top_hz
        )
    }
}

/// The scale of the band estimate's model-form floor (s): on clean logs (no skew, no delay)
/// it gave -0.01 to -0.13 ms while the presliding segments were in the estimate (500 Hz to
/// 2 kHz), +0.016 to +0.025 ms since (the truth generator's own half-step lag), so a negative
/// delay within that scale is not read as a skew, however significant.
pub const MODEL_FORM_FLOOR: f64 = 1.0e-4;

/// A current logged late against the encoders: the band estimate of the delay, from no delay,
/// came out negative (the motion answers before the logged current), which no drive's delay
/// can be. It is a property of the data acquisition, corrected in the data before the search.
#[derive(Debug, Clone, PartialEq)]
pub struct CurrentSkew {
    /// The band estimate from no delay (its `delay()` is the negative of the skew).
    pub estimate: BandDelay,
    /// The one-sided p level it was tested at.
    pub level: f64,
}

impl CurrentSkew {
    /// How much later than the encoders the current was stamped (s, positive).
    pub fn late(&self) -> f64 {
        -self.estimate.delay()
    }

    /// One line for reports.
    pub fn describe(&self) -> String {
        let e = &self.estimate;
        format!(
            "the current is logged {:.3} +- {:.3} ms ({:.2} samples) later than the encoders: the motion answers before the logged current, a negative delay no drive has (chi-square {:.1} at the one-sided level {:.1e}, beyond the band estimate's model-form floor of {:.2} ms; {})",
            self.late() * 1e3,
            e.sigma * 1e3,
            self.late() / e.dt,
            (e.delay() / e.sigma.max(f64::MIN_POSITIVE)).powi(2),
            self.level,
            MODEL_FORM_FLOOR * 1e3,
            e.method()
        )
    }
}

/// A current skew in the data: the band estimate from no delay (`params` with its delay set
/// to zero) is negative, significant at the one-sided p `level` and beyond
/// [`MODEL_FORM_FLOOR`]. A positive estimate is a drive delay or a current logged early,
/// which the data cannot tell apart; it is left to the delay candidate.
///
/// Only with two encoders and a two-mass set, where the estimate was measured against known
/// skews: a velocity-proportional model error is in quadrature with the torque too and can
/// read as a negative delay (a viscous coefficient 14 N m s/rad low on the rigid drive of
/// `tests/recheck.rs` was taken for a skew).
pub fn current_skew(data: &EquationData, params: &ParameterSet, level: f64) -> Option<CurrentSkew> {
    if data.structure != Structure::TwoMass {
        return None;
    }
    let mut from_zero = params.clone();
    from_zero.set(names::DELAY, 0.0);
    let estimate = estimate(data, &from_zero)?;
    (estimate.beaten_by.is_none() && is_skew(estimate.delay(), estimate.sigma, estimate.form_spread, level))
        .then_some(CurrentSkew { estimate, level })
}

/// Whether an apparent delay `delay` (s) with standard error `sigma` is a current skew: below
/// zero beyond the model-form floor's scale, and still below zero at the one-sided p `level`
/// once this log's own floor, the spread `form_spread` between the band's halves, is added.
/// A skew shifts the current by one time at every frequency; a delay of several milliseconds
/// turns the band's phase by more than a cycle, and its wrapped remainder reads as a small
/// delay of either sign that differs between the halves (a 9 ms delay at 2 kHz read as a
/// current 0.12 ms late).
fn is_skew(delay: f64, sigma: f64, form_spread: f64, level: f64) -> bool {
    let beyond = -delay - form_spread.max(0.0);
    let chi2 = (beyond / sigma.max(f64::MIN_POSITIVE)).powi(2);
    delay < -MODEL_FORM_FLOOR && beyond > 0.0 && 0.5 * antenna_dsp::chi_squared_sf(chi2, 1.0) < level
}

/// The log with its current (or torque) columns read `by` seconds later: the value logged `by`
/// later stands at each row, which undoes a current stamped `by` late. Cubic interpolation on
/// a uniform log, linear on an uneven one; the ends are held.
pub fn shift_current(log: &crate::measured_log::MeasuredLog, by: f64) -> crate::measured_log::MeasuredLog {
    use crate::measured_log::Signal;
    crate::twist::shift_signals(log, &[Signal::MotorCurrent, Signal::MotorCurrentCommand, Signal::MotorTorque], by)
}

/// The delay of the applied torque from the parameter set's, over the unsmoothed band of the
/// torque balance (the motor equation with two encoders, the total one otherwise). `None`
/// when the log is too short for enough segments or nothing in it carries a delay.
pub fn estimate(data: &EquationData, params: &ParameterSet) -> Option<BandDelay> {
    let dt = data.dt;
    let n = data.len();
    let first = data.first_sample;
    if data.raw_torque.len() < first + n + 1 || first == 0 {
        return None;
    }
    let segment_len = (SEGMENT_SECONDS / dt).round() as usize;
    let config = WelchConfig::new(segment_len).with_overlap(0.0).with_window(Window::Hann);
    let segments = config.segment_count(n);
    if segment_len < 16 || segments < MIN_SEGMENTS {
        return None;
    }
    let (measured, model, sliding) = balance(data, params);
    // Only segments in which the motor slides throughout: where it slows to the stick speed
    // its friction is in presliding, a stiff spring with the bristles' damping that holds the
    // motor (a mode near 190 Hz on the suite's drive), and the torque the motor does not
    // follow there reads as a negative delay (-0.02 to -0.13 ms on clean 2 kHz logs with a
    // noiseless current). The smoothed equation leaves the same samples out.
    let keep: Vec<bool> =
        (0..segments).map(|s| sliding[s * segment_len..(s + 1) * segment_len].iter().all(|&m| m)).collect();
    let used_segments = keep.iter().filter(|&&k| k).count();
    if used_segments < MIN_SEGMENTS {
        return None;
    }
    let kept = |spectra: Vec<Vec<antenna_dsp::spectral::Complex64>>| -> Vec<Vec<antenna_dsp::spectral::Complex64>> {
        spectra.into_iter().zip(&keep).filter(|(_, &k)| k).map(|(s, _)| s).collect()
    };
    let t_spectra = kept(segment_spectra(&measured, &config).ok()?);
    let m_spectra = kept(segment_spectra(&model, &config).ok()?);
    let bins = segment_len / 2 + 1;
    let top_hz = top_frequency(data, params);
    let frequency: Vec<f64> = (0..bins).map(|k| k as f64 / (segment_len as f64 * dt)).collect();
    // The lowest bins, where the window's own derivative and the slow model errors are, and
    // any above the top, are left out.
    let used: Vec<usize> = (2..bins).filter(|&k| frequency[k] <= top_hz && k < bins - 1).collect();
    if used.is_empty() {
        return None;
    }
    // The torque's own noise is in the torque rate too, where it adds power that no delay
    // explains and would pull the estimate towards zero (errors in the variable): its expected
    // power per bin, (2 pi f)^2 times the white noise's power through the window, comes off.
    let window_power: f64 = Window::Hann.coefficients(segment_len).iter().map(|w| w * w).sum();
    let scale = params.value(names::TORQUE_CONSTANT_SCALE);
    let rate_noise: Vec<f64> =
        frequency.iter().map(|f| (2.0 * PI * f * scale * data.torque_sigma).powi(2) * window_power).collect();
    // Gauss-Newton on the delay with the torque delayed exactly in the frequency domain
    // (T e^{-i w d}): at a few hundred hertz a delay of a sample turns the torque by tens of
    // degrees, where the first-order column alone would underestimate it by a quarter. Each
    // pass takes the bins' noise from the residual the current delay leaves, so a large delay
    // does not count as its own noise.
    let start = params.value(names::DELAY);
    let mut delay = start;
    let mut result = None;
    for _ in 0..MAX_ITERATIONS {
        let (x, r) = delayed_spectra(&t_spectra, &m_spectra, &frequency, delay);
        let noise = noise_power(&x, &r, 0.0, &used, bins);
        let fit = weighted_fit(&x, &r, &noise, &rate_noise, &used)?;
        delay += fit.0;
        let step = fit.0.abs();
        result = Some(fit);
        if step < 1e-3 * dt {
            break;
        }
    }
    let (_, sigma, information) = result?;
    let change = delay - start;
    let band_hz = weight_band(&information, &used, &frequency);
    let form_spread = band_halves_spread(&t_spectra, &m_spectra, &frequency, delay, &used, &information, &rate_noise);
    let beaten_by = longer_delay_fitting_better(&t_spectra, &m_spectra, &frequency, &used, delay, dt);
    Some(BandDelay {
        start: params.value(names::DELAY),
        change,
        sigma,
        form_spread,
        band_hz,
        top_hz: top_hz.min(frequency[bins - 1]),
        segments: used_segments,
        dt,
        beaten_by,
    })
}

/// A delay on a grid of half a sample over the search's range (0 to
/// [`crate::candidates::DELAY_SEARCH_SECONDS`]) that leaves less residual power over the
/// band's bins than `delay`, more than a sample away from it. The Gauss-Newton estimate
/// starts from the parameter set's delay and finds the nearest minimum: a delay of many
/// milliseconds turns the band's phase by cycles, and from zero its wrapped remainder is a
/// local minimum of a fraction of a millisecond of either sign (a 21 ms delay on a 500 Hz log
/// read as a current 0.28 ms late). A skew or a delay that is the log's own is the band's
/// global minimum over that range.
fn longer_delay_fitting_better(
    t_spectra: &[Vec<antenna_dsp::spectral::Complex64>],
    m_spectra: &[Vec<antenna_dsp::spectral::Complex64>],
    frequency: &[f64],
    used: &[usize],
    delay: f64,
    dt: f64,
) -> Option<f64> {
    let power = |d: f64| -> f64 {
        let turns: Vec<(f64, f64)> = used.iter().map(|&k| (2.0 * PI * frequency[k] * d).sin_cos()).collect();
        t_spectra
            .iter()
            .zip(m_spectra)
            .map(|(t, m)| {
                used.iter()
                    .zip(&turns)
                    .map(|(&k, &(s, c))| {
                        let (re, im) = (t[k].re * c + t[k].im * s, t[k].im * c - t[k].re * s);
                        (re - m[k].re).powi(2) + (im - m[k].im).powi(2)
                    })
                    .sum::<f64>()
            })
            .sum()
    };
    let own = power(delay);
    let step = 0.5 * dt;
    let steps = (crate::candidates::DELAY_SEARCH_SECONDS / step).round() as usize;
    (0..=steps)
        .map(|j| j as f64 * step)
        .filter(|d| (d - delay).abs() > dt)
        .map(|d| (d, power(d)))
        .filter(|(_, p)| *p < own)
        .min_by(|a, b| a.1.total_cmp(&b.1))
        .map(|(d, _)| d)
}

/// Half the difference between the delays the lower and the upper half of the band (by
/// information) give on their own, from the delay `delay` the whole band gives. A delay turns
/// the torque by the same time at every frequency; a model error in quadrature with the torque
/// (a damping, presliding friction, the smoothing of a slow term) reads as a delay that
/// changes with frequency, as 1/f^2 for a damping. The spread is this log's own measure of
/// the estimate's model-form floor (the estimation noise of the two halves included, so it
/// errs on the large side).
fn band_halves_spread(
    t_spectra: &[Vec<antenna_dsp::spectral::Complex64>],
    m_spectra: &[Vec<antenna_dsp::spectral::Complex64>],
    frequency: &[f64],
    delay: f64,
    used: &[usize],
    information: &[f64],
    rate_noise: &[f64],
) -> f64 {
    let total: f64 = used.iter().map(|&k| information[k].max(0.0)).sum();
    let mut cumulative = 0.0;
    let split = used
        .iter()
        .position(|&k| {
            cumulative += information[k].max(0.0);
            cumulative >= 0.5 * total
        })
        .map_or(used.len() / 2, |p| p + 1)
        .clamp(1, used.len().saturating_sub(1).max(1));
    let (lower, upper) = used.split_at(split);
    if lower.is_empty() || upper.is_empty() {
        return f64::INFINITY;
    }
    let (x, r) = delayed_spectra(t_spectra, m_spectra, frequency, delay);
    let noise = noise_power(&x, &r, 0.0, used, frequency.len());
    let half = |bins: &[usize]| weighted_fit(&x, &r, &noise, rate_noise, bins).map(|fit| fit.0);
    match (half(lower), half(upper)) {
        (Some(low), Some(high)) => 0.5 * (low - high).abs(),
        _ => f64::INFINITY,
    }
}

/// Per segment and bin, the torque rate of the torque delayed by `delay`, i w T e^{-i w d}
/// (the column of a change of the delay), and the balance's residual T e^{-i w d} - M.
#[allow(clippy::type_complexity)]
fn delayed_spectra(
    torque: &[Vec<antenna_dsp::spectral::Complex64>],
    model: &[Vec<antenna_dsp::spectral::Complex64>],
    frequency: &[f64],
    delay: f64,
) -> (Vec<Vec<(f64, f64)>>, Vec<Vec<(f64, f64)>>) {
    let mut x = Vec::with_capacity(torque.len());
    let mut r = Vec::with_capacity(torque.len());
    for (t, m) in torque.iter().zip(model) {
        let mut xs = Vec::with_capacity(t.len());
        let mut rs = Vec::with_capacity(t.len());
        for (k, (tk, mk)) in t.iter().zip(m).enumerate() {
            let w = 2.0 * PI * frequency[k];
            let (c, s) = ((w * delay).cos(), (w * delay).sin());
            // T e^{-i w d} = (re + i im)(c - i s).
            let (re, im) = (tk.re * c + tk.im * s, tk.im * c - tk.re * s);
            xs.push((-w * im, w * re));
            rs.push((re - mk.re, im - mk.im));
        }
        x.push(xs);
        r.push(rs);
    }
    (x, r)
}

/// The measured torque as logged (times the torque-constant scale) and the model's torque on
/// the analysed samples, with the fast terms (inertia, and the shaft with two encoders) from
/// the unsmoothed encoders and the slow ones (friction, offset, unbalance, cogging) as the
/// smoothed equation has them; and whether the motor slides at each sample (the torque
/// equation's mask).
fn balance(data: &EquationData, params: &ParameterSet) -> (Vec<f64>, Vec<f64>, Vec<bool>) {
    let (dt, n, first) = (data.dt, data.len(), data.first_sample);
    let gear = data.gear_ratio;
    let motor_inertia = params.value(names::MOTOR_INERTIA) * gear * gear;
    let load_inertia = params.value(names::LOAD_INERTIA);
    let stiffness = params.value(names::STIFFNESS);
    let damping = params.value(names::DAMPING);
    let scale = params.value(names::TORQUE_CONSTANT_SCALE);
    let torque = &data.raw_torque;
    let second = |x: &[f64], i: usize| (x[i + 1] - 2.0 * x[i] + x[i - 1]) / (dt * dt);
    let first_difference = |x: &[f64], i: usize| (x[i + 1] - x[i - 1]) / (2.0 * dt);
    let (qm, ql) = (&data.raw_motor_pos, &data.raw_load_pos);
    let fast_raw = |i: usize| match data.structure {
        Structure::TwoMass => {
            let twist = qm[i] - ql[i];
            let rate = first_difference(qm, i) - first_difference(ql, i);
            motor_inertia * second(qm, i) + stiffness * twist + damping * rate
        }
        Structure::TotalTwoEncoders | Structure::Rigid => motor_inertia * second(qm, i) + load_inertia * second(ql, i),
    };
    let fast_smoothed = |i: usize| match data.structure {
        Structure::TwoMass => {
            motor_inertia * data.motor_acc[i] + stiffness * data.twist[i] + damping * data.twist_rate[i]
        }
        Structure::TotalTwoEncoders | Structure::Rigid => {
            motor_inertia * data.motor_acc[i] + load_inertia * data.load_acc[i]
        }
    };
    // The friction's own share of the band: the smoothed equation evaluates the friction law
    // on the smoothed speed, so the speed's fast part is missing from it. While the motor
    // slides, friction follows its curve's slope (viscous and Stribeck) at the band's
    // frequencies, a damping (negative below the Stribeck velocity) that is in quadrature with
    // the torque and would read as a delay of either sign.
    let viscous = params.value(names::VISCOUS);
    let friction_slope = |i: usize| viscous + static_friction_slope(params, data.motor_vel[i]);
    let channel = &model_channels(data, params)[data.torque_channel()];
    let measured = (0..n).map(|i| scale * torque[first + i]).collect();
    let model = (0..n)
        .map(|i| {
            let fast_speed = first_difference(qm, first + i) - data.motor_vel[i];
            channel.predicted[i] * scale - fast_smoothed(i) + fast_raw(first + i) + friction_slope(i) * fast_speed
        })
        .collect();
    (measured, model, channel.mask.clone())
}

/// The slope of the starting set's static friction curve (without the viscous part) at the
/// axis-side motor speed `speed` (N m s/rad), by a central difference that stays on the side
/// of zero the speed is on; zero at standstill.
fn static_friction_slope(params: &ParameterSet, speed: f64) -> f64 {
    if speed == 0.0 {
        return 0.0;
    }
    let step = 1e-3 * speed.abs();
    (static_friction_curve(params, speed + step) - static_friction_curve(params, speed - step)) / (2.0 * step)
}

/// The highest frequency the balance holds at: with one encoder on a compliant drive the
/// rigid-body balance stops at a third of the anti-resonance (as its smoothing does), else
/// the Nyquist frequency.
fn top_frequency(data: &EquationData, params: &ParameterSet) -> f64 {
    let nyquist = 0.5 / data.dt;
    let stiffness = params.value(names::STIFFNESS);
    let load_inertia = params.value(names::LOAD_INERTIA);
    if data.structure == Structure::Rigid && stiffness > 0.0 && load_inertia > 0.0 {
        let anti_resonance = (stiffness / load_inertia).sqrt() / (2.0 * PI);
        (anti_resonance / RIGID_CUTOFF_FRACTION_OF_ANTI_RESONANCE).min(nyquist)
    } else {
        nyquist
    }
}

/// The residual's noise power per bin after the change `change`: the mean over the segments
/// of |R - change X|^2, averaged over NOISE_BINS neighbours each side among the used bins.
fn noise_power(x: &[Vec<(f64, f64)>], r: &[Vec<(f64, f64)>], change: f64, used: &[usize], bins: usize) -> Vec<f64> {
    let mut raw = vec![0.0; bins];
    for (xs, rs) in x.iter().zip(r) {
        for &k in used {
            let (re, im) = (rs[k].0 - change * xs[k].0, rs[k].1 - change * xs[k].1);
            raw[k] += (re * re + im * im) / x.len() as f64;
        }
    }
    let mut noise = vec![0.0; bins];
    for (position, &k) in used.iter().enumerate() {
        let low = position.saturating_sub(NOISE_BINS);
        let high = (position + NOISE_BINS + 1).min(used.len());
        noise[k] = used[low..high].iter().map(|&j| raw[j]).sum::<f64>() / (high - low) as f64;
    }
    noise
}

/// The weighted least-squares change of the delay over all segments and used bins, and its
/// standard error from the scatter of the segments (a sandwich over independent segments).
/// Returns the change, its standard error and the information (sum of |X|^2 / noise over the
/// segments, less the torque noise's share `rate_noise`) of each bin.
fn weighted_fit(
    x: &[Vec<(f64, f64)>],
    r: &[Vec<(f64, f64)>],
    noise: &[f64],
    rate_noise: &[f64],
    used: &[usize],
) -> Option<(f64, f64, Vec<f64>)> {
    let mut information = vec![0.0; noise.len()];
    let mut per_segment = Vec::with_capacity(x.len());
    for (xs, rs) in x.iter().zip(r) {
        let (mut numerator, mut denominator) = (0.0, 0.0);
        for &k in used {
            if noise[k] <= 0.0 {
                continue;
            }
            let weight = 1.0 / noise[k];
            let power = xs[k].0 * xs[k].0 + xs[k].1 * xs[k].1 - rate_noise[k];
            numerator += weight * (xs[k].0 * rs[k].0 + xs[k].1 * rs[k].1);
            denominator += weight * power;
            information[k] += weight * power;
        }
        per_segment.push((numerator, denominator));
    }
    let total: f64 = per_segment.iter().map(|s| s.1).sum();
    if total.is_nan() || total <= 0.0 {
        return None;
    }
    let change = per_segment.iter().map(|s| s.0).sum::<f64>() / total;
    let count = per_segment.len() as f64;
    let spread: f64 = per_segment.iter().map(|(a, b)| (a - change * b).powi(2)).sum();
    let sigma = (spread * count / (count - 1.0)).sqrt() / total;
    (change.is_finite() && sigma.is_finite()).then_some((change, sigma, information))
}

/// The band holding the middle 90 % of the estimate's information.
fn weight_band(information: &[f64], used: &[usize], frequency: &[f64]) -> (f64, f64) {
    let total: f64 = used.iter().map(|&k| information[k].max(0.0)).sum();
    let mut cumulative = 0.0;
    let (mut low, mut high) = (frequency[used[0]], frequency[used[used.len() - 1]]);
    let mut low_set = false;
    for &k in used {
        cumulative += information[k].max(0.0);
        if !low_set && cumulative >= 0.05 * total {
            low = frequency[k];
            low_set = true;
        }
        if cumulative >= 0.95 * total {
            high = frequency[k];
            break;
        }
    }
    (low, high)
}

/// The band estimate of a delay the search did not claim, with the test at the search's level
/// and, when the log was simulated, what the simulation makes of it.
#[derive(Debug, Clone)]
pub struct DelayAccount {
    pub estimate: BandDelay,
    /// The p threshold of the search's last step, which the band estimate is tested at.
    pub threshold: f64,
    pub significant: bool,
    pub simulation: Option<SimulationView>,
    /// The delay the search claimed (s), when it claimed one: the estimate is then the band's
    /// view of the same log from the start's delay, for comparison.
    pub claimed: Option<f64>,
    /// The delay was claimed from this band estimate (not by the search's smoothed test): the
    /// estimate was significant beyond its model-form floor and the simulation confirmed it;
    /// `claimed` is then the band's delay.
    pub from_band: bool,
}

/// The simulation's view of a delay the band estimate found: the corrected model with it
/// against the corrected model, and the smallest delay change the simulation would confirm
/// (s), from the curvature of its score over two simulated delays, when that is measurable.
#[derive(Debug, Clone)]
pub struct SimulationView {
    pub comparison: crate::output_error::Comparison,
    pub resolution: Option<f64>,
}

impl SimulationView {
    /// The view from the scores of the model with the change `change` and with twice it
    /// (each against the corrected model, whose score is 1), over `windows` windows: the score
    /// is quadratic in the change, 1 - 2 b c + a c^2, and a change c is confirmed when a c^2
    /// (what it alone does to the simulated motion) reaches the BIC's share for one parameter,
    /// ln(n_w) / n_w.
    pub fn new(comparison: crate::output_error::Comparison, twice_score: f64, change: f64) -> Self {
        let windows = comparison.windows.max(2) as f64;
        let (once, twice) = (comparison.score_after - 1.0, twice_score - 1.0);
        let curvature = (twice - 2.0 * once) / (2.0 * change * change);
        let resolution =
            (curvature > 0.0 && curvature.is_finite()).then(|| (windows.ln() / (windows * curvature)).sqrt());
        SimulationView { comparison, resolution }
    }
}

impl DelayAccount {
    /// One paragraph for the summary and the report: what the band estimate found, and why it
    /// is not claimed.
    pub fn finding(&self) -> String {
        let e = &self.estimate;
        let ms = |s: f64| s * 1e3;
        let status = match (self.from_band, self.claimed) {
            (true, Some(claimed)) => format!(
                "claimed at {:.3} ms (beyond the band's model-form floor of {:.3} ms, the spread between its halves)",
                ms(claimed),
                ms(e.form_spread)
            ),
            _ => "not claimed".to_string(),
        };
        let mut text = format!(
            "delay found by the equation error's band estimate, {status}: {:.3} +- {:.3} ms ({:.2} +- {:.2} samples; a change of {:+.3} ms from the set's {:.3} ms, chi-square {:.1} at the search's p threshold {:.1e}; {})",
            ms(e.delay()),
            ms(e.sigma),
            e.delay() / e.dt,
            e.sigma / e.dt,
            ms(e.change),
            ms(e.start),
            e.chi2(),
            self.threshold,
            e.method()
        );
        text.push_str("; delay or current skew: the data cannot tell (a current stamped earlier than the encoders by as much reads the same)");
        match &self.simulation {
            None => text.push_str("; the log was not simulated, so no simulation confirms it"),
            Some(view) => {
                let verdict = if view.comparison.confirmed && self.from_band {
                    "predicts the motion significantly better"
                } else if view.comparison.confirmed {
                    "predicts the motion significantly better, but the estimate is not beyond its model-form floor (the spread between the band's halves), so it is not claimed"
                } else {
                    "does not predict the motion significantly better"
                };
                text.push_str(&format!("; the corrected model with it {verdict} ({})", view.comparison.reason));
                match view.resolution {
                    Some(r) => text.push_str(&format!(
                        "; the simulation's resolution for a delay change here is about {:.3} ms ({:.2} samples)",
                        ms(r),
                        r / e.dt
                    )),
                    None => text.push_str("; the simulation does not resolve a delay change of this size (its score does not grow with it)"),
                }
            }
        }
        text
    }

    /// The detection limit of the band estimate in words, with its band.
    pub fn limit_text(&self) -> String {
        format!(
            "{:.3} ms ({:.2} samples) by {}",
            self.estimate.limit(self.threshold) * 1e3,
            self.estimate.limit(self.threshold) / self.estimate.dt,
            self.estimate.method()
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use antenna_dsp::spectral::Complex64;

    /// Per segment, one spectrum per bin.
    type Spectra = Vec<Vec<Complex64>>;

    /// Segment spectra of a model torque with a broadband random phase, and the measured
    /// torque leading it by `delay` (the model is the torque `delay` later), over bins 4 Hz
    /// apart up to 250 Hz, with the bins' frequencies and the bins used.
    fn spectra_with_delay(delay: f64) -> (Spectra, Spectra, Vec<f64>, Vec<usize>) {
        let frequency: Vec<f64> = (0..64).map(|k| 4.0 * k as f64).collect();
        let used: Vec<usize> = (2..63).collect();
        let mut state = 7_u64;
        let mut next = || {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        let (mut measured, mut model) = (Vec::new(), Vec::new());
        for _ in 0..20 {
            let m: Vec<Complex64> = frequency.iter().map(|_| Complex64::from_polar(1.0, 2.0 * PI * next())).collect();
            let t: Vec<Complex64> =
                m.iter().zip(&frequency).map(|(mk, f)| mk * Complex64::from_polar(1.0, 2.0 * PI * f * delay)).collect();
            measured.push(t);
            model.push(m);
        }
        (measured, model, frequency, used)
    }

    #[test]
    fn a_wrapped_remainder_of_a_long_delay_is_beaten_by_the_delay_itself() {
        let (t, m, frequency, used) = spectra_with_delay(0.021);
        // A fraction of a millisecond near zero, where Gauss-Newton from no delay may stop.
        let beaten = longer_delay_fitting_better(&t, &m, &frequency, &used, -2.8e-4, 2e-3);
        let by = beaten.expect("the 21 ms delay fits better");
        assert!((by - 0.021).abs() <= 1e-3, "{by}");
    }

    #[test]
    fn a_skew_that_is_the_bands_own_shift_is_not_beaten() {
        let (t, m, frequency, used) = spectra_with_delay(-2.8e-4);
        assert_eq!(longer_delay_fitting_better(&t, &m, &frequency, &used, -2.8e-4, 2e-3), None);
    }
    use crate::measured_log::{parse_str, Signal};

    #[test]
    fn only_a_significant_negative_delay_beyond_the_floor_is_a_current_skew() {
        // A current logged 0.3 ms late, well resolved: a skew.
        assert!(is_skew(-3.0e-4, 1.2e-5, 5.0e-6, 1e-3));
        // The clean logs' model-form floor: significant, but within the floor's scale.
        assert!(!is_skew(-0.6 * MODEL_FORM_FLOOR, 1.0e-6, 0.0, 1e-3));
        // Beyond the floor but not significant.
        assert!(!is_skew(-3.0e-4, 2.0e-4, 0.0, 1e-3));
        // A positive delay is a drive's delay or a current logged early: never a skew.
        assert!(!is_skew(1.0e-3, 1.0e-5, 0.0, 1e-3));
        // Negative, but the band's halves disagree by as much: not one time shift.
        assert!(!is_skew(-1.2e-4, 2.0e-5, 1.5e-4, 1e-3));
    }

    fn estimate_with(change: f64, sigma: f64, form_spread: f64) -> BandDelay {
        BandDelay {
            start: 0.0,
            change,
            sigma,
            form_spread,
            band_hz: (20.0, 110.0),
            top_hz: 1000.0,
            segments: 80,
            dt: 5e-4,
            beaten_by: None,
        }
    }

    #[test]
    fn a_delay_within_the_spread_between_the_band_halves_is_not_claimable() {
        // Resolved far beyond its noise, but the band's halves disagree by more than it.
        let within = estimate_with(2.0e-5, 2.0e-6, 2.5e-5);
        assert!(within.significant(1e-5));
        assert!(!within.significant_beyond_floor(1e-5));
        // The same delay with halves that agree.
        assert!(estimate_with(2.0e-5, 2.0e-6, 3.0e-6).significant_beyond_floor(1e-5));
        // A shorter delay than the start's is never claimable, however consistent.
        assert!(!estimate_with(-2.0e-4, 2.0e-6, 0.0).significant_beyond_floor(1e-5));
    }

    #[test]
    fn the_friction_slope_is_the_curves_derivative_on_the_speeds_side() {
        let mut params = ParameterSet::default();
        params.set(names::COULOMB, 3000.0);
        params.set(names::STATIC, 4000.0);
        params.set(names::STRIBECK_VELOCITY, 2e-3);
        // Below the Stribeck velocity the curve falls: (Fs - Fc) (-2 v / vs^2) e^(-(v/vs)^2).
        let v = 1e-3;
        let exact = 1000.0 * (-2.0 * v / 4e-6) * (-0.25f64).exp();
        assert!((static_friction_slope(&params, v) - exact).abs() < 1e-4 * exact.abs());
        // Odd curve, even slope; no jump across zero counted at standstill.
        assert!((static_friction_slope(&params, -v) - exact).abs() < 1e-4 * exact.abs());
        assert_eq!(static_friction_slope(&params, 0.0), 0.0);
    }

    #[test]
    fn shifting_the_current_undoes_a_current_logged_late() {
        let (dt, late) = (1e-3, 0.37e-3);
        let current = |t: f64| (7.0 * t).sin() + 0.3 * (23.0 * t).cos();
        let mut text = String::from("time_s,motor_current_A,load_pos_rad,motor_pos_rad\n");
        for i in 0..2000 {
            let t = i as f64 * dt;
            text.push_str(&format!("{t},{},{},{}\n", current(t - late), 0.1 * t, 0.1 * t));
        }
        let log = parse_str(&text).unwrap();
        let shifted = shift_current(&log, late);
        let values = shifted.signal(Signal::MotorCurrent).unwrap();
        let worst = (10..1990).map(|i| (values[i] - current(i as f64 * dt)).abs()).fold(0.0, f64::max);
        assert!(worst < 1e-5, "{worst}");
        assert_eq!(shifted.signal(Signal::LoadPos), log.signal(Signal::LoadPos));
    }
}
