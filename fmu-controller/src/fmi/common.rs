//! Pieces shared by the two controller FMUs: the cascade parameters (sampling, profiler,
//! loops, feedforwards, anti-limit-cycle) read from variable values, the status outputs, and
//! the model information.

use fmu_runtime::{DefaultExperiment, ModelInfo, Values, VariableSet};
use serde::{Deserialize, Serialize};

use crate::cascade::CascadeState;
use crate::params::CascadeParams;
use crate::status::AxisStatus;
use crate::timing::{SampleScheduler, SchedulerState};

/// A controller FMU's part of an FMU state, for outputs `O`; both parts are absent before
/// initialisation, and the scheduler before the first step.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ControllerState<O> {
    pub cascade: Option<CascadeState>,
    pub scheduler: Option<SchedulerState<O>>,
}

impl<O: Clone> ControllerState<O> {
    /// Writes a controller's state over this one, reusing the pending outputs' storage (the
    /// runtime keeps a state before every step: this way the step does not allocate).
    pub fn overwrite(&mut self, cascade: Option<CascadeState>, scheduler: Option<&SampleScheduler<O>>) {
        self.cascade = cascade;
        match (scheduler, &mut self.scheduler) {
            (Some(scheduler), Some(kept)) => scheduler.save_into(kept),
            (scheduler, kept) => *kept = scheduler.map(SampleScheduler::saved_state),
        }
    }
}

const ARCSEC_DEG: f64 = 1.0 / 3600.0;

// Declared bounds of the controllers' inputs and parameters (docs/fmu-robustness.md): each far
// beyond any drive of a 13-15 m dish, so that no real configuration meets it, and near enough
// that no value inside it is a denormal or 1e308 stand-in that overflows the arithmetic.

/// Largest position command or measured position, deg (either sign): a hundred turns, beyond
/// any travel, so that open-loop identification runs that turn the axis still fit.
pub const MAX_POSITION_DEG: f64 = 36_000.0;

/// Largest commanded or profiled axis speed, deg/s (fifty times the azimuth slew speed).
pub const MAX_AXIS_SPEED_DEG_PER_S: f64 = 100.0;

/// Largest axis acceleration limit, deg/s^2, and jerk limit, deg/s^3: far above any drive,
/// so that identification runs can switch a limiter off with a value such as 1e6 deg/s^2
/// (tools/sim, velocity-loop Bode).
pub const MAX_AXIS_ACCELERATION: f64 = 1e7;
pub const MAX_AXIS_JERK: f64 = 1e9;

/// Largest measured motor speed, rad/s (about 95,000 rpm).
pub const MAX_MOTOR_SPEED: f64 = 1e4;

/// Largest current command or limit, A.
pub const MAX_CURRENT: f64 = 1e4;

/// Largest loop frequency (bandwidths, crossovers, corners, filters), Hz: above the Nyquist
/// frequency of the fastest sampling.sample_time allowed.
pub const MAX_LOOP_FREQUENCY: f64 = 1e5;

/// Largest gain override of the position loop, 1/s, and of the speed loops, N m s/rad.
pub const MAX_POSITION_GAIN: f64 = 1e4;
pub const MAX_SPEED_GAIN: f64 = 1e6;

/// Largest torque of the bias, differential loop or friction feedforward at a motor, N m.
pub const MAX_MOTOR_TORQUE: f64 = 1e4;

/// Largest position error band of the anti-limit-cycle hold, arcsec (one degree).
pub const MAX_HOLD_ERROR_ARCSEC: f64 = 3600.0;

/// Largest gear ratio, motor inertia (kg m^2), axis inertia (kg m^2) and torque constant
/// (N m/A) the controller may assume: the plants' bounds.
pub const MAX_GEAR_RATIO: f64 = 1e6;
pub const MAX_MOTOR_INERTIA: f64 = 10.0;
pub const MAX_AXIS_INERTIA: f64 = 1e9;
pub const MAX_TORQUE_CONSTANT: f64 = 100.0;

/// Smallest positive values of quantities that must be positive, as the plants declare them.
pub const MIN_MOTOR_INERTIA: f64 = 1e-6;
pub const TINY: f64 = 1e-9;

/// A gain override of 0 means "use the designed gain".
fn override_or_design(value: f64) -> Option<f64> {
    (value > 0.0).then_some(value)
}

/// The value references of the cascade parameters both axes share.
pub struct CascadeVars<V> {
    pub sample_time: V,
    pub delay_samples: V,
    pub profiler_enabled: V,
    pub profiler_max_velocity: V,
    pub profiler_max_acceleration: V,
    pub profiler_jerk_limit: V,
    pub profiler_step_threshold: V,
    pub velocity_feedforward: V,
    pub acceleration_feedforward: V,
    pub position_bandwidth: V,
    pub position_gain_override: V,
    pub position_integrator: V,
    pub position_integral_corner: V,
    pub position_max_velocity: V,
    pub position_max_acceleration: V,
    pub velocity_crossover: V,
    pub velocity_integral_ratio: V,
    pub velocity_gain_override: V,
    pub velocity_integral_override: V,
    pub velocity_integrator: V,
    pub anti_windup: V,
    pub speed_low_pass: V,
    pub notch_frequency: V,
    pub notch_damping: V,
    pub notch_depth: V,
    pub anti_limit_cycle: V,
    pub hold_entry: V,
    pub hold_release: V,
    pub hold_motion_band: V,
    pub rest_time: V,
}

impl<V: VariableSet> CascadeVars<V> {
    /// The cascade parameters: the axis defaults with every exposed value applied.
    pub fn read(&self, v: &Values<V>, defaults: CascadeParams) -> CascadeParams {
        let mut c = defaults;
        c.sampling.sample_time_s = v.real(self.sample_time);
        c.sampling.delay_samples = v.integer(self.delay_samples) as u32;
        c.profiler.enabled = v.boolean(self.profiler_enabled);
        c.profiler.max_velocity_deg_per_s = v.real(self.profiler_max_velocity);
        c.profiler.max_acceleration_deg_per_s2 = v.real(self.profiler_max_acceleration);
        c.profiler.jerk_limit_deg_per_s3 = v.real(self.profiler_jerk_limit);
        c.profiler.step_threshold_deg = v.real(self.profiler_step_threshold);
        c.feedforward.velocity_enabled = v.boolean(self.velocity_feedforward);
        c.feedforward.acceleration_enabled = v.boolean(self.acceleration_feedforward);
        c.position_loop.bandwidth_hz = v.real(self.position_bandwidth);
        c.position_loop.proportional_gain_override_per_s = override_or_design(v.real(self.position_gain_override));
        c.position_loop.integrator_enabled = v.boolean(self.position_integrator);
        c.position_loop.integral_corner_hz = v.real(self.position_integral_corner);
        c.position_loop.max_velocity_deg_per_s = v.real(self.position_max_velocity);
        c.position_loop.max_acceleration_deg_per_s2 = v.real(self.position_max_acceleration);
        c.velocity_loop.crossover_hz = v.real(self.velocity_crossover);
        c.velocity_loop.integral_corner_ratio = v.real(self.velocity_integral_ratio);
        c.velocity_loop.proportional_gain_override_nm_s_per_rad =
            override_or_design(v.real(self.velocity_gain_override));
        c.velocity_loop.integral_corner_override_hz = override_or_design(v.real(self.velocity_integral_override));
        c.velocity_loop.integrator_enabled = v.boolean(self.velocity_integrator);
        c.velocity_loop.anti_windup_enabled = v.boolean(self.anti_windup);
        c.velocity_loop.speed_low_pass_hz = v.real(self.speed_low_pass);
        c.velocity_loop.speed_notch.frequency_hz = v.real(self.notch_frequency);
        c.velocity_loop.speed_notch.damping = v.real(self.notch_damping);
        c.velocity_loop.speed_notch.depth = v.real(self.notch_depth);
        c.anti_limit_cycle.enabled = v.boolean(self.anti_limit_cycle);
        c.anti_limit_cycle.hold_entry_error_deg = v.real(self.hold_entry) * ARCSEC_DEG;
        c.anti_limit_cycle.hold_release_error_deg = v.real(self.hold_release) * ARCSEC_DEG;
        c.anti_limit_cycle.hold_motion_band_deg = v.real(self.hold_motion_band) * ARCSEC_DEG;
        c.anti_limit_cycle.rest_time_s = v.real(self.rest_time);
        c
    }
}

/// The value references of the status outputs both axes share.
pub struct StatusVars<V> {
    pub reference_position: V,
    pub reference_velocity: V,
    pub reference_acceleration: V,
    pub position_error: V,
    pub command_error: V,
    pub velocity_reference: V,
    pub measured_velocity: V,
    pub torque_command: V,
    pub profiling: V,
    pub torque_limited: V,
    pub holding: V,
}

impl<V: VariableSet> StatusVars<V> {
    pub fn write(&self, s: &AxisStatus, v: &mut Values<V>) {
        v.set_real(self.reference_position, s.reference_position_deg);
        v.set_real(self.reference_velocity, s.reference_velocity_deg_per_s);
        v.set_real(self.reference_acceleration, s.reference_acceleration_deg_per_s2);
        v.set_real(self.position_error, s.position_error_deg * 3600.0);
        v.set_real(self.command_error, s.command_error_deg * 3600.0);
        v.set_real(self.velocity_reference, s.velocity_reference_deg_per_s);
        v.set_real(self.measured_velocity, s.measured_velocity_deg_per_s);
        v.set_real(self.torque_command, s.torque_command_nm);
        v.set_boolean(self.profiling, s.profiling);
        v.set_boolean(self.torque_limited, s.torque_limited);
        v.set_boolean(self.holding, s.holding);
    }
}

pub fn model_info(identifier: &'static str, description: &'static str) -> ModelInfo {
    ModelInfo {
        model_identifier: identifier,
        model_name: identifier,
        description,
        author: "MeerKAT antenna positioner reference model contributors",
        version: env!("CARGO_PKG_VERSION"),
        default_experiment: DefaultExperiment { start_time: 0.0, stop_time: 10.0, step_size: 1e-3 },
    }
}
