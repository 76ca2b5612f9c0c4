//! Sensor errors estimated before the physical effects are judged: the load encoder's
//! position-dependent error (eccentricity, graduation error, the gear's transmission error).
//!
//! With two encoders the drive path's twist is the motor encoder (referred to the axis) less
//! the load encoder. A load encoder that reads `q + e(q)` takes `e(q)` off the twist, and the
//! equations turn it into a torque `K e(q)` that no current supplied: with a stiffness of
//! 4e7 N m/rad, 5 arcsec of encoder error is 1 kN m, thirty times a current sensor's noise.
//! Left in the data, it raises every residual and every detection limit with it, and the
//! physical effects are judged against that instead of the noise.
//!
//! The twist less the twist the model explains from the motor side (the shaft torque the
//! measured current delivers after the motor's inertia, friction and cogging, over the
//! stiffness, plus the lost motion) is free of every load-side torque: an unbalance or an
//! offset deflects the shaft, and the motor side measures that torque. What stays there as a
//! function of the load angle is the encoder's error (or the gear's transmission error, which
//! enters the equations the same way). It is regressed, together with the twist terms of
//! [`crate::twist`] (a constant, a timing skew, a compliance and a lost-motion change), on a
//! smooth function of the angle (Legendre polynomials up to degree 6 over the angle range, for
//! errors with less than one and a half periods in it) and on harmonics of the angle
//! `sin(k q)`, `cos(k q)` with at least one and a half periods in the range, chosen one at a
//! time (the harmonic that explains most of what is left, kept while its Wald statistic passes
//! a 5-sigma test on the residual's correlation time). The error found is taken out of the
//! load encoder before the search, and reported; it is not an effect of the plant.

use crate::equation_error::{EquationData, Structure};
use crate::measured_log::{MeasuredLog, Signal, DRIFT_REMOVED_UNIT, INTEGRATED_UNIT};
use crate::parameters::ParameterSet;
use crate::stats::SinCosSums;
use crate::twist::{twist_regression, TwistOptions};
use antenna_dsp::weighted_least_squares;

/// Degree of the smooth part of the error (Legendre polynomials over the angle range).
const SMOOTH_DEGREE: usize = 6;
/// A harmonic needs this many periods within the angle range to stand apart from the smooth
/// part.
const MIN_PERIODS: f64 = 1.5;
/// At most this many harmonics are chosen (and never orders from half the gear ratio up).
const MAX_HARMONICS: usize = 24;
/// The highest harmonic order searched (a period of 0.18 deg).
const MAX_ORDER: u32 = 2000;

/// The load encoder's error found in a log, as a function of the load angle (rad).
#[derive(Debug, Clone, PartialEq)]
pub struct LoadEncoderError {
    /// The angle range the smooth part is defined over (rad).
    pub low: f64,
    pub high: f64,
    /// Coefficients of the Legendre polynomials P1..P6 over the range (rad); empty when the
    /// smooth part is not significant.
    pub smooth: Vec<f64>,
    /// Harmonics (order k, sine and cosine amplitude, rad) of the error.
    pub harmonics: Vec<(u32, f64, f64)>,
    /// RMS of the error over the log (rad), and the twist's sensor noise it is judged against.
    pub rms: f64,
    pub noise: f64,
}

impl LoadEncoderError {
    /// The error the load encoder reads at angle `q` (rad): what it reads less the truth.
    pub fn at(&self, q: f64) -> f64 {
        let mut e = 0.0;
        if !self.smooth.is_empty() {
            let x = (2.0 * (q - self.low) / (self.high - self.low).max(f64::MIN_POSITIVE) - 1.0).clamp(-1.0, 1.0);
            let p = legendre(x);
            e += self.smooth.iter().zip(&p).map(|(c, p)| c * p).sum::<f64>();
        }
        for &(k, s, c) in &self.harmonics {
            let phase = k as f64 * q;
            e += s * phase.sin() + c * phase.cos();
        }
        e
    }

    /// The log with the error taken out of every load-encoder column.
    pub fn correct(&self, log: &MeasuredLog) -> MeasuredLog {
        let mut out = log.clone();
        for channel in out.channels.iter_mut().filter(|c| c.signal == Signal::LoadPos) {
            // The reading is q + e(q): a few fixed-point steps find q (each multiplies the
            // error by e'(q), a few 1e-4 for any encoder error that matters).
            for reading in channel.values.iter_mut() {
                let mut q = *reading;
                for _ in 0..3 {
                    q = *reading - self.at(q);
                }
                *reading = q;
            }
        }
        out
    }

    /// One line for reports: the RMS and the harmonics' orders and amplitudes.
    pub fn describe(&self) -> String {
        let arcsec = 180.0 * 3600.0 / std::f64::consts::PI;
        let mut parts = Vec::new();
        if !self.smooth.is_empty() {
            parts.push("a smooth part over the angle range".to_string());
        }
        for &(k, s, c) in &self.harmonics {
            parts.push(format!("{:.3} arcsec at {k} per turn", s.hypot(c) * arcsec));
        }
        format!(
            "load encoder error {:.3} arcsec RMS over the log (twist noise {:.3} arcsec): {}",
            self.rms * arcsec,
            self.noise * arcsec,
            parts.join(", ")
        )
    }
}

/// P1..P6 at x in [-1, 1], by the three-term recurrence.
fn legendre(x: f64) -> [f64; SMOOTH_DEGREE] {
    let mut p = [0.0; SMOOTH_DEGREE];
    let (mut previous, mut current) = (1.0, x);
    for (n, value) in p.iter_mut().enumerate() {
        if n > 0 {
            let next = ((2 * n + 1) as f64 * x * current - n as f64 * previous) / (n + 1) as f64;
            previous = current;
            current = next;
        }
        *value = current;
    }
    p
}

/// A least-squares fit of the twist residual on the rows kept.
struct Fit {
    beta: Vec<f64>,
    /// Variance of a coefficient per unit of the inverse Gram matrix: the residual's variance
    /// times its correlation time.
    scale: f64,
    inverse: nalgebra::DMatrix<f64>,
    residual: Vec<f64>,
}

fn fit(columns: &[Vec<f64>], target: &[f64]) -> Fit {
    let weights = vec![1.0; target.len()];
    let (beta, inverse) = weighted_least_squares(columns, target, &weights);
    let residual: Vec<f64> =
        (0..target.len()).map(|i| target[i] - columns.iter().zip(&beta).map(|(c, b)| b * c[i]).sum::<f64>()).collect();
    let dof = target.len().saturating_sub(columns.len()).max(1) as f64;
    let variance = residual.iter().map(|r| r * r).sum::<f64>() / dof;
    let scale = variance * crate::stats::correlation_time(&residual);
    Fit { beta, scale, inverse, residual }
}

/// The Wald statistic of the coefficients `range` being zero.
fn wald(fit: &Fit, range: std::ops::Range<usize>) -> f64 {
    crate::stats::wald(&fit.beta, |a, b| fit.inverse[(a, b)] * fit.scale, range)
}

/// The rows the regression uses: the twist is smoothed to the equations' cut-off, so four
/// rows per cut-off period carry what every row does, at a fraction of the cost; and only
/// where the motor slides, since a sticking motor's friction (and so the shaft torque the
/// motor side implies) is not known.
fn rows(data: &EquationData) -> Vec<usize> {
    let step = ((0.25 / (data.cutoff_hz * data.dt)).floor() as usize).max(1);
    let sliding = &data.channels[data.torque_channel()].mask;
    (0..data.len()).step_by(step).filter(|&i| sliding[i]).collect()
}

/// The load encoder's error in a two-encoder log with a two-mass starting set, when it is
/// significant and at least `options.min_effect_to_noise` times the twist's sensor noise;
/// `None` otherwise, and for a linear axis (its scale's errors are not periodic in an angle)
/// or a motor position integrated from a speed (whose twist's slow part is not measured).
pub fn load_encoder_error(
    data: &EquationData,
    params: &ParameterSet,
    options: &TwistOptions,
) -> Option<LoadEncoderError> {
    if data.structure != Structure::TwoMass || data.linear || !data.slow_twist_hats.is_empty() || data.len() < 200 {
        return None;
    }
    let regression = twist_regression(data, params);
    let keep = rows(data);
    let pick = |v: &[f64]| -> Vec<f64> { keep.iter().map(|&i| v[i]).collect() };
    let target = pick(&regression.target);
    let angle = pick(&data.load_pos);
    let (low, high) = angle.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &q| (a.min(q), b.max(q)));
    let span = high - low;
    // Written so that a NaN span returns too.
    if span.is_nan() || span <= 0.0 {
        return None;
    }
    // The twist terms of the two-encoder check (constant, skew, compliance, lost motion), the
    // motor side's own model errors (the search's Coulomb, viscous, inertia, torque-constant
    // and delay columns, over the stiffness: a friction level the start lacks changes the
    // shaft torque the motor side implies, and over a short log the direction of travel goes
    // with the angle; a delay the start lacks moves it by the delay times the torque's rate,
    // which left out stood in the residual as a twist of several arcsec at 9 ms and hid a
    // 1 arcsec encoder error), then the smooth part.
    let mut columns: Vec<Vec<f64>> = regression.columns[..4].iter().map(|c| pick(c)).collect();
    let direction: Vec<f64> = data.smooth(&data.motor_vel_inner.iter().map(|v| v.signum()).collect::<Vec<_>>());
    let torque_rate = data.torque_rate_delayed(params.value(crate::parameters::names::DELAY));
    for motor_side in [&direction, &data.motor_vel, &data.motor_acc, &data.torque, &torque_rate] {
        columns.push(pick(motor_side));
    }
    let base = columns.len();
    let polynomials: Vec<[f64; SMOOTH_DEGREE]> = angle.iter().map(|q| legendre(2.0 * (q - low) / span - 1.0)).collect();
    for d in 0..SMOOTH_DEGREE {
        columns.push(polynomials.iter().map(|p| p[d]).collect());
    }
    let level = antenna_dsp::distributions::chi_squared_sf(options.z_threshold * options.z_threshold, 1.0);
    let noise = (data.motor_pos_sigma.powi(2) + data.load_pos_sigma.powi(2)).sqrt();
    let lowest = (MIN_PERIODS * 2.0 * std::f64::consts::PI / span).ceil().max(1.0) as u32;
    // A torque periodic in the motor angle (cogging, ripple) is periodic in the load angle at
    // orders that are multiples of the gear ratio: the search stays below half of it, where
    // only the load side's errors are.
    let highest = MAX_ORDER.min((0.5 * data.gear_ratio.abs()).floor() as u32);
    let load_side = LoadSide::new(data, &keep, &regression.columns[3], &angle);
    let mut orders: Vec<u32> = Vec::new();
    // Harmonics the motor side shows and the load side does not: torques at the motor
    // (cogging), kept in the fit as nuisance columns after the encoder's, never in its error.
    let mut motor_torques: Vec<u32> = Vec::new();
    let mut current = fit(&columns, &target);
    while orders.len() < MAX_HARMONICS && orders.len() + motor_torques.len() < 2 * MAX_HARMONICS {
        let searched: Vec<u32> = orders.iter().chain(&motor_torques).copied().collect();
        let Some(k) = strongest_harmonic(&current.residual, &angle, lowest..=highest, &searched) else { break };
        let mut trial = columns.clone();
        trial.push(angle.iter().map(|q| (k as f64 * q).sin()).collect());
        trial.push(angle.iter().map(|q| (k as f64 * q).cos()).collect());
        let candidate = fit(&trial, &target);
        let end = trial.len();
        // The strongest of many orders: its test is at the level divided by the orders tried,
        // and what it adds must be at least the practical size (its RMS is amplitude / sqrt 2).
        let tried = (highest + 1).saturating_sub(lowest).max(1) as f64;
        let amplitude = candidate.beta[end - 2].hypot(candidate.beta[end - 1]);
        if antenna_dsp::distributions::chi_squared_sf(wald(&candidate, end - 2..end), 2.0) >= level / tried
            || amplitude / std::f64::consts::SQRT_2 < options.min_effect_to_noise * noise
        {
            break;
        }
        if load_side.confirms(k, (candidate.beta[end - 2], candidate.beta[end - 1]), level) {
            orders.push(k);
            columns = trial;
        } else {
            motor_torques.push(k);
        }
        current = fit(&with_motor_torques(&columns, &angle, &motor_torques), &target);
    }
    let smooth_range = base..base + SMOOTH_DEGREE;
    let smooth_shape: Vec<f64> =
        (0..angle.len()).map(|i| smooth_range.clone().map(|j| current.beta[j] * columns[j][i]).sum::<f64>()).collect();
    let smooth_significant =
        antenna_dsp::distributions::chi_squared_sf(wald(&current, smooth_range.clone()), SMOOTH_DEGREE as f64) < level
            && load_side.confirms_shape(&smooth_shape, level);
    // The twist holds -e(q): the error is the negative of the fitted terms.
    let error = LoadEncoderError {
        low,
        high,
        smooth: if smooth_significant { current.beta[smooth_range].iter().map(|b| -b).collect() } else { Vec::new() },
        harmonics: orders
            .iter()
            .enumerate()
            .map(|(j, &k)| {
                let at = base + SMOOTH_DEGREE + 2 * j;
                (k, -current.beta[at], -current.beta[at + 1])
            })
            .collect(),
        rms: 0.0,
        noise,
    };
    let values: Vec<f64> = data.load_pos.iter().map(|&q| error.at(q)).collect();
    let mean = values.iter().sum::<f64>() / values.len() as f64;
    let rms = (values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / values.len() as f64).sqrt();
    let error = LoadEncoderError { rms, ..error };
    (rms >= options.min_effect_to_noise * error.noise && (!error.smooth.is_empty() || !error.harmonics.is_empty()))
        .then_some(error)
}

/// A motor speed sensor's integrated bias drift, found in a log whose motor position was
/// integrated from that speed: a piecewise linear function of time (axis rad) on the knots the
/// equation error's slow twist offset uses.
///
/// A tacho's bias wanders (with temperature, with the drive's own heat), and integrated it is
/// a motor-position error that wanders in time and enters the twist. Its slow part is not
/// measured by the speed sensor at all; only a model can put it back. The twist enters both
/// torque equations, with the stiffness as its unit and opposite signs, so the drift is fitted
/// on both at once, beside the linearised columns of every slow effect the search will look
/// for (friction levels, offset, unbalance, inertias, stiffness, lost motion, torque
/// constant): none of them is taken for drift, and the load equation, whose noise is the
/// encoders' rather than the torque sensor's, carries the estimate. (From the motor side
/// alone, the torque noise over the stiffness left an error twenty times the encoders' noise in
/// the twist, and the offset's and the unbalance's limits rose with it.) The knots are as far
/// apart as the integrated white noise of the speed takes to reach the load encoder's noise
/// (0.5 to 10 s): closer knots would follow that noise, farther ones leave the drift's
/// curvature in the data.
#[derive(Debug, Clone, PartialEq)]
pub struct TachoDrift {
    /// Knot times (s) and the drift's value there (axis rad, what the integral reads less the
    /// truth), linear between the knots and held beyond the first and last.
    pub knots: Vec<f64>,
    pub values: Vec<f64>,
    /// What is left of the speed sensor's scale error (the integral's first fit took it
    /// against the load encoder alone, where the twist's share along the position reads as
    /// scale): the motor position reads `1 + scale_error` times its travel from its mean.
    pub scale_error: f64,
    /// RMS of the drift over the log (rad, its mean taken off: a constant is the twist offset),
    /// and the twist's sensor noise it is judged against.
    pub rms: f64,
    pub noise: f64,
}

impl TachoDrift {
    /// The drift at time `t` (s).
    pub fn at(&self, t: f64) -> f64 {
        let k = &self.knots;
        match k.iter().position(|&knot| knot > t) {
            None => self.values[k.len() - 1],
            Some(0) => self.values[0],
            Some(j) => {
                let w = (t - k[j - 1]) / (k[j] - k[j - 1]);
                self.values[j - 1] * (1.0 - w) + self.values[j] * w
            }
        }
    }

    /// The log with the drift taken out of every integrated motor position, which is then
    /// marked as a position whose drift was removed (one constant twist offset from here on).
    pub fn correct(&self, log: &MeasuredLog) -> MeasuredLog {
        let mut out = log.clone();
        for channel in out.channels.iter_mut().filter(|c| c.signal == Signal::MotorPos && c.unit == INTEGRATED_UNIT) {
            // The scale is taken about the channel's own mean: another centre only moves the
            // twist by a constant, which the twist offset is.
            let mean = channel.values.iter().sum::<f64>() / channel.values.len().max(1) as f64;
            for (value, &t) in channel.values.iter_mut().zip(&log.time) {
                *value -= self.at(t) + self.scale_error * (*value - mean);
            }
            channel.unit = DRIFT_REMOVED_UNIT.into();
        }
        out
    }

    /// Knot spacing (s).
    pub fn spacing(&self) -> f64 {
        (self.knots[self.knots.len() - 1] - self.knots[0]) / (self.knots.len() - 1).max(1) as f64
    }

    /// One line for reports.
    pub fn describe(&self) -> String {
        let arcsec = 180.0 * 3600.0 / std::f64::consts::PI;
        let (low, high) =
            self.values.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| (a.min(v), b.max(v)));
        format!(
            "motor speed sensor's bias drift, integrated: {:.3} arcsec RMS over the log (twist noise {:.3} arcsec; with the scale error's remainder, {:+.4} %), {:.3} arcsec from lowest to highest, piecewise linear in time with {} knots {:.2} s apart",
            self.rms * arcsec,
            self.noise * arcsec,
            100.0 * self.scale_error,
            (high - low) * arcsec,
            self.knots.len(),
            self.spacing()
        )
    }
}

/// The integrated drift of a motor speed sensor in a log whose motor position was integrated
/// from it, with a two-mass starting set: the slow twist offset's knots fitted on both torque
/// equations together with every slow effect's columns
/// ([`crate::selection::slow_twist_offsets`]) and a twist proportional to the motor's travel
/// (what is left of the speed sensor's scale error), so that neither a lost motion nor a
/// friction level, an offset or an unbalance the start lacks is taken for drift. The drift is
/// returned when its RMS (mean taken off) is at least `options.min_effect_to_noise` times the
/// twist's noise, `None` otherwise and when the log has no integrated motor position.
pub fn tacho_drift(data: &EquationData, params: &ParameterSet, options: &TwistOptions) -> Option<TachoDrift> {
    let hats = &data.slow_twist_hats;
    if data.structure != Structure::TwoMass || hats.len() < 2 || data.len() < 200 {
        return None;
    }
    // The speed sensor's scale error was first fitted against the load encoder alone, where
    // the twist's share along the position (the shaft torque follows the trajectory: friction
    // with the direction, inertia against the position on a swing) reads as scale. Its
    // remainder is a twist proportional to the motor's travel, which a function of time
    // follows only where the axis moves slowly: it is estimated beside the drift and taken
    // out with it.
    let mean_position = data.motor_pos.iter().sum::<f64>() / data.len() as f64;
    let travel: Vec<f64> = data.motor_pos.iter().map(|q| q - mean_position).collect();
    let fitted = crate::selection::slow_twist_offsets(data, params, std::slice::from_ref(&travel));
    if fitted.len() != hats.len() + 1 || fitted.iter().any(|v| !v.is_finite()) {
        return None;
    }
    let (values, scale_error) = (fitted[..hats.len()].to_vec(), fitted[hats.len()]);
    let (t0, t1) = (data.time[0], data.time[data.len() - 1]);
    let count = values.len() - 1;
    let knots: Vec<f64> = (0..=count).map(|j| t0 + (t1 - t0) * j as f64 / count as f64).collect();
    // The twist holds +drift (the motor position reads high): the fitted offsets are the drift.
    let noise = (data.motor_pos_sigma.powi(2) + data.load_pos_sigma.powi(2)).sqrt();
    let mut drift = TachoDrift { knots, values, scale_error, rms: 0.0, noise };
    let along: Vec<f64> =
        data.time.iter().zip(&travel).map(|(&t, &travel)| drift.at(t) + scale_error * travel).collect();
    let mean = along.iter().sum::<f64>() / along.len() as f64;
    drift.values.iter_mut().for_each(|v| *v -= mean);
    drift.rms = (along.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / along.len() as f64).sqrt();
    (drift.rms.is_finite() && drift.rms >= options.min_effect_to_noise * noise).then_some(drift)
}

/// `columns` with the sine and cosine of each order in `orders` appended.
fn with_motor_torques(columns: &[Vec<f64>], angle: &[f64], orders: &[u32]) -> Vec<Vec<f64>> {
    let mut all = columns.to_vec();
    for &k in orders {
        all.push(angle.iter().map(|q| (k as f64 * q).sin()).collect());
        all.push(angle.iter().map(|q| (k as f64 * q).cos()).collect());
    }
    all
}

/// The load side's view of the twist: the load equation's residual at the starting set, as a
/// twist (the measured twist less what the load's inertia, damping, lost motion and torques
/// explain). An encoder error is in it as it is in the motor side's; a torque at the motor
/// (cogging) is not, since the load side's twist is the shaft's true deflection. Its own
/// unknowns are fitted beside each harmonic: a constant (the twist offset, a torque offset), an
/// unbalance (cosine and sine of the angle), an inertia error (the load acceleration), a skew
/// (the load speed) and a lost-motion change.
struct LoadSide {
    target: Vec<f64>,
    columns: Vec<Vec<f64>>,
    angle: Vec<f64>,
}

impl LoadSide {
    fn new(data: &EquationData, keep: &[usize], contact: &[f64], angle: &[f64]) -> LoadSide {
        let pick = |v: &[f64]| -> Vec<f64> { keep.iter().map(|&i| v[i]).collect() };
        let channel = data.load_channel().map(|c| data.channels[c].residual()).unwrap_or_else(|| vec![0.0; data.len()]);
        let target: Vec<f64> = keep.iter().map(|&i| channel[i] / data.twist_scale).collect();
        let columns = vec![
            vec![1.0; keep.len()],
            angle.iter().map(|q| q.cos()).collect(),
            angle.iter().map(|q| q.sin()).collect(),
            pick(&data.load_acc),
            pick(&data.load_vel),
            pick(contact),
        ];
        LoadSide { target, columns, angle: angle.to_vec() }
    }

    /// True when the load side holds the harmonic `k` the motor side found with coefficients
    /// `motor` (sine, cosine): significant there at `level`, and at least half of the motor
    /// side's along it.
    fn confirms(&self, k: u32, motor: (f64, f64), level: f64) -> bool {
        let columns = with_motor_torques(&self.columns, &self.angle, &[k]);
        let load = fit(&columns, &self.target);
        let end = columns.len();
        let (s, c) = (load.beta[end - 2], load.beta[end - 1]);
        let along = (s * motor.0 + c * motor.1) / (motor.0 * motor.0 + motor.1 * motor.1).max(f64::MIN_POSITIVE);
        antenna_dsp::distributions::chi_squared_sf(wald(&load, end - 2..end), 2.0) < level && along > 0.5
    }
}

impl LoadSide {
    /// True unless the load side can test the smooth function `shape` (the motor side's fit)
    /// and does not hold it. Over a short angle range much of a smooth function is an
    /// unbalance or a constant to the load side; what is left of it after those is tested
    /// when it is resolved (its coefficient's standard deviation under a quarter), and must
    /// then be significant and at least half the motor side's.
    fn confirms_shape(&self, shape: &[f64], level: f64) -> bool {
        let mut columns = self.columns.clone();
        columns.push(shape.to_vec());
        let load = fit(&columns, &self.target);
        let end = columns.len();
        let sd = (load.inverse[(end - 1, end - 1)] * load.scale).sqrt();
        if sd.is_nan() || sd >= 0.25 {
            return true;
        }
        let coefficient = load.beta[end - 1];
        antenna_dsp::distributions::chi_squared_sf((coefficient / sd).powi(2), 1.0) < level && coefficient > 0.5
    }
}

/// The harmonic order (not yet chosen) whose sine and cosine explain most of `residual`, by
/// projection: over a range of more than one and a half periods the pair is nearly orthogonal
/// to the columns already fitted, and the chosen one is refitted with all of them.
fn strongest_harmonic(
    residual: &[f64],
    angle: &[f64],
    orders: std::ops::RangeInclusive<u32>,
    chosen: &[u32],
) -> Option<u32> {
    let mut best: Option<(u32, f64)> = None;
    // sin(k q) and cos(k q) for consecutive k by rotation through the angle q: one
    // multiply-add per row and order instead of a sine and a cosine.
    let (first, last) = (*orders.start(), *orders.end());
    let step: Vec<(f64, f64)> = angle.iter().map(|q| q.sin_cos()).collect();
    let mut phasor: Vec<(f64, f64)> = angle.iter().map(|q| (first as f64 * q).sin_cos()).collect();
    for k in first..=last {
        if k > first {
            for ((s, c), (ds, dc)) in phasor.iter_mut().zip(&step) {
                (*s, *c) = (*s * dc + *c * ds, *c * dc - *s * ds);
            }
        }
        if chosen.contains(&k) {
            continue;
        }
        let mut sums = SinCosSums::default();
        for (r, &(s, c)) in residual.iter().zip(&phasor) {
            sums.add(1.0, *r, c, s);
        }
        if !sums.independent(1e-12) {
            continue;
        }
        // The reduction of the residual's sum of squares by the pair's least-squares fit.
        let gain = sums.explained();
        if best.is_none_or(|(_, g)| gain > g) {
            best = Some((k, gain));
        }
    }
    best.map(|(k, _)| k)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn legendre_polynomials_follow_their_closed_forms() {
        for x in [-1.0, -0.3, 0.0, 0.45, 1.0] {
            let p = legendre(x);
            assert!((p[0] - x).abs() < 1e-15);
            assert!((p[1] - (1.5 * x * x - 0.5)).abs() < 1e-15);
            assert!((p[2] - (2.5 * x * x * x - 1.5 * x)).abs() < 1e-15);
            assert!((p[3] - (35.0 * x.powi(4) - 30.0 * x * x + 3.0) / 8.0).abs() < 1e-14);
        }
    }

    #[test]
    fn the_strongest_harmonic_is_the_one_in_the_residual() {
        let angle: Vec<f64> = (0..4000).map(|i| 0.3 + 1.2 * i as f64 / 4000.0).collect();
        let residual: Vec<f64> =
            angle.iter().map(|q| 2e-6 * (36.0 * q + 0.7).sin() + 5e-7 * (90.0 * q).cos()).collect();
        assert_eq!(strongest_harmonic(&residual, &angle, 8..=2000, &[]), Some(36));
        let rest: Vec<f64> = angle.iter().map(|q| 5e-7 * (90.0 * q).cos()).collect();
        assert_eq!(strongest_harmonic(&rest, &angle, 8..=2000, &[36]), Some(90));
        // The rotation through 2000 orders keeps the phase: the same answer at the top.
        let top: Vec<f64> = angle.iter().map(|q| (1999.0 * q).sin()).collect();
        assert_eq!(strongest_harmonic(&top, &angle, 8..=2000, &[]), Some(1999));
    }

    #[test]
    fn the_drift_correction_takes_a_piecewise_linear_drift_out_of_an_integrated_motor_position() {
        let drift = TachoDrift {
            knots: vec![0.0, 1.0, 2.0],
            values: vec![1e-6, -2e-6, 0.5e-6],
            scale_error: 0.0,
            rms: 0.0,
            noise: 0.0,
        };
        assert!((drift.at(0.5) + 0.5e-6).abs() < 1e-18);
        assert!((drift.at(-1.0) - 1e-6).abs() < 1e-18 && (drift.at(5.0) - 0.5e-6).abs() < 1e-18);
        let text: String = std::iter::once("time_s,motor_current_A,motor_vel_rad_s,load_pos_rad\n".to_string())
            .chain((0..200).map(|i| {
                let t = i as f64 * 0.01;
                format!("{t},0,{},{}\n", (3.0 * t).cos(), (3.0 * t).sin() / 3.0)
            }))
            .collect();
        let integrated = crate::measured_log::parse_str(&text).unwrap().with_motor_position_from_speed().unwrap();
        let mut drifting = integrated.clone();
        for channel in drifting.channels.iter_mut().filter(|c| c.signal == Signal::MotorPos) {
            channel.values.iter_mut().zip(&integrated.time).for_each(|(v, &t)| *v += drift.at(t));
        }
        let corrected = drift.correct(&drifting);
        let (a, b) = (corrected.signal(Signal::MotorPos).unwrap(), integrated.signal(Signal::MotorPos).unwrap());
        let worst = a.iter().zip(b).map(|(x, y)| (x - y).abs()).fold(0.0, f64::max);
        assert!(worst < 1e-15, "{worst}");
        // From here on the twist offset is one constant: the position no longer counts as an
        // integrated one with a free drift.
        assert!(drifting.motor_position_is_integrated() && !corrected.motor_position_is_integrated());
    }

    #[test]
    fn the_drift_correction_takes_a_scale_error_out_about_the_positions_mean() {
        // A motor position that reads 1 + s times its travel from its mean: the correction is
        // first order in s, so what is left is s^2 times the travel, and nothing is added to
        // the mean (a constant is the twist offset's).
        let s = 2e-3;
        let drift = TachoDrift { knots: vec![0.0, 1.0], values: vec![0.0, 0.0], scale_error: s, rms: 0.0, noise: 0.0 };
        let text: String = std::iter::once("time_s,motor_current_A,motor_vel_rad_s,load_pos_rad\n".to_string())
            .chain((0..200).map(|i| {
                let t = i as f64 * 0.01;
                format!("{t},0,{},{}\n", 0.5 + (3.0 * t).cos(), 0.5 * t + (3.0 * t).sin() / 3.0)
            }))
            .collect();
        let integrated = crate::measured_log::parse_str(&text).unwrap().with_motor_position_from_speed().unwrap();
        let truth = integrated.signal(Signal::MotorPos).unwrap().to_vec();
        let mean = truth.iter().sum::<f64>() / truth.len() as f64;
        let mut scaled = integrated.clone();
        for channel in scaled.channels.iter_mut().filter(|c| c.signal == Signal::MotorPos) {
            channel.values.iter_mut().for_each(|v| *v += s * (*v - mean));
        }
        let corrected = drift.correct(&scaled);
        let travel = truth.iter().map(|v| (v - mean).abs()).fold(0.0, f64::max);
        let worst = corrected
            .signal(Signal::MotorPos)
            .unwrap()
            .iter()
            .zip(&truth)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        assert!(worst <= 1.01 * s * s * travel, "{worst} against {}", s * s * travel);
        assert!(worst > 0.0 || travel == 0.0);
    }

    #[test]
    fn the_correction_takes_the_error_out_of_the_load_encoder() {
        let error = LoadEncoderError {
            low: 0.0,
            high: 1.0,
            smooth: Vec::new(),
            harmonics: vec![(16, 1e-5, -2e-5)],
            rms: 0.0,
            noise: 0.0,
        };
        let truth: Vec<f64> = (0..100).map(|i| 0.3 + i as f64 * 0.01).collect();
        let text: String = std::iter::once("time_s,motor_current_A,load_pos_rad,motor_pos_rad\n".to_string())
            .chain(
                truth
                    .iter()
                    .enumerate()
                    .map(|(i, &q)| format!("{},{},{},{}\n", i as f64 * 0.01, 0.0, q + error.at(q), q)),
            )
            .collect();
        let log = crate::measured_log::parse_str(&text).unwrap();
        let corrected = error.correct(&log);
        let load = corrected.signal(Signal::LoadPos).unwrap();
        let worst = load.iter().zip(&truth).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
        assert!(worst < 1e-12, "{worst}");
    }
}
