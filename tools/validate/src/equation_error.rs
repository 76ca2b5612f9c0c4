//! The equation-error (inverse-dynamics) residual: the torque the model needs to produce the
//! measured motion, against the torque that was measured.
//!
//! This route needs no simulation, so it neither drifts nor depends on the initial state: it
//! is how robot drives are identified (Gautier and Khalil; Swevers et al.). Velocities and
//! accelerations come from zero-phase Savitzky-Golay filters of the encoder positions; the
//! measured torque goes through the same smoothing, and every regressor that is a nonlinear
//! function of the motion (sign of the speed, cos of the angle, ...) is smoothed after it is
//! evaluated ("parallel filtering"), so both sides of the equation see the same filter.
//!
//! With two encoders (motor and load) and a drive-path stiffness in the parameter set, two
//! equations are used, each with its own residual channel:
//! - motor: N s T(t - d) = J_m N^2 a_m + K tw + D dtw + friction(w_m) + offset + cogging(q_m)
//! - load:  K tw + D dtw = J_L a_L + unbalance(angle) - disturbance
//!
//! where tw = q_m - q_L is the twist. They split the effects by where they act: friction on the
//! motor side shows only in the first, unbalance and load inertia only in the second, stiffness
//! and backlash in both with opposite signs. Without a second encoder or without a stiffness,
//! the sum of the two (the rigid-body total) is the only channel. All torques are axis side.

use super::parameters::{names, ParameterSet};
use super::signals::torque_noise_sigma;
use crate::finite::{check_parameters, check_series, check_signal, NonFinite};
use crate::measured_log::{MeasuredLog, Signal};
use antenna_dsp::conditioning::{gaussian_kernel, noise_sigma, SavitzkyGolay};
use antenna_dsp::weighted_least_squares;
use std::collections::HashMap;
use std::sync::{Arc, Mutex, PoisonError};

/// Settings of the data conditioning. Defaults are documented in docs/validation.md.
#[derive(Debug, Clone)]
pub struct EquationOptions {
    /// Polynomial order of the Savitzky-Golay filters.
    pub filter_order: usize,
    /// Bounds of the filter half-width in samples and seconds.
    pub min_half_width: usize,
    pub max_half_width_seconds: f64,
    /// Samples slower than this many standard deviations of the speed noise are sticking.
    pub stick_noise_multiple: f64,
    /// ... and slower than this fraction of the set's Stribeck velocity, when it states one.
    pub stick_stribeck_fraction: f64,
    /// The sensors' noise of the log as logged (torque in axis N m, motor and load encoders in
    /// rad), used in place of the estimate from the data: a correction that shifts a signal by
    /// a fraction of a sample interpolates it, which smooths its noise (to about half the
    /// variance at half a sample), and every noise-scaled judgement would then read finer
    /// than the sensors are. None: estimated from the data.
    pub logged_noise: Option<[f64; 3]>,
}

impl Default for EquationOptions {
    fn default() -> Self {
        EquationOptions {
            filter_order: 4,
            min_half_width: 3,
            max_half_width_seconds: 0.05,
            stick_noise_multiple: 3.0,
            stick_stribeck_fraction: 0.1,
            logged_noise: None,
        }
    }
}

/// Which equations the data allows.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Structure {
    /// Motor and load equations (two encoders, a stiffness in the parameter set).
    TwoMass,
    /// One total-torque equation with separate motor and load accelerations (two encoders but
    /// no stiffness in the parameter set).
    TotalTwoEncoders,
    /// One total-torque equation with one measured motion (one encoder).
    Rigid,
}

/// One residual channel.
#[derive(Debug, Clone)]
pub struct ChannelData {
    pub name: &'static str,
    /// The measured side of the equation (axis N m), for NRMSE fit.
    pub measured: Vec<f64>,
    /// The model side at the starting parameters.
    pub predicted: Vec<f64>,
    /// Samples used in the fit (sticking samples are left out of equations with friction).
    pub mask: Vec<bool>,
}

impl ChannelData {
    pub fn residual(&self) -> Vec<f64> {
        self.measured.iter().zip(&self.predicted).map(|(m, p)| m - p).collect()
    }
}

/// Conditioned signals and the starting model's residual channels.
#[derive(Debug, Clone)]
pub struct EquationData {
    pub structure: Structure,
    /// The axis is linear (positions in metres): axis-side values are m, m/s, N, kg, N/m and
    /// N s/m, an axis of unit radius ([`crate::measured_log::UNITS`]).
    pub linear: bool,
    pub dt: f64,
    pub half_width: usize,
    /// -3 dB frequency of the smoothing (Hz).
    pub cutoff_hz: f64,
    pub gear_ratio: f64,
    /// Time, on the analysed region.
    pub time: Vec<f64>,
    /// Axis-side measured torque (N m), smoothed, before any delay or scale correction; the
    /// "inner" copy covers `half_width` more samples each side, for shifting.
    pub torque: Vec<f64>,
    pub torque_inner: Vec<f64>,
    pub motor_pos: Vec<f64>,
    pub motor_vel: Vec<f64>,
    pub motor_acc: Vec<f64>,
    pub load_pos: Vec<f64>,
    pub load_vel: Vec<f64>,
    pub load_acc: Vec<f64>,
    pub twist: Vec<f64>,
    pub twist_rate: Vec<f64>,
    /// The angle for unbalance: elevation when logged, else the axis angle.
    pub angle: Vec<f64>,
    pub angle_is_elevation: bool,
    pub disturbance: Option<Vec<f64>>,
    /// Inner-region copies of what nonlinear regressors are evaluated on.
    pub motor_pos_inner: Vec<f64>,
    pub motor_vel_inner: Vec<f64>,
    pub twist_inner: Vec<f64>,
    pub angle_inner: Vec<f64>,
    pub smoother: Vec<f64>,
    /// Model-free sensor noise estimates: torque (axis N m) and encoders (rad).
    pub torque_sigma: f64,
    pub motor_pos_sigma: f64,
    pub load_pos_sigma: f64,
    /// Speed below which a sample counts as sticking (rad/s).
    pub stick_speed: f64,
    /// The starting stiffness, used as a fixed unit that turns the load equation's twist into
    /// torque (1 when the structure has no load equation).
    pub twist_scale: f64,
    /// The slowly varying twist offset's basis when the motor position was integrated from a
    /// speed signal, whose slow part a speed sensor cannot measure: one hat function a knot
    /// ([`hat_functions`]) on the analysed samples, computed once; empty when the twist offset is
    /// one constant (two encoders).
    pub slow_twist_hats: Vec<Vec<f64>>,
    /// Index of the first analysed sample in the log.
    pub first_sample: usize,
    /// The axis-side torque and the positions as logged (uniform log, unsmoothed), for the
    /// estimates that need the band the smoothing takes away ([`crate::band_delay`]); the
    /// analysed region starts at `first_sample`.
    pub raw_torque: Vec<f64>,
    pub raw_motor_pos: Vec<f64>,
    pub raw_load_pos: Vec<f64>,
    pub channels: Vec<ChannelData>,
    pub notes: Vec<String>,
    /// The smoothed regressors that depend on the data and one number only, kept once made
    /// ([`EquationData::smoothed_regressor`]).
    pub regressors: SmoothedRegressors,
}

/// A smoothed regressor that depends on the data and one number only: the cogging search's
/// sine and cosine of the motor angle at a motor's period, the Stribeck hump at a velocity.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Regressor {
    CoggingSin,
    CoggingCos,
    StribeckHump,
}

/// The smoothed regressors made so far, by regressor and the bits of its number. Every step
/// of the search tries the same motor periods and, on a fixed set of moving samples, the same
/// Stribeck velocities; smoothing each once per log instead of once per step saves most of
/// the search's smoothing (about 0.5 MB a column for a minute at 1 kHz, some 130 columns).
#[derive(Default)]
pub struct SmoothedRegressors {
    columns: Mutex<HashMap<RegressorKey, Arc<Vec<f64>>>>,
}

/// A regressor and the bits of its number.
type RegressorKey = (Regressor, u64);

/// A copy of the data may have its signals changed, so it starts with none kept.
impl Clone for SmoothedRegressors {
    fn clone(&self) -> Self {
        SmoothedRegressors::default()
    }
}

impl std::fmt::Debug for SmoothedRegressors {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let count = self.columns.lock().unwrap_or_else(PoisonError::into_inner).len();
        write!(f, "SmoothedRegressors({count} kept)")
    }
}

impl EquationData {
    /// The samples where the motor slides: its smoothed speed above the stick speed. Friction
    /// is a function of the speed only there, so the fits that rest on it use these samples.
    pub fn sliding(&self) -> Vec<bool> {
        self.motor_vel.iter().map(|v| v.abs() > self.stick_speed).collect()
    }

    /// Smooths a column evaluated on the inner region down to the analysed region.
    pub fn smooth(&self, inner: &[f64]) -> Vec<f64> {
        SavitzkyGolay::apply(&self.smoother, inner)
    }

    /// The smoothed `regressor` at `value`: made by smoothing what `inner` evaluates on the
    /// inner region the first time it is asked for, the kept column after that. `inner` must
    /// depend on the data and `value` only. Threads that ask for the same new column at once
    /// may each make it; the columns they make are the same.
    pub fn smoothed_regressor(
        &self,
        regressor: Regressor,
        value: f64,
        inner: impl FnOnce() -> Vec<f64>,
    ) -> Arc<Vec<f64>> {
        let key = (regressor, value.to_bits());
        let kept = self.regressors.columns.lock().unwrap_or_else(PoisonError::into_inner).get(&key).cloned();
        if let Some(column) = kept {
            return column;
        }
        let column = Arc::new(self.smooth(&inner()));
        let mut columns = self.regressors.columns.lock().unwrap_or_else(PoisonError::into_inner);
        Arc::clone(columns.entry(key).or_insert(column))
    }

    pub fn len(&self) -> usize {
        self.time.len()
    }

    pub fn is_empty(&self) -> bool {
        self.time.is_empty()
    }

    /// The channel index of the equation that carries the measured torque.
    pub fn torque_channel(&self) -> usize {
        0
    }

    /// The load channel, when there is one.
    pub fn load_channel(&self) -> Option<usize> {
        (self.structure == Structure::TwoMass).then_some(1)
    }

    /// Time derivative of the smoothed measured torque delayed by `delay` seconds.
    pub fn torque_rate_delayed(&self, delay: f64) -> Vec<f64> {
        let shifted = antenna_dsp::conditioning::shift_samples(&self.torque_inner, -delay / self.dt);
        let rate = central_first(&shifted, self.dt);
        rate[self.half_width..self.half_width + self.len()].to_vec()
    }

    /// Smoothed measured torque delayed by `delay` seconds: the value logged `delay` earlier,
    /// which is the torque acting now when the drive applies it `delay` after logging it.
    pub fn torque_delayed(&self, delay: f64) -> Vec<f64> {
        let mut out = Vec::with_capacity(self.len());
        self.torque_delayed_into(delay, &mut out);
        out
    }

    /// [`Self::torque_delayed`] written into `out`: the same values, shifted only over the
    /// samples kept, into a buffer a search over delays reuses.
    pub fn torque_delayed_into(&self, delay: f64, out: &mut Vec<f64>) {
        let kept = self.half_width..self.half_width + self.len();
        antenna_dsp::conditioning::shift_samples_into(&self.torque_inner, -delay / self.dt, kept, out);
    }
}

/// The starting model's friction torque on the motor (axis side), without the viscous part,
/// evaluated at a speed. The model form the plant FMU implements: Coulomb plus a Stribeck hump
/// with the sign of the speed, both levels scaled by (1 + a) moving forward and (1 - a) moving
/// backward (multiplicative asymmetry).
pub fn static_friction_curve(params: &ParameterSet, speed: f64) -> f64 {
    let fc = params.value(names::COULOMB);
    let fs = params.get(names::STATIC).unwrap_or(fc);
    let vs = params.value(names::STRIBECK_VELOCITY).max(1e-12);
    let sign: f64 = if speed > 0.0 {
        1.0
    } else if speed < 0.0 {
        -1.0
    } else {
        0.0
    };
    (fc + (fs - fc) * (-(speed / vs).powi(2)).exp()) * (sign + params.value(names::ASYMMETRY) * sign.abs())
}

/// With one encoder on a compliant drive, the rigid-body equation's smoothing cut-off is the
/// starting set's anti-resonance divided by this.
pub const RIGID_CUTOFF_FRACTION_OF_ANTI_RESONANCE: f64 = 3.0;

/// Shortest and longest knot spacing (s) of the slowly varying twist offset of an integrated
/// motor position.
pub const SLOW_TWIST_KNOT_SPACING: (f64, f64) = (0.5, 10.0);

/// The hat functions of a piecewise linear interpolation through `knots`, evaluated at `time`:
/// one column per knot, summing to one everywhere.
pub fn hat_functions(knots: &[f64], time: &[f64]) -> Vec<Vec<f64>> {
    (0..knots.len())
        .map(|j| {
            time.iter()
                .map(|&t| {
                    let left = if j > 0 { knots[j - 1] } else { f64::NEG_INFINITY };
                    let right = knots.get(j + 1).copied().unwrap_or(f64::INFINITY);
                    if t <= knots[j] {
                        if j == 0 {
                            1.0
                        } else if t <= left {
                            0.0
                        } else {
                            (t - left) / (knots[j] - left)
                        }
                    } else if j + 1 == knots.len() {
                        1.0
                    } else if t >= right {
                        0.0
                    } else {
                        (right - t) / (right - knots[j])
                    }
                })
                .collect()
        })
        .collect()
}

/// Why a log and a parameter set cannot be conditioned for the equation error.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum PrepareError {
    #[error("the parameter set has no {0}")]
    MissingParameter(&'static str),
    #[error("the log has currents, not torques: the parameter set needs {0}")]
    NeedsTorqueConstant(&'static str),
    #[error("the log has no position output")]
    NoPosition,
    #[error("the log is too short: {samples} samples for a filter of {filter} samples")]
    TooShort { samples: usize, filter: usize },
    #[error(transparent)]
    NonFinite(#[from] NonFinite),
}

/// Builds the conditioned data and the starting model's residual channels.
pub fn prepare(
    log: &MeasuredLog,
    params: &ParameterSet,
    options: &EquationOptions,
) -> Result<EquationData, PrepareError> {
    check_log(log)?;
    check_parameters(params)?;
    let mut notes = Vec::new();
    let log = uniform(log, &mut notes);
    let n = log.len();
    let dt = log.sample_interval();
    let raw = raw_inputs(&log, params, &mut notes)?;
    let two_encoders = raw.two_encoders;

    let positions: Vec<&[f64]> = if two_encoders { vec![&raw.motor_pos, &raw.load_pos] } else { vec![&raw.motor_pos] };
    let [torque_sigma, motor_pos_sigma, load_pos_sigma] = options.logged_noise.unwrap_or_else(|| {
        [torque_noise_sigma(&raw.torque, &positions), noise_sigma(&raw.motor_pos), noise_sigma(&raw.load_pos)]
    });
    let noise = SensorNoise { torque: torque_sigma, motor_pos: motor_pos_sigma, load_pos: load_pos_sigma };

    let stiffness = params.value(names::STIFFNESS);
    let load_inertia = params.value(names::LOAD_INERTIA);
    let kernel_sigma = smoothing_sigma(params, raw.gear, two_encoders, &noise, dt, options, &mut notes);
    let smoother = gaussian_kernel(kernel_sigma);
    let half_width = smoother.len() / 2;
    if n < 8 * half_width + 16 {
        return Err(PrepareError::TooShort { samples: n, filter: smoother.len() });
    }
    let cutoff_hz = 0.1325 / (kernel_sigma * dt);
    let h = half_width;
    let motion = filtered_motion(&log, &raw, &smoother, dt);
    let first_sample = 2 * h;
    let time = log.time[first_sample..n - first_sample].to_vec();

    let speed_noise = motor_pos_sigma * SavitzkyGolay::gain(&convolve(&smoother, &FIRST_STENCIL)) / dt;
    // Below a tenth of the Stribeck velocity the friction is in presliding (the bristles'
    // spring, not the sliding law) whether or not the set holds a hump: the velocity is the
    // set's statement of where the low-speed regime lies. Kept in, those samples pull the
    // friction fit: on a carriage with 10 micrometre bristles (the second generator's) a
    // Coulomb change of 5 N was named as viscous friction with the noise's threshold
    // (10 micrometres/s) and as Coulomb with this one (1 mm/s).
    let mut stick_speed = options.stick_noise_multiple * speed_noise;
    if let Some(vs) = params.get(names::STRIBECK_VELOCITY) {
        stick_speed = stick_speed.max(options.stick_stribeck_fraction * vs);
    }

    let structure = if !two_encoders {
        Structure::Rigid
    } else if stiffness > 0.0 && load_inertia > 0.0 {
        Structure::TwoMass
    } else {
        notes.push(format!(
            "{} or {} is not set: only the total torque equation is used, so stiffness and backlash cannot be checked",
            names::STIFFNESS,
            names::LOAD_INERTIA
        ));
        Structure::TotalTwoEncoders
    };
    let slow_twist_hats = slow_twist_basis(&log, structure, load_pos_sigma, dt, &time, &mut notes);

    let mut data = EquationData {
        structure,
        linear: log.is_linear(),
        dt,
        half_width: h,
        cutoff_hz,
        gear_ratio: raw.gear,
        time,
        torque: motion.torque,
        torque_inner: motion.torque_inner,
        motor_pos: motion.motor_pos,
        motor_vel: motion.motor_vel,
        motor_acc: motion.motor_acc,
        load_pos: motion.load_pos,
        load_vel: motion.load_vel,
        load_acc: motion.load_acc,
        twist: motion.twist,
        twist_rate: motion.twist_rate,
        angle: Vec::new(),
        angle_is_elevation: motion.angle_is_elevation,
        disturbance: motion.disturbance,
        motor_pos_inner: motion.motor_pos_inner,
        motor_vel_inner: motion.motor_vel_inner,
        twist_inner: motion.twist_inner,
        angle_inner: motion.angle_inner,
        smoother,
        torque_sigma,
        motor_pos_sigma,
        load_pos_sigma,
        stick_speed,
        twist_scale: if structure == Structure::TwoMass { stiffness } else { 1.0 },
        slow_twist_hats,
        first_sample,
        raw_torque: raw.torque.clone(),
        raw_motor_pos: raw.motor_pos.clone(),
        raw_load_pos: raw.load_pos.clone(),
        channels: Vec::new(),
        notes,
        regressors: SmoothedRegressors::default(),
    };
    data.angle = data.smooth(&data.angle_inner);
    let resolution = resolution_note(&raw, &data);
    data.notes.push(resolution);
    data.channels = model_channels(&data, params);
    check_channels(&data, &data.channels)?;
    Ok(data)
}

/// How the note on what the log's sensors resolve begins.
pub const RESOLUTION_NOTE: &str = "sensor resolution:";

/// What the log's sensors resolve: the step of each position and of the torque as logged, the
/// torque's noise floor, and, with two encoders, the twist's spread against the load encoder's
/// count, with what that rules out.
fn resolution_note(raw: &RawInputs, data: &EquationData) -> String {
    use super::signals::torque_noise_floor;
    use antenna_dsp::conditioning::resolution;
    let (scale, small) = if data.linear { (1e3, "mm") } else { (180.0 * 3600.0 / std::f64::consts::PI, "arcsec") };
    let torque_unit = if data.linear { "N" } else { "N m" };
    let load_step = resolution(&raw.load_pos);
    let mut note = format!(
        "{RESOLUTION_NOTE} load encoder {:.3} {small} per step, motor encoder {:.3e} {small} per step (axis side), torque {:.3e} {torque_unit} per step (axis side); the torque's noise is floored at {:.3e} {torque_unit} (its rounding, or a 16-bit converter over its range)",
        load_step * scale,
        resolution(&raw.motor_pos) * scale,
        resolution(&raw.torque),
        torque_noise_floor(&raw.torque)
    );
    if raw.two_encoders && !data.twist.is_empty() {
        let mean = data.twist.iter().sum::<f64>() / data.twist.len() as f64;
        let spread = (data.twist.iter().map(|t| (t - mean).powi(2)).sum::<f64>() / data.twist.len() as f64).sqrt();
        if load_step > spread {
            note.push_str(&format!(
                "; the twist spreads over {:.3} {small} RMS, less than one load-encoder step: a drive-path change (stiffness, lost motion) shows only as far as the motion dithers the count, and the twist cannot carry the output-error criterion for a delay or an inertia change",
                spread * scale
            ));
        } else {
            note.push_str(&format!(
                "; the twist spreads over {:.3} {small} RMS, {:.0} load-encoder steps",
                spread * scale,
                spread / load_step.max(f64::MIN_POSITIVE)
            ));
        }
    }
    note
}

/// Checks every logged signal (the time first) for NaN and infinity.
pub fn check_log(log: &MeasuredLog) -> Result<(), NonFinite> {
    check_signal("time", &log.time)?;
    for channel in &log.channels {
        check_signal(&format!("column '{}'", channel.column), &channel.values)?;
    }
    Ok(())
}

/// Checks both sides of residual channels on conditioned data: with a finite log and finite
/// parameters, a non-finite value here is an overflow (a parameter out of range).
pub fn check_channels(data: &EquationData, channels: &[ChannelData]) -> Result<(), NonFinite> {
    let at = |i: usize| match data.time.get(i) {
        Some(t) => format!("at analysed sample {i} (t = {t:.4} s)"),
        None => format!("at analysed sample {i}"),
    };
    for channel in channels {
        check_series(&format!("the measured side of the {}", channel.name), &channel.measured, at)?;
        check_series(&format!("the model side of the {}", channel.name), &channel.predicted, at)?;
    }
    Ok(())
}

/// The log's inputs of the equations: the axis-side measured torque and the raw positions (one
/// encoder stands in for the other when the log has only one).
struct RawInputs {
    gear: f64,
    torque: Vec<f64>,
    motor_pos: Vec<f64>,
    load_pos: Vec<f64>,
    two_encoders: bool,
}

fn raw_inputs(log: &MeasuredLog, params: &ParameterSet, notes: &mut Vec<String>) -> Result<RawInputs, PrepareError> {
    let gear = params.get(names::GEAR_RATIO).ok_or(PrepareError::MissingParameter(names::GEAR_RATIO))?;
    let torque_constant = params.value(names::TORQUE_CONSTANT);
    if log.torque_from_current() && params.get(names::TORQUE_CONSTANT).is_none() {
        return Err(PrepareError::NeedsTorqueConstant(names::TORQUE_CONSTANT));
    }
    let torque: Vec<f64> = log.total_motor_torque(torque_constant).iter().map(|t| t * gear).collect();
    check_series("the axis-side measured torque (logged torque times the gear ratio)", &torque, |i| {
        format!("at sample {i}")
    })?;

    let motor_pos_raw = log.signal(Signal::MotorPos).map(<[f64]>::to_vec);
    let load_pos_raw = log.signal(Signal::LoadPos).map(<[f64]>::to_vec);
    if (log.signal(Signal::MotorVel).is_some() && !log.motor_position_is_integrated())
        || log.signal(Signal::LoadVel).is_some()
    {
        notes.push("logged speeds are not used: speeds come from the positions through a zero-phase filter, since a drive's own speed filter may lag".into());
    }
    let (motor_pos, load_pos, two_encoders) = match (motor_pos_raw, load_pos_raw) {
        (Some(m), Some(l)) => (m, l, true),
        (Some(m), None) => {
            notes.push(
                "no load encoder: the drive is treated as rigid (stiffness and backlash cannot be checked)".into(),
            );
            (m.clone(), m, false)
        }
        (None, Some(l)) => {
            notes.push(
                "no motor encoder: the drive is treated as rigid (stiffness and backlash cannot be checked)".into(),
            );
            (l.clone(), l, false)
        }
        (None, None) => return Err(PrepareError::NoPosition),
    };
    Ok(RawInputs { gear, torque, motor_pos, load_pos, two_encoders })
}

/// Model-free sensor noise estimates: torque (axis N m) and encoders (rad).
struct SensorNoise {
    torque: f64,
    motor_pos: f64,
    load_pos: f64,
}

/// The standard deviation (samples) of the Gaussian smoothing kernel.
fn smoothing_sigma(
    params: &ParameterSet,
    gear: f64,
    two_encoders: bool,
    noise: &SensorNoise,
    dt: f64,
    options: &EquationOptions,
    notes: &mut Vec<String>,
) -> f64 {
    let motor_inertia = params.value(names::MOTOR_INERTIA) * gear * gear;
    let load_inertia = params.value(names::LOAD_INERTIA);
    // The smoothing: a Gaussian kernel, the narrowest (in steps of a quarter sample) whose
    // acceleration noise (encoder noise through the smoothing and the second difference, times
    // the inertia it multiplies) stays below the torque noise through the same smoothing. A
    // narrower kernel keeps more of the dynamics; a wider one is needed when the encoders are
    // coarse compared with the torque sensor.
    let max_sigma = (options.max_half_width_seconds / dt / 4.0).max(options.min_half_width as f64 / 4.0);
    let mut kernel_sigma = max_sigma;
    let mut trial = (options.min_half_width as f64 / 4.0).max(0.75);
    while trial <= max_sigma {
        let kernel = gaussian_kernel(trial);
        let torque_noise = noise.torque * SavitzkyGolay::gain(&kernel);
        let acc_gain = SavitzkyGolay::gain(&convolve(&kernel, &SECOND_STENCIL)) / (dt * dt);
        let motor_noise = motor_inertia * noise.motor_pos * acc_gain;
        let load_noise = if two_encoders { load_inertia * noise.load_pos * acc_gain } else { 0.0 };
        if motor_noise.max(load_noise) <= torque_noise {
            kernel_sigma = trial;
            break;
        }
        trial += 0.25;
    }
    // One encoder on a compliant drive: the equation error takes the motor and load as one
    // rigid body, which holds only well below the drive's anti-resonance (the motor's extra
    // acceleration, the twist's second derivative, grows as (f / f_ar)^2 above it and would
    // look like a delay or an inertia error). The smoothing then stops at a third of the
    // starting set's anti-resonance, where that error is under a ninth of the motor's share
    // of the inertia torque; the output error still simulates the compliant plant.
    let stiffness = params.value(names::STIFFNESS);
    if !two_encoders && stiffness > 0.0 && load_inertia > 0.0 {
        let anti_resonance_hz = (stiffness / load_inertia).sqrt() / (2.0 * std::f64::consts::PI);
        let rigid_cutoff_hz = anti_resonance_hz / RIGID_CUTOFF_FRACTION_OF_ANTI_RESONANCE;
        if 0.1325 / (kernel_sigma * dt) > rigid_cutoff_hz {
            kernel_sigma = 0.1325 / (rigid_cutoff_hz * dt);
            notes.push(format!(
                "one encoder on a compliant drive: the rigid-body equation is smoothed to {rigid_cutoff_hz:.2} Hz, a third of the starting set's anti-resonance {anti_resonance_hz:.2} Hz, below which the drive moves as one body"
            ));
        }
    }
    kernel_sigma
}

/// The smoothed signals and their derivatives: "inner" copies on the log samples h..n-h (one
/// filter pass), the others on the analysed region 2h..n-2h.
struct FilteredMotion {
    torque_inner: Vec<f64>,
    torque: Vec<f64>,
    motor_pos: Vec<f64>,
    motor_vel: Vec<f64>,
    motor_acc: Vec<f64>,
    load_pos: Vec<f64>,
    load_vel: Vec<f64>,
    load_acc: Vec<f64>,
    twist: Vec<f64>,
    twist_rate: Vec<f64>,
    angle_is_elevation: bool,
    disturbance: Option<Vec<f64>>,
    motor_pos_inner: Vec<f64>,
    motor_vel_inner: Vec<f64>,
    twist_inner: Vec<f64>,
    angle_inner: Vec<f64>,
}

fn filtered_motion(log: &MeasuredLog, raw: &RawInputs, smoother: &[f64], dt: f64) -> FilteredMotion {
    let h = smoother.len() / 2;
    let inner = |x: &[f64]| SavitzkyGolay::apply(smoother, x);
    let cut = |x: Vec<f64>| x[h..x.len() - h].to_vec();

    // Speeds and accelerations: the smoothed positions differentiated by five-point central
    // differences. Their error against the exact derivative is below 1e-4 over the smoothing
    // passband, so the motion terms see exactly the smoothing the torque sees; a separate
    // Savitzky-Golay derivative filter would smooth differently near the cut-off, and the
    // difference would show up as an inertia or stiffness error.
    let torque_inner = inner(&raw.torque);
    let motor_pos_inner = inner(&raw.motor_pos);
    let load_pos_inner = inner(&raw.load_pos);
    let motor_vel_inner = central_first(&motor_pos_inner, dt);
    let load_vel_inner = central_first(&load_pos_inner, dt);
    let motor_acc_inner = central_second(&motor_pos_inner, dt);
    let load_acc_inner = central_second(&load_pos_inner, dt);
    let twist_inner: Vec<f64> = motor_pos_inner.iter().zip(&load_pos_inner).map(|(m, l)| m - l).collect();
    // Unbalance acts on the axis angle, as in the plant FMU (its periodic load torque); an
    // elevation column is an input of the azimuth plant's inertia, not of this axis' unbalance.
    let angle_is_elevation = false;
    let angle_inner = load_pos_inner.clone();
    let disturbance = log.signal(Signal::DisturbanceTorque).map(|d| cut(inner(d)));

    let torque = cut(torque_inner.clone());
    let motor_pos = cut(motor_pos_inner.clone());
    let motor_vel = cut(motor_vel_inner.clone());
    let motor_acc = cut(motor_acc_inner);
    let load_pos = cut(load_pos_inner.clone());
    let load_vel = cut(load_vel_inner);
    let load_acc = cut(load_acc_inner);
    let twist: Vec<f64> = motor_pos.iter().zip(&load_pos).map(|(m, l)| m - l).collect();
    let twist_rate: Vec<f64> = motor_vel.iter().zip(&load_vel).map(|(m, l)| m - l).collect();
    FilteredMotion {
        torque_inner,
        torque,
        motor_pos,
        motor_vel,
        motor_acc,
        load_pos,
        load_vel,
        load_acc,
        twist,
        twist_rate,
        angle_is_elevation,
        disturbance,
        motor_pos_inner,
        motor_vel_inner,
        twist_inner,
        angle_inner,
    }
}

/// A motor position integrated from a speed signal drifts as a random walk of the speed
/// noise; its twist is trusted over the time T in which that walk stays within the load
/// encoder's noise, sigma_v sqrt(dt T) = sigma_l, and the twist offset becomes a piecewise
/// linear function with knots T apart (0.5 to 10 s). Returns its hat functions, or none.
fn slow_twist_basis(
    log: &MeasuredLog,
    structure: Structure,
    load_pos_sigma: f64,
    dt: f64,
    time: &[f64],
    notes: &mut Vec<String>,
) -> Vec<Vec<f64>> {
    match log.signal(Signal::MotorVel).filter(|_| log.motor_position_is_integrated() && structure == Structure::TwoMass)
    {
        Some(speed) => {
            let speed_sigma = noise_sigma(speed).max(f64::MIN_POSITIVE);
            let spacing = ((load_pos_sigma / speed_sigma).powi(2) / dt)
                .clamp(SLOW_TWIST_KNOT_SPACING.0, SLOW_TWIST_KNOT_SPACING.1);
            let (t0, t1) = (time[0], time[time.len() - 1]);
            let count = ((t1 - t0) / spacing).ceil().max(1.0) as usize;
            notes.push(format!(
                "the motor position is integrated from a speed signal (noise {speed_sigma:.2e} rad/s): its twist is trusted over {:.2} s, and the twist offset is a free piecewise linear function of time with {} knots",
                (t1 - t0) / count as f64,
                count + 1
            ));
            let knots: Vec<f64> = (0..=count).map(|j| t0 + (t1 - t0) * j as f64 / count as f64).collect();
            hat_functions(&knots, time)
        }
        None => Vec::new(),
    }
}

/// The residual channels of a parameter set on conditioned data: measured side and model side.
pub fn model_channels(data: &EquationData, params: &ParameterSet) -> Vec<ChannelData> {
    let n = data.len();
    let gear = data.gear_ratio;
    let motor_inertia = params.value(names::MOTOR_INERTIA) * gear * gear;
    let load_inertia = params.value(names::LOAD_INERTIA);
    let stiffness = params.value(names::STIFFNESS);
    let damping = params.value(names::DAMPING);
    let viscous = params.value(names::VISCOUS);
    let scale = params.value(names::TORQUE_CONSTANT_SCALE);
    let delay = params.value(names::DELAY);

    let friction_static =
        data.smooth(&data.motor_vel_inner.iter().map(|&v| static_friction_curve(params, v)).collect::<Vec<_>>());
    let cogging = cogging_torque(data, params);
    let unbalance_amplitude = params.value(names::UNBALANCE_TORQUE);
    let unbalance_phase = params.value(names::UNBALANCE_PHASE);
    let unbalance: Vec<f64> = data.angle.iter().map(|a| unbalance_amplitude * (a + unbalance_phase).cos()).collect();
    let offset = params.value(names::TORQUE_OFFSET);
    let disturbance = data.disturbance.clone().unwrap_or_else(|| vec![0.0; n]);
    let backlash = params.value(names::BACKLASH_WIDTH);
    let backlash_sign = if backlash > 0.0 { backlash_sign(data, params) } else { vec![0.0; n] };

    let torque: Vec<f64> = if delay != 0.0 { data.torque_delayed(delay) } else { data.torque.clone() };
    // The torque-constant scale divides the model side: the measured torque stays fixed, so no
    // choice of parameters can scale the equation to zero.
    let measured_torque = torque;
    let inverse_scale = 1.0 / scale;
    let moving = data.sliding();

    match data.structure {
        Structure::TwoMass => {
            // The load equation K (tw - c) - K b/2 sign + D dtw = S_L, solved for the twist and
            // scaled to torque by the starting stiffness K0 (a fixed unit, not a parameter):
            // measured K0 tw, model K0 (b/2) sign + (K0/K) (S_L - D dtw). With the measured
            // side fixed, no scaling of the parameters can fit it to zero; only the ratio of
            // load inertia to stiffness (the anti-resonance) is seen here, and the motor
            // equation fixes the stiffness itself. The twist offset c is a nuisance column.
            let k0 = data.twist_scale;
            let ratio = k0 / stiffness;
            let motor_model: Vec<f64> = (0..n)
                .map(|i| {
                    let shaft = stiffness * data.twist[i] + damping * data.twist_rate[i]
                        - 0.5 * stiffness * backlash * backlash_sign[i];
                    inverse_scale
                        * (motor_inertia * data.motor_acc[i]
                            + shaft
                            + viscous * data.motor_vel[i]
                            + friction_static[i]
                            + cogging[i])
                })
                .collect();
            // The torque offset acts on the load, as the plant FMU's load.torque_offset does.
            // With the free twist offset c, an offset at the motor and one at the load fit the
            // data equally (they differ by a constant twist, offset/K).
            let load_model: Vec<f64> = (0..n)
                .map(|i| {
                    let load_side = load_inertia * data.load_acc[i] + unbalance[i] + offset - disturbance[i];
                    0.5 * k0 * backlash * backlash_sign[i] + ratio * (load_side - damping * data.twist_rate[i])
                })
                .collect();
            let measured_twist: Vec<f64> = data.twist.iter().map(|t| k0 * t).collect();
            vec![
                ChannelData {
                    name: "motor torque balance",
                    measured: measured_torque,
                    predicted: motor_model,
                    mask: moving,
                },
                ChannelData {
                    name: "load torque balance",
                    measured: measured_twist,
                    predicted: load_model,
                    mask: vec![true; n],
                },
            ]
        }
        Structure::TotalTwoEncoders | Structure::Rigid => {
            let (motor_acc, load_acc) = (&data.motor_acc, &data.load_acc);
            let model: Vec<f64> = (0..n)
                .map(|i| {
                    inverse_scale
                        * (motor_inertia * motor_acc[i]
                            + load_inertia * load_acc[i]
                            + viscous * data.motor_vel[i]
                            + friction_static[i]
                            + offset
                            + cogging[i]
                            + unbalance[i]
                            - disturbance[i])
                })
                .collect();
            vec![ChannelData {
                name: "total torque balance",
                measured: measured_torque,
                predicted: model,
                mask: moving,
            }]
        }
    }
}

/// The parameter set's position-periodic (cogging) torque on the motor, smoothed like the
/// measured torque (axis side, N m); zero when the set has none.
pub fn cogging_torque(data: &EquationData, params: &ParameterSet) -> Vec<f64> {
    let amplitude = params.value(names::COGGING_AMPLITUDE);
    let period = params.value(names::COGGING_PERIOD);
    if amplitude == 0.0 || period <= 0.0 {
        return vec![0.0; data.len()];
    }
    let phase = params.value(names::COGGING_PHASE);
    data.smooth(
        &data
            .motor_pos_inner
            .iter()
            .map(|q| amplitude * (2.0 * std::f64::consts::PI * q / period + phase).sin())
            .collect::<Vec<_>>(),
    )
}

/// The sign of the twist relative to the centre of the dead zone, smoothed like the torque:
/// the direction in which the drive path is in contact. The centre is the twist at zero shaft
/// torque, estimated robustly (median) from the load equation.
pub fn backlash_sign(data: &EquationData, params: &ParameterSet) -> Vec<f64> {
    let centres = twist_centres(data, params);
    let h = data.half_width;
    let last = centres.len() - 1;
    // The inner region reaches h samples beyond the analysed one each side.
    data.smooth(
        &data
            .twist_inner
            .iter()
            .enumerate()
            .map(|(j, t)| (t - centres[j.saturating_sub(h).min(last)]).signum())
            .collect::<Vec<_>>(),
    )
}

/// The twist at zero shaft torque on every analysed sample: the constant [`twist_centre`], or,
/// for a motor position integrated from a speed signal, a piecewise linear function of time on
/// the data's slow-twist knots fitted by least squares to the same per-sample estimates (the
/// slow part of such a twist is the speed sensor's drift, which only a model can put back;
/// every parameter set gets its own, as it gets its own constant centre).
pub fn twist_centres(data: &EquationData, params: &ParameterSet) -> Vec<f64> {
    if data.slow_twist_hats.is_empty() {
        return vec![twist_centre(data, params); data.len()];
    }
    let implied = implied_twist_centres(data, params);
    let hats = &data.slow_twist_hats;
    let (beta, _) = weighted_least_squares(hats, &implied, &vec![1.0; implied.len()]);
    (0..data.len()).map(|i| hats.iter().zip(&beta).map(|(h, b)| h[i] * b).sum()).collect()
}

/// Per analysed sample, the measured twist less the twist the load equation needs.
fn implied_twist_centres(data: &EquationData, params: &ParameterSet) -> Vec<f64> {
    let stiffness = params.value(names::STIFFNESS).max(f64::MIN_POSITIVE);
    let load_inertia = params.value(names::LOAD_INERTIA);
    let amplitude = params.value(names::UNBALANCE_TORQUE);
    let phase = params.value(names::UNBALANCE_PHASE);
    let offset = params.value(names::TORQUE_OFFSET);
    let damping = params.value(names::DAMPING);
    (0..data.len())
        .map(|i| {
            let disturbance = data.disturbance.as_ref().map_or(0.0, |d| d[i]);
            let load_side =
                load_inertia * data.load_acc[i] + amplitude * (data.angle[i] + phase).cos() + offset - disturbance;
            data.twist[i] - (load_side - damping * data.twist_rate[i]) / stiffness
        })
        .collect()
}

/// The measured twist at zero shaft torque (encoder zero offsets, preload, the centre of a
/// backlash gap): the median over the log of the measured twist minus the twist the load
/// equation needs. The output-error route starts the plant's path deflection at the measured
/// twist minus this.
pub fn twist_centre(data: &EquationData, params: &ParameterSet) -> f64 {
    let mut centres = implied_twist_centres(data, params);
    centres.sort_by(|a, b| a.total_cmp(b));
    centres[centres.len() / 2]
}

/// Five-point central difference stencils, in units of one sample.
const FIRST_STENCIL: [f64; 5] = [1.0 / 12.0, -8.0 / 12.0, 0.0, 8.0 / 12.0, -1.0 / 12.0];
const SECOND_STENCIL: [f64; 5] = [-1.0 / 12.0, 16.0 / 12.0, -30.0 / 12.0, 16.0 / 12.0, -1.0 / 12.0];

/// Full convolution of two coefficient vectors: the impulse response of one filter after the
/// other.
fn convolve(a: &[f64], b: &[f64]) -> Vec<f64> {
    let mut out = vec![0.0; a.len() + b.len() - 1];
    for (i, x) in a.iter().enumerate() {
        for (j, y) in b.iter().enumerate() {
            out[i + j] += x * y;
        }
    }
    out
}

/// Five-point central first derivative; the two samples at each end copy their neighbours.
fn central_first(x: &[f64], dt: f64) -> Vec<f64> {
    let n = x.len();
    let mut out = vec![0.0; n];
    for i in 2..n.saturating_sub(2) {
        out[i] = (x[i - 2] - 8.0 * x[i - 1] + 8.0 * x[i + 1] - x[i + 2]) / (12.0 * dt);
    }
    fill_ends(&mut out);
    out
}

/// Five-point central second derivative; the two samples at each end copy their neighbours.
fn central_second(x: &[f64], dt: f64) -> Vec<f64> {
    let n = x.len();
    let mut out = vec![0.0; n];
    for i in 2..n.saturating_sub(2) {
        out[i] = (-x[i - 2] + 16.0 * x[i - 1] - 30.0 * x[i] + 16.0 * x[i + 1] - x[i + 2]) / (12.0 * dt * dt);
    }
    fill_ends(&mut out);
    out
}

fn fill_ends(x: &mut [f64]) {
    let n = x.len();
    if n >= 5 {
        x[0] = x[2];
        x[1] = x[2];
        x[n - 1] = x[n - 3];
        x[n - 2] = x[n - 3];
    }
}

/// Resamples a log whose sampling is uneven (more than 1 % jitter) onto a uniform grid.
pub fn uniform(log: &MeasuredLog, notes: &mut Vec<String>) -> MeasuredLog {
    let dt = log.sample_interval();
    let uneven = log.time.windows(2).any(|w| ((w[1] - w[0]) / dt - 1.0).abs() > 0.01);
    if !uneven {
        return log.clone();
    }
    let t0 = log.time[0];
    let count = ((log.time[log.len() - 1] - t0) / dt).floor() as usize + 1;
    let grid: Vec<f64> = (0..count).map(|i| t0 + i as f64 * dt).collect();
    let mut out = log.clone();
    for channel in &mut out.channels {
        channel.values =
            grid.iter().map(|&t| antenna_dsp::conditioning::interpolate(&log.time, &channel.values, t)).collect();
    }
    out.time = grid;
    notes.push(format!("sampling is uneven: resampled to a uniform {dt:.6} s grid by linear interpolation"));
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hat_functions_interpolate_linearly_and_sum_to_one() {
        let knots = [0.0, 1.0, 3.0];
        let time: Vec<f64> = (0..=30).map(|k| k as f64 * 0.1).collect();
        let hats = hat_functions(&knots, &time);
        assert_eq!(hats.len(), 3);
        for (i, t) in time.iter().enumerate() {
            let sum: f64 = hats.iter().map(|h| h[i]).sum();
            assert!((sum - 1.0).abs() < 1e-12, "sum {sum} at {t}");
            // Values at the knots interpolate linearly: sum of h_j(t) x_j for x = t^1 is t.
            let interpolated: f64 = hats.iter().zip(&knots).map(|(h, x)| h[i] * x).sum();
            assert!((interpolated - t).abs() < 1e-12, "{interpolated} at {t}");
        }
        assert_eq!(hats[1][10], 1.0);
        assert_eq!(hats[0][20], 0.0);
    }
}
