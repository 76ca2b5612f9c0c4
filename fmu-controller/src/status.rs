//! The diagnostic outputs both axes share: the reference, the errors and the state of the
//! profiler, limits and anti-limit-cycle hold, in the ACU's units (deg) for logging and for
//! the lead's requirement checks.

use serde::{Deserialize, Serialize};

use crate::cascade::CascadeOutput;

/// Internal signals of one sample, axis units.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct AxisStatus {
    /// Reference position the position loop follows (the profile during a step, the command
    /// while tracking; the measured position in velocity and open-loop modes), deg.
    pub reference_position_deg: f64,
    /// Reference velocity (the velocity feedforward), deg/s.
    pub reference_velocity_deg_per_s: f64,
    /// Reference acceleration (the acceleration feedforward), deg/s^2.
    pub reference_acceleration_deg_per_s2: f64,
    /// Reference position minus encoder position, deg.
    pub position_error_deg: f64,
    /// Position command minus encoder position (the pointing error the requirements are about
    /// when the command is the source direction), deg.
    pub command_error_deg: f64,
    /// Velocity reference handed to the velocity loop, deg/s of the axis.
    pub velocity_reference_deg_per_s: f64,
    /// Measured axis speed (motor speed over the gear ratio), deg/s.
    pub measured_velocity_deg_per_s: f64,
    /// Total torque command of the velocity loop (sum over motors, feedforward included),
    /// N m at the motor.
    pub torque_command_nm: f64,
    /// True while the profiler executes a step.
    pub profiling: bool,
    /// True when the torque limit cut the velocity loop's command.
    pub torque_limited: bool,
    /// True while the anti-limit-cycle hold freezes the integrators.
    pub holding: bool,
}

impl AxisStatus {
    pub(crate) fn new(out: &CascadeOutput, command_position_deg: f64, encoder_position_deg: f64) -> Self {
        let reference_position_deg = out.reference.position.to_degrees();
        Self {
            reference_position_deg,
            reference_velocity_deg_per_s: out.reference.velocity.to_degrees(),
            reference_acceleration_deg_per_s2: out.reference.acceleration.to_degrees(),
            position_error_deg: reference_position_deg - encoder_position_deg,
            command_error_deg: command_position_deg - encoder_position_deg,
            velocity_reference_deg_per_s: out.velocity_reference.to_degrees(),
            measured_velocity_deg_per_s: out.measured_axis_velocity.to_degrees(),
            torque_command_nm: out.torque,
            profiling: out.reference.stepping,
            torque_limited: out.torque_limited,
            holding: out.holding,
        }
    }
}
