//! Parameter types shared by the azimuth and elevation plants, and their validation.
//!
//! Every field carries its unit in its name and doc comment so that it maps one-to-one onto a
//! named FMI variable. Effects that exist only for the later model-validation work (Stribeck
//! curve, asymmetry, cogging, position-periodic torques, torque-constant error, command delay)
//! have a neutral value that switches them off, and that value is the default.

use crate::error::PlantError;

/// One friction element acting on a body: Coulomb and static levels, optionally a Stribeck
/// curve between them and a direction asymmetry.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FrictionParams {
    /// Kinetic (Coulomb) friction torque while sliding, N m.
    pub coulomb_nm: f64,
    /// Breakaway (static) friction torque, N m: a body at rest stays at rest until the torque
    /// on it exceeds this. At least `coulomb_nm`.
    pub static_nm: f64,
    /// Stribeck velocity, rad/s of the body the friction acts on. When positive the sliding
    /// friction is `coulomb + (static - coulomb) exp(-(v/v_s)^2)`, falling smoothly from the
    /// breakaway level; 0 (the default) switches the curve off, so the friction drops from the
    /// static to the Coulomb level at breakaway.
    pub stribeck_velocity_rad_per_s: f64,
    /// Direction asymmetry `a`, in (-1, 1): both levels are `(1 + a)` times nominal for
    /// positive motion and `(1 - a)` times for negative motion. 0 (the default) is symmetric.
    pub asymmetry: f64,
}

impl FrictionParams {
    /// No friction at all.
    pub const NONE: FrictionParams =
        FrictionParams { coulomb_nm: 0.0, static_nm: 0.0, stribeck_velocity_rad_per_s: 0.0, asymmetry: 0.0 };

    /// Symmetric Coulomb and static friction without a Stribeck curve.
    pub fn coulomb_and_static(coulomb_nm: f64, static_nm: f64) -> Self {
        Self { coulomb_nm, static_nm, ..Self::NONE }
    }

    /// True if this element produces any friction torque.
    pub fn is_present(&self) -> bool {
        self.coulomb_nm > 0.0 || self.static_nm > 0.0
    }

    /// The same element referred through a gear: torque divided by `torque_ratio`, speeds
    /// multiplied by it (a torque `T` at the far side is `T / ratio` at the near side, and
    /// the near side turns `ratio` times faster).
    pub fn referred_through(&self, torque_ratio: f64) -> Self {
        Self {
            coulomb_nm: self.coulomb_nm / torque_ratio,
            static_nm: self.static_nm / torque_ratio,
            stribeck_velocity_rad_per_s: self.stribeck_velocity_rad_per_s * torque_ratio,
            asymmetry: self.asymmetry,
        }
    }

    pub(crate) fn validate(&self, name: &str, errors: &mut Vec<String>) {
        finite_non_negative(&format!("{name}.coulomb_nm"), self.coulomb_nm, errors);
        finite_non_negative(&format!("{name}.static_nm"), self.static_nm, errors);
        finite_non_negative(&format!("{name}.stribeck_velocity_rad_per_s"), self.stribeck_velocity_rad_per_s, errors);
        if self.static_nm < self.coulomb_nm {
            errors.push(format!(
                "{name}.static_nm ({}) must be at least {name}.coulomb_nm ({}): breakaway needs at least the sliding friction",
                self.static_nm, self.coulomb_nm
            ));
        }
        if !(self.asymmetry.is_finite() && self.asymmetry.abs() < 1.0) {
            errors.push(format!("{name}.asymmetry ({}) must lie strictly between -1 and 1", self.asymmetry));
        }
    }
}

/// A sinusoidal torque ripple that repeats with the motor angle (cogging).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CoggingParams {
    /// Amplitude of the cogging torque at the motor, N m. 0 (the default) is off.
    pub amplitude_nm: f64,
    /// Period in motor revolutions (for example 1/48 for 48 slots).
    pub period_motor_revolutions: f64,
    /// Phase at motor angle 0, deg.
    pub phase_deg: f64,
}

impl CoggingParams {
    pub const NONE: CoggingParams = CoggingParams { amplitude_nm: 0.0, period_motor_revolutions: 1.0, phase_deg: 0.0 };

    /// Cogging torque at a motor angle (rad), N m.
    pub fn torque_nm(&self, motor_angle_rad: f64) -> f64 {
        if self.amplitude_nm == 0.0 {
            return 0.0;
        }
        let cycles = motor_angle_rad / (std::f64::consts::TAU * self.period_motor_revolutions);
        self.amplitude_nm * (std::f64::consts::TAU * cycles.fract() + self.phase_deg.to_radians()).sin()
    }

    pub(crate) fn validate(&self, name: &str, errors: &mut Vec<String>) {
        finite(&format!("{name}.amplitude_nm"), self.amplitude_nm, errors);
        finite(&format!("{name}.phase_deg"), self.phase_deg, errors);
        finite_positive(&format!("{name}.period_motor_revolutions"), self.period_motor_revolutions, errors);
    }
}

/// A sinusoidal torque on the load that repeats with the axis angle: gear-tooth or bull-gear
/// run-out ripple, or (with a 360 deg period) the unbalance of a tilted azimuth axis.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PeriodicTorqueParams {
    /// Amplitude, N m about the axis. 0 (the default) is off.
    pub amplitude_nm: f64,
    /// Period in axis degrees.
    pub period_deg: f64,
    /// Phase at axis angle 0, deg.
    pub phase_deg: f64,
}

impl PeriodicTorqueParams {
    pub const NONE: PeriodicTorqueParams =
        PeriodicTorqueParams { amplitude_nm: 0.0, period_deg: 360.0, phase_deg: 0.0 };

    /// Torque at an axis angle (rad), N m.
    pub fn torque_nm(&self, axis_angle_rad: f64) -> f64 {
        if self.amplitude_nm == 0.0 {
            return 0.0;
        }
        let cycles = axis_angle_rad.to_degrees() / self.period_deg;
        self.amplitude_nm * (std::f64::consts::TAU * cycles.fract() + self.phase_deg.to_radians()).sin()
    }

    pub(crate) fn validate(&self, name: &str, errors: &mut Vec<String>) {
        finite(&format!("{name}.amplitude_nm"), self.amplitude_nm, errors);
        finite(&format!("{name}.phase_deg"), self.phase_deg, errors);
        finite_positive(&format!("{name}.period_deg"), self.period_deg, errors);
    }
}

/// One servo motor with its gearbox input stage and its current loop.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MotorParams {
    /// Rotor plus gearbox input-stage inertia `J_M`, kg m^2.
    pub inertia_kg_m2: f64,
    /// Viscous friction `B_M` of motor and gearbox, N m s/rad at the motor.
    pub viscous_friction_nm_s_per_rad: f64,
    /// Coulomb and static friction of motor and gearbox, N m at the motor.
    pub friction: FrictionParams,
    /// Torque constant `K_phi`, N m/A.
    pub torque_constant_nm_per_a: f64,
    /// Multiplier on the torque constant, for a torque-constant error. 1 (the default) is nominal.
    pub torque_constant_scale: f64,
    /// Current limit, A: the command is clamped to +/- this, so the torque saturates at
    /// `K_phi * limit`. `f64::INFINITY` switches saturation off.
    pub current_limit_a: f64,
    /// Closed-loop bandwidth of the current loop, modelled as a first-order lag, Hz.
    pub current_loop_bandwidth_hz: f64,
    /// Pure time delay on the current command, s. 0 (the default) is off.
    pub current_command_delay_s: f64,
    /// Cogging torque of the motor. Off by default.
    pub cogging: CoggingParams,
    /// Presliding (bristle) stiffness of the motor's friction, N m/rad at the motor: while the
    /// motor sticks it is tied to a friction anchor through this spring and the damper below
    /// (an elasto-plastic, single Maxwell-slip element), and it slips when the spring torque
    /// reaches the breakaway level. 0 (the default) is a rigid stick.
    pub presliding_stiffness_nm_per_rad: f64,
    /// Damping of that bristle spring, N m s/rad at the motor (used only with a stiffness).
    pub presliding_damping_nm_s_per_rad: f64,
}

impl MotorParams {
    /// Longest command delay accepted; it bounds the memory of the delay line.
    pub const MAX_COMMAND_DELAY_S: f64 = 1.0;

    /// The torque actually produced per ampere, `K_phi` times its scale, N m/A.
    pub fn effective_torque_constant(&self) -> f64 {
        self.torque_constant_nm_per_a * self.torque_constant_scale
    }

    /// The same motor with everything the paper's linear Eq. 1 model lacks switched off:
    /// no Coulomb or static friction, no saturation, no delay, no cogging, nominal `K_phi`.
    pub fn linearised(&self) -> Self {
        Self {
            friction: FrictionParams::NONE,
            torque_constant_scale: 1.0,
            current_limit_a: f64::INFINITY,
            current_command_delay_s: 0.0,
            cogging: CoggingParams::NONE,
            presliding_stiffness_nm_per_rad: 0.0,
            presliding_damping_nm_s_per_rad: 0.0,
            ..*self
        }
    }

    pub(crate) fn validate(&self, name: &str, errors: &mut Vec<String>) {
        finite_positive(&format!("{name}.inertia_kg_m2"), self.inertia_kg_m2, errors);
        finite_non_negative(
            &format!("{name}.viscous_friction_nm_s_per_rad"),
            self.viscous_friction_nm_s_per_rad,
            errors,
        );
        self.friction.validate(&format!("{name}.friction"), errors);
        finite_positive(&format!("{name}.torque_constant_nm_per_a"), self.torque_constant_nm_per_a, errors);
        finite_positive(&format!("{name}.torque_constant_scale"), self.torque_constant_scale, errors);
        if self.current_limit_a.is_nan() || self.current_limit_a <= 0.0 {
            errors.push(format!(
                "{name}.current_limit_a ({}) must be positive (INFINITY for no limit)",
                self.current_limit_a
            ));
        }
        finite_positive(&format!("{name}.current_loop_bandwidth_hz"), self.current_loop_bandwidth_hz, errors);
        if !(self.current_command_delay_s >= 0.0 && self.current_command_delay_s <= Self::MAX_COMMAND_DELAY_S) {
            errors.push(format!(
                "{name}.current_command_delay_s ({}) must lie in [0, {}] s",
                self.current_command_delay_s,
                Self::MAX_COMMAND_DELAY_S
            ));
        }
        self.cogging.validate(&format!("{name}.cogging"), errors);
        finite_non_negative(
            &format!("{name}.presliding_stiffness_nm_per_rad"),
            self.presliding_stiffness_nm_per_rad,
            errors,
        );
        finite_non_negative(
            &format!("{name}.presliding_damping_nm_s_per_rad"),
            self.presliding_damping_nm_s_per_rad,
            errors,
        );
    }
}

/// Settings of the numerical scheme. They change accuracy and speed, never the physics.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NumericsParams {
    /// Cell size of the elevation grid on which angle-dependent parameters (azimuth load
    /// inertia; elevation stiffness, ratio and reflected inertia) are frozen at the cell
    /// centre, deg.
    pub parameter_grid_cell_deg: f64,
    /// Longest internal sub-step over which torques that are not piecewise linear in the state
    /// (Stribeck curve, cogging, position-periodic and unbalance torques) are held constant, s.
    /// Used only when one of those effects is on.
    pub nonlinear_substep_s: f64,
    /// Time resolution to which a mode switch (stick, slip, contact, separation) is localised
    /// by dyadic subdivision of the step, s.
    pub event_time_resolution_s: f64,
    /// Longest interval at whose end alone the mode is checked, s. A longer communication
    /// step is cut into equal pieces no longer than this, so that a speed that reverses and
    /// comes back within a long step is not missed. The default, 1 ms, is not below every
    /// event-relevant time of the default drives (current loop 1.6 ms, the spring's relaxation
    /// in the backlash gap 0.7 ms, stick-slip of a motor floating in its backlash sometimes
    /// shorter): where the pinions cross the backlash often, 0.1 ms is more accurate
    /// (docs/plant-model.md, section 8.4).
    pub event_check_interval_s: f64,
    /// Number of discretisation ladders (one per mode, grid cell and piece length, each with
    /// all dyadic fractions of the length) kept per cache generation; at most twice this many
    /// are held, so memory stays bounded whatever step sizes a master uses. A ladder holds
    /// only the full-length discretisation (1.2 kB for azimuth) until an event needs the
    /// fractions (then about 13 kB for a 1 ms step).
    pub cache_capacity: usize,
}

impl Default for NumericsParams {
    fn default() -> Self {
        Self {
            parameter_grid_cell_deg: 0.25,
            nonlinear_substep_s: 1e-4,
            event_time_resolution_s: 1e-6,
            event_check_interval_s: 1e-3,
            cache_capacity: 64,
        }
    }
}

impl NumericsParams {
    pub(crate) fn validate(&self, errors: &mut Vec<String>) {
        if !(self.parameter_grid_cell_deg > 0.0 && self.parameter_grid_cell_deg <= 10.0) {
            errors.push(format!(
                "numerics.parameter_grid_cell_deg ({}) must lie in (0, 10] deg",
                self.parameter_grid_cell_deg
            ));
        }
        if !(self.nonlinear_substep_s >= 1e-7 && self.nonlinear_substep_s <= 1.0) {
            errors.push(format!("numerics.nonlinear_substep_s ({}) must lie in [1e-7, 1] s", self.nonlinear_substep_s));
        }
        if !(self.event_time_resolution_s >= 1e-9 && self.event_time_resolution_s <= 1e-3) {
            errors.push(format!(
                "numerics.event_time_resolution_s ({}) must lie in [1e-9, 1e-3] s",
                self.event_time_resolution_s
            ));
        }
        if !(self.event_check_interval_s >= self.event_time_resolution_s && self.event_check_interval_s <= 1.0) {
            errors.push(format!(
                "numerics.event_check_interval_s ({}) must lie between the event time resolution and 1 s",
                self.event_check_interval_s
            ));
        }
        if self.cache_capacity < 8 {
            errors.push(format!("numerics.cache_capacity ({}) must be at least 8", self.cache_capacity));
        }
    }
}

pub(crate) fn finite(name: &str, value: f64, errors: &mut Vec<String>) {
    if !value.is_finite() {
        errors.push(format!("{name} ({value}) must be finite"));
    }
}

pub(crate) fn finite_positive(name: &str, value: f64, errors: &mut Vec<String>) {
    if !(value.is_finite() && value > 0.0) {
        errors.push(format!("{name} ({value}) must be finite and positive"));
    }
}

pub(crate) fn finite_non_negative(name: &str, value: f64, errors: &mut Vec<String>) {
    if !(value.is_finite() && value >= 0.0) {
        errors.push(format!("{name} ({value}) must be finite and non-negative"));
    }
}

/// Turns collected validation messages into the `Result` the constructors return.
pub(crate) fn into_result(axis: &'static str, problems: Vec<String>) -> Result<(), PlantError> {
    if problems.is_empty() {
        Ok(())
    } else {
        Err(PlantError::InvalidParameters { axis, problems })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cogging_repeats_with_its_period_in_motor_revolutions() {
        let c = CoggingParams { amplitude_nm: 0.05, period_motor_revolutions: 1.0 / 48.0, phase_deg: 30.0 };
        let period_rad = std::f64::consts::TAU / 48.0;
        for angle in [0.0, 0.1, 3.0, -7.0, 1234.5] {
            let a = c.torque_nm(angle);
            let b = c.torque_nm(angle + 5.0 * period_rad);
            assert!((a - b).abs() < 1e-9, "angle {angle}: {a} vs {b}");
        }
        assert!((c.torque_nm(0.0) - 0.05 * 30f64.to_radians().sin()).abs() < 1e-15);
        assert!((c.torque_nm(period_rad / 4.0) - 0.05 * 120f64.to_radians().sin()).abs() < 1e-12);
    }

    #[test]
    fn periodic_axis_torque_repeats_with_its_period_in_degrees() {
        let p = PeriodicTorqueParams { amplitude_nm: 200.0, period_deg: 7.5, phase_deg: 0.0 };
        let quarter = (7.5f64 / 4.0).to_radians();
        assert!((p.torque_nm(quarter) - 200.0).abs() < 1e-9);
        assert!((p.torque_nm(1.0) - p.torque_nm(1.0 + 2.0 * 7.5f64.to_radians())).abs() < 1e-9);
    }

    #[test]
    fn friction_validation_names_the_offending_field() {
        let mut errors = Vec::new();
        FrictionParams { coulomb_nm: 0.5, static_nm: 0.4, ..FrictionParams::NONE }
            .validate("motor.friction", &mut errors);
        assert_eq!(errors.len(), 1);
        assert!(errors[0].contains("motor.friction.static_nm"), "{}", errors[0]);
    }

    #[test]
    fn friction_referred_through_a_gear_scales_torque_down_and_speed_up() {
        let f = FrictionParams { coulomb_nm: 8.0, static_nm: 10.0, stribeck_velocity_rad_per_s: 0.5, asymmetry: 0.1 };
        let r = f.referred_through(28.0);
        assert_eq!(r.coulomb_nm, 8.0 / 28.0);
        assert_eq!(r.static_nm, 10.0 / 28.0);
        assert_eq!(r.stribeck_velocity_rad_per_s, 14.0);
        assert_eq!(r.asymmetry, 0.1);
    }
}
