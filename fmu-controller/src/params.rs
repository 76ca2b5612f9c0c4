//! Parameters of the azimuth and elevation controllers, their MeerKAT-like defaults and their
//! validation.
//!
//! Every field carries its unit in its name and doc comment so that it maps one-to-one onto a
//! named FMI parameter. Angles at this edge are in degrees (the ACU's and the pointing model's
//! unit); everything inside the controller is SI (rad, rad/s, N m). Each feature of the seed
//! paper's Fig. 3 has an `enabled` flag so that it can be switched off on its own, as the
//! paper's identification runs needed. `docs/controller.md` explains how the defaults were
//! chosen.

/// One arcsecond in degrees.
pub const ARCSEC_DEG: f64 = 1.0 / 3600.0;

/// Sampling of the discrete controller and its computation/transport delay.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SamplingParams {
    /// Sample time `Ts`, s. 1 ms (1 kHz) is typical of a PC-based ACU and is ten times faster
    /// than the 100 Hz current loop it commands.
    pub sample_time_s: f64,
    /// Computation/transport delay in whole samples: the currents computed from the
    /// measurements taken at `t_k` are applied from `t_k + delay_samples * Ts` on. 1 (the
    /// default) models an ACU that writes its outputs at the next sample tick.
    pub delay_samples: u32,
}

impl SamplingParams {
    /// Longest delay accepted; it bounds the memory of the output queue.
    pub const MAX_DELAY_SAMPLES: u32 = 64;
}

impl Default for SamplingParams {
    fn default() -> Self {
        Self { sample_time_s: 1.0e-3, delay_samples: 1 }
    }
}

/// The command profiler of Fig. 3: turns position steps into a velocity- and
/// acceleration-limited trajectory that does not overshoot; inactive while tracking.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ProfilerParams {
    /// Switches the profiler on. Off, the position command goes straight to the position
    /// loop, whose velocity and acceleration limits then make large steps overshoot.
    pub enabled: bool,
    /// Largest profiled axis speed, deg/s (the antenna's maximum slew speed).
    pub max_velocity_deg_per_s: f64,
    /// Largest profiled axis acceleration, deg/s^2, used to accelerate.
    pub max_acceleration_deg_per_s2: f64,
    /// Fraction of `max_acceleration_deg_per_s2` planned for braking, in (0, 1]. Planning to
    /// brake below the limit leaves acceleration in reserve to absorb a moving target and the
    /// lag of the profiler's own velocity loop, which is what keeps it from overshooting.
    pub deceleration_fraction: f64,
    /// Gain of the final, linear approach to the target, 1/s: within the last few arcmin
    /// the profiled velocity relative to the target is this gain times the distance to go.
    pub approach_gain_per_s: f64,
    /// Gain with which the profiled acceleration follows the wanted velocity, 1/s. At least
    /// four times `approach_gain_per_s`, so that the final approach is critically damped or
    /// slower and never crosses the target.
    pub velocity_gain_per_s: f64,
    /// Largest rate of change of the profiled acceleration, deg/s^3; 0 (the default) means no
    /// jerk limit. When set, the braking curve is lengthened for the jerk ramp; it must exceed
    /// `deceleration_fraction * max_acceleration * approach_gain / 2`.
    pub jerk_limit_deg_per_s3: f64,
    /// A position command that departs from the reference's prediction by more than this is a
    /// step and is profiled, deg. Smaller jumps go to the position loop directly, which
    /// follows them linearly within its limits.
    pub step_threshold_deg: f64,
    /// A command velocity that departs from the reference velocity by more than this is a
    /// step too, deg/s. It lies above the fastest tracking rate (0.04 deg/s, Req. 5), so
    /// starting or stopping a track never starts a profile.
    pub velocity_step_threshold_deg_per_s: f64,
    /// The profile hands back to tracking once it is this close to the target, deg.
    pub handover_position_tolerance_deg: f64,
    /// ... and its velocity this close to the command velocity, deg/s.
    pub handover_velocity_tolerance_deg_per_s: f64,
}

impl ProfilerParams {
    fn for_axis(max_velocity_deg_per_s: f64, max_acceleration_deg_per_s2: f64) -> Self {
        Self {
            enabled: true,
            max_velocity_deg_per_s,
            max_acceleration_deg_per_s2,
            deceleration_fraction: 0.8,
            approach_gain_per_s: 4.0,
            velocity_gain_per_s: 24.0,
            jerk_limit_deg_per_s3: 0.0,
            step_threshold_deg: 0.002,
            velocity_step_threshold_deg_per_s: 0.05,
            handover_position_tolerance_deg: 1.0e-6,
            handover_velocity_tolerance_deg_per_s: 1.0e-5,
        }
    }
}

/// Velocity and acceleration feedforward into the velocity loop.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FeedforwardParams {
    /// Adds the reference velocity (profiled, or the command velocity while tracking) to the
    /// position loop's output.
    pub velocity_enabled: bool,
    /// Adds `J_total * N * a_ref` to the torque command, `a_ref` the reference acceleration.
    pub acceleration_enabled: bool,
}

impl Default for FeedforwardParams {
    fn default() -> Self {
        Self { velocity_enabled: true, acceleration_enabled: true }
    }
}

/// The position loop: proportional (optionally with a small integral) on the axis encoder,
/// with velocity and acceleration limits on its velocity reference.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PositionLoopParams {
    /// Closed-loop bandwidth the proportional gain is designed for, Hz: `Kp = 2 pi f`. With
    /// the 10-15 Hz velocity loop inside, the -3 dB bandwidth comes out within a few percent
    /// of this (the paper: 0.5-1 Hz).
    pub bandwidth_hz: f64,
    /// Uses this proportional gain instead of the designed one, 1/s (deg/s per deg).
    pub proportional_gain_override_per_s: Option<f64>,
    /// Adds an integral term. Off by default: the velocity loop's integrator already makes
    /// the static position error under a constant torque zero; see `docs/controller.md`.
    pub integrator_enabled: bool,
    /// Corner frequency of the integral term, Hz: `Ki = Kp * 2 pi f`.
    pub integral_corner_hz: f64,
    /// Limit on the velocity reference, deg/s. A little above the profiler's limit so that
    /// the loop can still correct an error while the profile cruises.
    pub max_velocity_deg_per_s: f64,
    /// Limit on the rate of change of the velocity reference, deg/s^2. Above the profiler's
    /// limit for the same reason.
    pub max_acceleration_deg_per_s2: f64,
}

impl PositionLoopParams {
    fn for_axis(max_velocity_deg_per_s: f64, max_acceleration_deg_per_s2: f64) -> Self {
        Self {
            bandwidth_hz: 0.75,
            proportional_gain_override_per_s: None,
            integrator_enabled: false,
            integral_corner_hz: 0.05,
            max_velocity_deg_per_s,
            max_acceleration_deg_per_s2,
        }
    }
}

/// A second-order notch on the measured motor speed, `(s^2 + 2 d z w s + w^2) / (s^2 + 2 z w
/// s + w^2)` at `w = 2 pi f`, discretised by the bilinear transform prewarped at `f`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NotchParams {
    /// Notch frequency, Hz; 0 (the default) switches the notch off.
    pub frequency_hz: f64,
    /// Damping `z` of the notch's poles; sets its width.
    pub damping: f64,
    /// Depth `d`: the gain at the notch frequency, in (0, 1).
    pub depth: f64,
}

impl Default for NotchParams {
    fn default() -> Self {
        Self { frequency_hz: 0.0, damping: 0.5, depth: 0.1 }
    }
}

/// The velocity loop: PI on the motor speed, gains designed from the drive model.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct VelocityLoopParams {
    /// Rigid-body crossover frequency the proportional gain is designed for, Hz:
    /// `Kv = 2 pi f J_total`. With the PI zero, the delay and the drive's compliance the
    /// closed loop's -3 dB bandwidth comes out 1.1-1.25 times higher (11-12.5 Hz at 10 Hz).
    pub crossover_hz: f64,
    /// Ratio of the crossover to the integral corner frequency: `f_i = crossover / ratio`.
    pub integral_corner_ratio: f64,
    /// Uses this proportional gain instead of the designed one, N m per motor rad/s.
    pub proportional_gain_override_nm_s_per_rad: Option<f64>,
    /// Uses this integral corner instead of the designed one, Hz.
    pub integral_corner_override_hz: Option<f64>,
    /// Switches the integral term on.
    pub integrator_enabled: bool,
    /// Stops integrating while the torque command is saturated in the direction the error
    /// pushes it (conditional integration), and bounds the integral to the torque limit.
    pub anti_windup_enabled: bool,
    /// In velocity mode, limits the rate of change of the velocity command to the position
    /// loop's acceleration limit. Switch it off to inject broadband test signals.
    pub velocity_mode_acceleration_limited: bool,
    /// Corner of a first-order low-pass on the measured motor speed, Hz; 0 (the default)
    /// switches it off.
    pub speed_low_pass_hz: f64,
    /// Notch on the measured motor speed; off by default.
    pub speed_notch: NotchParams,
}

impl Default for VelocityLoopParams {
    fn default() -> Self {
        Self {
            crossover_hz: 10.0,
            integral_corner_ratio: 5.0,
            proportional_gain_override_nm_s_per_rad: None,
            integral_corner_override_hz: None,
            integrator_enabled: true,
            anti_windup_enabled: true,
            velocity_mode_acceleration_limited: true,
            speed_low_pass_hz: 0.0,
            speed_notch: NotchParams::default(),
        }
    }
}

/// The anti-limit-cycle measure. With stiction, an integrator near a stationary target ramps
/// the torque up to breakaway, the axis slips past the target, sticks, and the cycle repeats
/// the other way (hunting). The measure freezes the integrators (velocity and position) once
/// the axis has stuck within a window around a stationary target, and runs them again when
/// the error leaves a wider window; the proportional paths stay active throughout.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AntiLimitCycleParams {
    /// Switches the measure on.
    pub enabled: bool,
    /// The integrators freeze when the axis is at rest with a position error below this, deg.
    /// It must exceed half the slip of one stick-slip event to catch a cycle; it is also the
    /// largest static error the hold can leave.
    pub hold_entry_error_deg: f64,
    /// ... and run again once the error exceeds this, deg. Larger than the entry level.
    pub hold_release_error_deg: f64,
    /// ... or once the measured position has moved by more than this since the hold began,
    /// deg: a held axis that moves is not stuck but pushed (by wind), and needs its
    /// integrators. Above the encoder's reading noise and count.
    pub hold_motion_band_deg: f64,
    /// The axis must have been at rest this long before the hold engages, s: friction sticks an
    /// axis for good, while a wind-driven axis only passes through zero speed (and a noisy
    /// speed signal only dips below the rest speed for a sample).
    pub rest_time_s: f64,
    /// The axis counts as at rest below this measured axis speed, deg/s.
    pub rest_speed_deg_per_s: f64,
    /// The command counts as stationary while not profiling and while the reference
    /// velocity is below this, deg/s (an eighth of the sidereal rate by default).
    pub stationary_velocity_deg_per_s: f64,
}

impl Default for AntiLimitCycleParams {
    fn default() -> Self {
        Self {
            enabled: true,
            hold_entry_error_deg: 2.0 * ARCSEC_DEG,
            hold_release_error_deg: 4.0 * ARCSEC_DEG,
            hold_motion_band_deg: 0.5 * ARCSEC_DEG,
            rest_time_s: 0.25,
            rest_speed_deg_per_s: 1.0e-5,
            stationary_velocity_deg_per_s: 5.0e-4,
        }
    }
}

/// Everything the azimuth and elevation controllers share: profiler, position loop, velocity
/// loop, feedforward, anti-limit-cycle measure and sampling.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CascadeParams {
    pub sampling: SamplingParams,
    pub profiler: ProfilerParams,
    pub feedforward: FeedforwardParams,
    pub position_loop: PositionLoopParams,
    pub velocity_loop: VelocityLoopParams,
    pub anti_limit_cycle: AntiLimitCycleParams,
}

impl CascadeParams {
    /// Defaults for an axis with the given maximum slew speed (deg/s) and profiled
    /// acceleration (deg/s^2); the position loop gets 5 % velocity and 100 % acceleration
    /// headroom above the profile.
    pub fn for_axis(max_slew_deg_per_s: f64, max_acceleration_deg_per_s2: f64) -> Self {
        Self {
            sampling: SamplingParams::default(),
            profiler: ProfilerParams::for_axis(max_slew_deg_per_s, max_acceleration_deg_per_s2),
            feedforward: FeedforwardParams::default(),
            position_loop: PositionLoopParams::for_axis(1.05 * max_slew_deg_per_s, 2.0 * max_acceleration_deg_per_s2),
            velocity_loop: VelocityLoopParams::default(),
            anti_limit_cycle: AntiLimitCycleParams::default(),
        }
    }

    fn validate(&self, errors: &mut Vec<String>) {
        let s = &self.sampling;
        positive("sampling.sample_time_s", s.sample_time_s, errors);
        if s.sample_time_s > 0.1 {
            errors.push(format!("sampling.sample_time_s ({}) must be at most 0.1 s", s.sample_time_s));
        }
        if s.delay_samples > SamplingParams::MAX_DELAY_SAMPLES {
            errors.push(format!(
                "sampling.delay_samples ({}) must be at most {}",
                s.delay_samples,
                SamplingParams::MAX_DELAY_SAMPLES
            ));
        }

        let p = &self.profiler;
        positive("profiler.max_velocity_deg_per_s", p.max_velocity_deg_per_s, errors);
        positive("profiler.max_acceleration_deg_per_s2", p.max_acceleration_deg_per_s2, errors);
        if !(p.deceleration_fraction > 0.0 && p.deceleration_fraction <= 1.0) {
            errors.push(format!("profiler.deceleration_fraction ({}) must lie in (0, 1]", p.deceleration_fraction));
        }
        positive("profiler.approach_gain_per_s", p.approach_gain_per_s, errors);
        positive("profiler.velocity_gain_per_s", p.velocity_gain_per_s, errors);
        if p.velocity_gain_per_s < 4.0 * p.approach_gain_per_s {
            errors.push(format!(
                "profiler.velocity_gain_per_s ({}) must be at least 4 x profiler.approach_gain_per_s ({}): \
                 a faster approach than critically damped crosses the target",
                p.velocity_gain_per_s, p.approach_gain_per_s
            ));
        }
        if s.sample_time_s > 0.0 && p.velocity_gain_per_s * s.sample_time_s > 0.5 {
            errors.push(format!(
                "profiler.velocity_gain_per_s ({}) times the sample time must stay below 0.5",
                p.velocity_gain_per_s
            ));
        }
        non_negative("profiler.jerk_limit_deg_per_s3", p.jerk_limit_deg_per_s3, errors);
        let braking = p.deceleration_fraction * p.max_acceleration_deg_per_s2;
        if p.jerk_limit_deg_per_s3 > 0.0 && p.jerk_limit_deg_per_s3 <= 0.5 * braking * p.approach_gain_per_s {
            errors.push(format!(
                "profiler.jerk_limit_deg_per_s3 ({}) must exceed deceleration_fraction * max_acceleration * \
                 approach_gain / 2 ({}) or the braking curve cannot join the linear approach",
                p.jerk_limit_deg_per_s3,
                0.5 * braking * p.approach_gain_per_s
            ));
        }
        non_negative("profiler.step_threshold_deg", p.step_threshold_deg, errors);
        non_negative("profiler.velocity_step_threshold_deg_per_s", p.velocity_step_threshold_deg_per_s, errors);
        positive("profiler.handover_position_tolerance_deg", p.handover_position_tolerance_deg, errors);
        positive("profiler.handover_velocity_tolerance_deg_per_s", p.handover_velocity_tolerance_deg_per_s, errors);

        let l = &self.position_loop;
        positive("position_loop.bandwidth_hz", l.bandwidth_hz, errors);
        if let Some(k) = l.proportional_gain_override_per_s {
            positive("position_loop.proportional_gain_override_per_s", k, errors);
        }
        positive("position_loop.integral_corner_hz", l.integral_corner_hz, errors);
        positive("position_loop.max_velocity_deg_per_s", l.max_velocity_deg_per_s, errors);
        positive("position_loop.max_acceleration_deg_per_s2", l.max_acceleration_deg_per_s2, errors);

        let v = &self.velocity_loop;
        positive("velocity_loop.crossover_hz", v.crossover_hz, errors);
        positive("velocity_loop.integral_corner_ratio", v.integral_corner_ratio, errors);
        if let Some(k) = v.proportional_gain_override_nm_s_per_rad {
            positive("velocity_loop.proportional_gain_override_nm_s_per_rad", k, errors);
        }
        if let Some(f) = v.integral_corner_override_hz {
            positive("velocity_loop.integral_corner_override_hz", f, errors);
        }
        let nyquist = 0.5 / s.sample_time_s;
        non_negative("velocity_loop.speed_low_pass_hz", v.speed_low_pass_hz, errors);
        if v.speed_low_pass_hz >= nyquist {
            errors.push(format!(
                "velocity_loop.speed_low_pass_hz ({}) must lie below the Nyquist frequency ({nyquist} Hz)",
                v.speed_low_pass_hz
            ));
        }
        let n = &v.speed_notch;
        non_negative("velocity_loop.speed_notch.frequency_hz", n.frequency_hz, errors);
        if n.frequency_hz >= nyquist {
            errors.push(format!(
                "velocity_loop.speed_notch.frequency_hz ({}) must lie below the Nyquist frequency ({nyquist} Hz)",
                n.frequency_hz
            ));
        }
        positive("velocity_loop.speed_notch.damping", n.damping, errors);
        if !(n.depth > 0.0 && n.depth < 1.0) {
            errors.push(format!("velocity_loop.speed_notch.depth ({}) must lie in (0, 1)", n.depth));
        }

        let a = &self.anti_limit_cycle;
        positive("anti_limit_cycle.hold_entry_error_deg", a.hold_entry_error_deg, errors);
        positive("anti_limit_cycle.hold_release_error_deg", a.hold_release_error_deg, errors);
        positive("anti_limit_cycle.hold_motion_band_deg", a.hold_motion_band_deg, errors);
        non_negative("anti_limit_cycle.rest_time_s", a.rest_time_s, errors);
        if a.hold_release_error_deg <= a.hold_entry_error_deg {
            errors.push(format!(
                "anti_limit_cycle.hold_release_error_deg ({}) must exceed hold_entry_error_deg ({}): \
                 the hysteresis is what stops the hold from chattering",
                a.hold_release_error_deg, a.hold_entry_error_deg
            ));
        }
        non_negative("anti_limit_cycle.rest_speed_deg_per_s", a.rest_speed_deg_per_s, errors);
        non_negative("anti_limit_cycle.stationary_velocity_deg_per_s", a.stationary_velocity_deg_per_s, errors);
    }
}

/// What the azimuth controller knows about its drive, used to design its gains and to
/// compute the acceleration feedforward. Defaults match `fmu_plant::AzimuthParams::default()`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AzimuthDriveModel {
    /// Gear ratio of each drive, motor rad per axis rad.
    pub gear_ratio: f64,
    /// Inertia of one motor with its gearbox input stage, kg m^2.
    pub motor_inertia_kg_m2: f64,
    /// Load inertia about the azimuth axis assumed for the design, kg m^2. The true value
    /// runs from 7.5e5 (horizon) to 9.5e5 (zenith); the default is the 45 deg value, so the
    /// loop gain is within +-6 % of its design everywhere.
    pub axis_inertia_kg_m2: f64,
    /// Motor torque constant, N m/A.
    pub torque_constant_nm_per_a: f64,
    /// Current limit of each drive, A.
    pub current_limit_a: f64,
}

impl Default for AzimuthDriveModel {
    fn default() -> Self {
        Self {
            gear_ratio: 9000.0,
            motor_inertia_kg_m2: 0.006,
            axis_inertia_kg_m2: 8.5e5,
            torque_constant_nm_per_a: 0.8,
            current_limit_a: 15.0,
        }
    }
}

impl AzimuthDriveModel {
    /// Both motors plus the load reflected through the gear, kg m^2 at the motor.
    pub fn total_inertia_at_motor_kg_m2(&self) -> f64 {
        2.0 * self.motor_inertia_kg_m2 + self.axis_inertia_kg_m2 / (self.gear_ratio * self.gear_ratio)
    }

    /// Largest torque both motors together can produce, N m at the motor.
    pub fn torque_limit_nm(&self) -> f64 {
        2.0 * self.torque_constant_nm_per_a * self.current_limit_a
    }

    fn validate(&self, errors: &mut Vec<String>) {
        positive("drive.gear_ratio", self.gear_ratio, errors);
        positive("drive.motor_inertia_kg_m2", self.motor_inertia_kg_m2, errors);
        non_negative("drive.axis_inertia_kg_m2", self.axis_inertia_kg_m2, errors);
        positive("drive.torque_constant_nm_per_a", self.torque_constant_nm_per_a, errors);
        positive("drive.current_limit_a", self.current_limit_a, errors);
    }
}

/// The elevation jackscrew's geometry as the controller knows it: enough to compute the
/// transmission ratio `N(el) = (2 pi G / lead) h(el)` with the lever arm
/// `h = r_d r_y sin(phi) / L` and `phi = phi_0 + el`. Defaults match
/// `fmu_plant::JackscrewParams` in `fmu_plant::ElevationParams::default()`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct JackscrewGeometry {
    /// Distance from the elevation pivot to the actuator's attachment on the dish, m.
    pub dish_attachment_radius_m: f64,
    /// Distance from the elevation pivot to the actuator's trunnion on the yoke, m.
    pub yoke_attachment_radius_m: f64,
    /// Angle at the pivot between the two attachment radii at 0 deg elevation, deg.
    pub attachment_angle_at_zero_elevation_deg: f64,
    /// Screw lead, m of nut travel per screw revolution.
    pub screw_lead_m: f64,
    /// Gearbox ratio between motor and screw, motor revolutions per screw revolution.
    pub gearbox_ratio: f64,
}

impl Default for JackscrewGeometry {
    fn default() -> Self {
        Self {
            dish_attachment_radius_m: 2.0,
            yoke_attachment_radius_m: 3.6,
            attachment_angle_at_zero_elevation_deg: 20.0,
            screw_lead_m: 0.02,
            gearbox_ratio: 28.0,
        }
    }
}

impl JackscrewGeometry {
    /// Transmission ratio at an elevation, motor rad per axis rad.
    pub fn ratio(&self, elevation_rad: f64) -> f64 {
        let (rd, ry) = (self.dish_attachment_radius_m, self.yoke_attachment_radius_m);
        let angle = self.attachment_angle_at_zero_elevation_deg.to_radians() + elevation_rad;
        let length = (rd * rd + ry * ry - 2.0 * rd * ry * angle.cos()).sqrt();
        let lever_arm = rd * ry * angle.sin() / length;
        std::f64::consts::TAU * self.gearbox_ratio / self.screw_lead_m * lever_arm
    }
}

/// What the elevation controller knows about its drive. Defaults match
/// `fmu_plant::ElevationParams::default()`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ElevationDriveModel {
    /// Jackscrew geometry, for the angle-dependent transmission ratio.
    pub jackscrew: JackscrewGeometry,
    /// Lower end of the travel, deg; the ratio is held at its end values outside the travel.
    pub travel_min_deg: f64,
    /// Upper end of the travel, deg.
    pub travel_max_deg: f64,
    /// Inertia of the motor with its gearbox input stage, kg m^2.
    pub motor_inertia_kg_m2: f64,
    /// Inertia of the dish structure about the elevation axis, kg m^2 (constant: balanced).
    pub dish_inertia_kg_m2: f64,
    /// Motor torque constant, N m/A.
    pub torque_constant_nm_per_a: f64,
    /// Current limit of the drive, A.
    pub current_limit_a: f64,
}

impl Default for ElevationDriveModel {
    fn default() -> Self {
        Self {
            jackscrew: JackscrewGeometry::default(),
            travel_min_deg: 15.0,
            travel_max_deg: 92.0,
            motor_inertia_kg_m2: 0.002,
            dish_inertia_kg_m2: 3.5e5,
            torque_constant_nm_per_a: 0.8,
            current_limit_a: 15.0,
        }
    }
}

impl ElevationDriveModel {
    /// Transmission ratio at an elevation (deg), held at its end values outside the travel.
    pub fn gear_ratio_at(&self, elevation_deg: f64) -> f64 {
        let clamped = elevation_deg.clamp(self.travel_min_deg, self.travel_max_deg);
        self.jackscrew.ratio(clamped.to_radians())
    }

    /// Motor plus reflected dish inertia at an elevation (deg), kg m^2 at the motor.
    pub fn total_inertia_at_motor_kg_m2(&self, elevation_deg: f64) -> f64 {
        let n = self.gear_ratio_at(elevation_deg);
        self.motor_inertia_kg_m2 + self.dish_inertia_kg_m2 / (n * n)
    }

    /// Largest motor torque, N m.
    pub fn torque_limit_nm(&self) -> f64 {
        self.torque_constant_nm_per_a * self.current_limit_a
    }

    fn validate(&self, errors: &mut Vec<String>) {
        let j = &self.jackscrew;
        positive("drive.jackscrew.dish_attachment_radius_m", j.dish_attachment_radius_m, errors);
        positive("drive.jackscrew.yoke_attachment_radius_m", j.yoke_attachment_radius_m, errors);
        finite(
            "drive.jackscrew.attachment_angle_at_zero_elevation_deg",
            j.attachment_angle_at_zero_elevation_deg,
            errors,
        );
        positive("drive.jackscrew.screw_lead_m", j.screw_lead_m, errors);
        positive("drive.jackscrew.gearbox_ratio", j.gearbox_ratio, errors);
        finite("drive.travel_min_deg", self.travel_min_deg, errors);
        finite("drive.travel_max_deg", self.travel_max_deg, errors);
        if self.travel_min_deg >= self.travel_max_deg {
            errors.push(format!(
                "drive.travel_min_deg ({}) must be below drive.travel_max_deg ({})",
                self.travel_min_deg, self.travel_max_deg
            ));
        }
        positive("drive.motor_inertia_kg_m2", self.motor_inertia_kg_m2, errors);
        non_negative("drive.dish_inertia_kg_m2", self.dish_inertia_kg_m2, errors);
        positive("drive.torque_constant_nm_per_a", self.torque_constant_nm_per_a, errors);
        positive("drive.current_limit_a", self.current_limit_a, errors);
        if errors.is_empty() {
            // The ratio must stay positive over the travel, or the velocity loop's sign flips.
            for k in 0..=100 {
                let el = self.travel_min_deg + (self.travel_max_deg - self.travel_min_deg) * k as f64 / 100.0;
                let n = self.gear_ratio_at(el);
                if !(n.is_finite() && n > 0.0) {
                    errors.push(format!("drive.jackscrew gives a non-positive ratio ({n}) at {el:.2} deg elevation"));
                    return;
                }
            }
        }
    }
}

/// Azimuth torque bias: motor 1 gets `T/2 + b(T)`, motor 2 gets `T/2 - b(T)`, with
/// `b(T) = bias` for `|T| <= fade_start`, falling linearly to 0 at `|T| = fade_end`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TorqueBiasParams {
    /// Switches the bias on.
    pub enabled: bool,
    /// Bias torque at small total torque, N m at each motor. 15 % of the rated 12 N m.
    pub bias_torque_nm: f64,
    /// Total torque (both motors, N m) at which the bias starts to fade. The default,
    /// twice the bias, is where motor 2's torque reaches zero.
    pub fade_start_torque_nm: f64,
    /// Total torque at which the bias has faded to zero and both motors drive equally, N m.
    /// At least `fade_start + 2 * bias`, so that neither motor's torque ever falls while the
    /// total rises.
    pub fade_end_torque_nm: f64,
}

impl Default for TorqueBiasParams {
    fn default() -> Self {
        Self { enabled: true, bias_torque_nm: 1.8, fade_start_torque_nm: 3.6, fade_end_torque_nm: 7.2 }
    }
}

/// The azimuth's superimposed differential speed controller: a proportional loop on the
/// difference of the two motor speeds that adds `+Delta` to motor 1 and `-Delta` to motor 2.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DifferentialLoopParams {
    /// Switches the loop on.
    pub enabled: bool,
    /// Bandwidth of the differential loop on one motor's inertia, Hz:
    /// `K_d = 2 pi f J_motor / 2` (each motor gets half of the differential torque).
    pub bandwidth_hz: f64,
    /// Uses this gain instead of the designed one, N m per rad/s of speed difference.
    pub gain_override_nm_s_per_rad: Option<f64>,
    /// Limit on the differential torque, N m per motor.
    pub max_torque_nm: f64,
}

impl Default for DifferentialLoopParams {
    fn default() -> Self {
        Self { enabled: true, bandwidth_hz: 15.0, gain_override_nm_s_per_rad: None, max_torque_nm: 3.0 }
    }
}

/// The elevation's direction-dependent friction-torque feedforward: `T_up s(v/v_b)` for
/// `v >= 0` and `T_down s(v/v_b)` for `v < 0`, with `s` a smooth odd step that reaches +-1
/// at `|v| = v_b`, `v` the reference (feedforward) velocity.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FrictionFeedforwardParams {
    /// Switches the feedforward on.
    pub enabled: bool,
    /// Torque fed forward while raising the dish (positive velocity), N m at the motor.
    pub raising_torque_nm: f64,
    /// Torque magnitude fed forward while lowering the dish, N m at the motor; it is applied
    /// negative.
    pub lowering_torque_nm: f64,
    /// Velocity band over which the feedforward builds up from zero, deg/s.
    pub velocity_band_deg_per_s: f64,
}

impl Default for FrictionFeedforwardParams {
    /// About 85 % of the default plant's sliding friction at the motor (0.15 N m motor,
    /// 8/28 N m screw, about 0.035 N m pivot): under-compensating leaves the integrator the
    /// last part and cannot make the axis creep away on its own.
    fn default() -> Self {
        Self { enabled: true, raising_torque_nm: 0.40, lowering_torque_nm: 0.40, velocity_band_deg_per_s: 0.001 }
    }
}

/// Parameters of the azimuth controller.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AzimuthControllerParams {
    pub cascade: CascadeParams,
    pub drive: AzimuthDriveModel,
    pub torque_bias: TorqueBiasParams,
    pub differential_loop: DifferentialLoopParams,
}

impl Default for AzimuthControllerParams {
    /// Maximum slew 2 deg/s, profiled acceleration 1 deg/s^2 (less than a sixth of the
    /// 6.4 deg/s^2 the drives can give at the zenith inertia, leaving torque for the loops).
    fn default() -> Self {
        Self {
            cascade: CascadeParams::for_axis(2.0, 1.0),
            drive: AzimuthDriveModel::default(),
            torque_bias: TorqueBiasParams::default(),
            differential_loop: DifferentialLoopParams::default(),
        }
    }
}

impl AzimuthControllerParams {
    /// Checks every field; the message names each offending field and its constraint.
    pub fn validate(&self) -> Result<(), ParameterError> {
        let mut errors = Vec::new();
        self.cascade.validate(&mut errors);
        self.drive.validate(&mut errors);
        let b = &self.torque_bias;
        non_negative("torque_bias.bias_torque_nm", b.bias_torque_nm, &mut errors);
        non_negative("torque_bias.fade_start_torque_nm", b.fade_start_torque_nm, &mut errors);
        finite("torque_bias.fade_end_torque_nm", b.fade_end_torque_nm, &mut errors);
        if b.fade_end_torque_nm - b.fade_start_torque_nm < 2.0 * b.bias_torque_nm
            || b.fade_end_torque_nm <= b.fade_start_torque_nm
        {
            errors.push(format!(
                "torque_bias.fade_end_torque_nm ({}) must exceed fade_start_torque_nm ({}) by at least twice \
                 the bias ({}): a steeper fade makes one motor's torque fall while the demand rises",
                b.fade_end_torque_nm, b.fade_start_torque_nm, b.bias_torque_nm
            ));
        }
        let per_motor_limit = self.drive.torque_constant_nm_per_a * self.drive.current_limit_a;
        if b.bias_torque_nm >= per_motor_limit {
            errors.push(format!(
                "torque_bias.bias_torque_nm ({}) must be below one motor's torque limit ({per_motor_limit} N m)",
                b.bias_torque_nm
            ));
        }
        let d = &self.differential_loop;
        positive("differential_loop.bandwidth_hz", d.bandwidth_hz, &mut errors);
        if let Some(k) = d.gain_override_nm_s_per_rad {
            non_negative("differential_loop.gain_override_nm_s_per_rad", k, &mut errors);
        }
        non_negative("differential_loop.max_torque_nm", d.max_torque_nm, &mut errors);
        into_result("azimuth controller", errors)
    }
}

/// Parameters of the elevation controller.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ElevationControllerParams {
    pub cascade: CascadeParams,
    pub drive: ElevationDriveModel,
    pub friction_feedforward: FrictionFeedforwardParams,
}

impl Default for ElevationControllerParams {
    /// Maximum slew 1 deg/s, profiled acceleration 0.5 deg/s^2.
    fn default() -> Self {
        Self {
            cascade: CascadeParams::for_axis(1.0, 0.5),
            drive: ElevationDriveModel::default(),
            friction_feedforward: FrictionFeedforwardParams::default(),
        }
    }
}

impl ElevationControllerParams {
    /// Checks every field; the message names each offending field and its constraint.
    pub fn validate(&self) -> Result<(), ParameterError> {
        let mut errors = Vec::new();
        self.cascade.validate(&mut errors);
        self.drive.validate(&mut errors);
        let f = &self.friction_feedforward;
        non_negative("friction_feedforward.raising_torque_nm", f.raising_torque_nm, &mut errors);
        non_negative("friction_feedforward.lowering_torque_nm", f.lowering_torque_nm, &mut errors);
        positive("friction_feedforward.velocity_band_deg_per_s", f.velocity_band_deg_per_s, &mut errors);
        into_result("elevation controller", errors)
    }
}

fn finite(name: &str, value: f64, errors: &mut Vec<String>) {
    if !value.is_finite() {
        errors.push(format!("{name} ({value}) must be finite"));
    }
}

fn positive(name: &str, value: f64, errors: &mut Vec<String>) {
    if !(value.is_finite() && value > 0.0) {
        errors.push(format!("{name} ({value}) must be finite and positive"));
    }
}

fn non_negative(name: &str, value: f64, errors: &mut Vec<String>) {
    if !(value.is_finite() && value >= 0.0) {
        errors.push(format!("{name} ({value}) must be finite and non-negative"));
    }
}

/// Why a controller's parameters are refused.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ParameterError {
    /// Fields that break their constraints; each problem names the field and the constraint
    /// it must meet (`differential_loop.bandwidth_hz (0) must be finite and positive`).
    #[error("invalid {controller} parameters: {}", .problems.join("; "))]
    Invalid { controller: &'static str, problems: Vec<String> },
}

fn into_result(controller: &'static str, problems: Vec<String>) -> Result<(), ParameterError> {
    if problems.is_empty() {
        Ok(())
    } else {
        Err(ParameterError::Invalid { controller, problems })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_are_valid() {
        AzimuthControllerParams::default().validate().unwrap();
        ElevationControllerParams::default().validate().unwrap();
    }

    #[test]
    fn validation_names_the_offending_field() {
        let mut p = AzimuthControllerParams::default();
        p.cascade.profiler.velocity_gain_per_s = 3.0 * p.cascade.profiler.approach_gain_per_s;
        p.torque_bias.fade_end_torque_nm = p.torque_bias.fade_start_torque_nm + p.torque_bias.bias_torque_nm;
        let message = p.validate().unwrap_err().to_string();
        assert!(message.contains("profiler.velocity_gain_per_s"), "{message}");
        assert!(message.contains("torque_bias.fade_end_torque_nm"), "{message}");

        let mut e = ElevationControllerParams::default();
        e.cascade.anti_limit_cycle.hold_release_error_deg = e.cascade.anti_limit_cycle.hold_entry_error_deg;
        let message = e.validate().unwrap_err().to_string();
        assert!(message.contains("anti_limit_cycle.hold_release_error_deg"), "{message}");
    }
}
