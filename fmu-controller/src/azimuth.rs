//! The azimuth controller: the shared cascade on the mean of the two motor speeds, then the
//! torque bias and the superimposed differential speed controller that turn the total torque
//! into two current commands.

use fmu_runtime::state::StateError;
use serde::{Deserialize, Serialize};

use crate::cascade::{Cascade, CascadeInput, CascadeState, ControlMode};
use crate::linear::{PositionLoopModel, VelocityLoopModel};
use crate::params::{AzimuthControllerParams, ParameterError, SamplingParams};
use crate::status::AxisStatus;
use crate::timing::SampledController;
use crate::torque_bias::{differential_gain, differential_torque, split_torque};
use crate::velocity_loop::VelocityGains;

/// Measurements and commands of one azimuth sample.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct AzimuthInputs {
    /// What the controller does with the commands below.
    pub mode: ControlMode,
    /// Position command (the pointing model's output), deg.
    pub position_command_deg: f64,
    /// Command velocity, the derivative of the pointing table, deg/s; the velocity
    /// feedforward while tracking. 0 for a fixed target.
    pub command_velocity_deg_per_s: f64,
    /// Axis velocity command in velocity mode, deg/s.
    pub velocity_mode_command_deg_per_s: f64,
    /// Current of each motor in open-loop current mode, A (both motors get it; the torque bias
    /// and differential loop are added when enabled).
    pub open_loop_current_a: f64,
    /// Axis encoder position, deg.
    pub encoder_position_deg: f64,
    /// Speeds of motor 1 and motor 2, rad/s at the motor, positive towards positive azimuth.
    pub motor_speed_rad_per_s: [f64; 2],
}

/// What one azimuth sample produces.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct AzimuthOutputs {
    /// Current commands of motor 1 and motor 2, A, limited to the current limit.
    pub current_command_a: [f64; 2],
    /// Bias torque `b(T)` added to motor 1 and taken from motor 2, N m.
    pub bias_torque_nm: f64,
    /// Differential-loop torque added to motor 1 and taken from motor 2, N m.
    pub differential_torque_nm: f64,
    /// Reference, errors and flags.
    pub status: AxisStatus,
}

/// The gains the azimuth controller runs with.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AzimuthGains {
    pub velocity: VelocityGains,
    /// Position loop proportional gain, 1/s.
    pub position_proportional_per_s: f64,
    /// Position loop integral gain, 1/s^2 (0 when off).
    pub position_integral_per_s2: f64,
    /// Differential speed controller gain, N m per rad/s.
    pub differential_nm_s_per_rad: f64,
}

/// The azimuth axis controller. See the module documentation.
#[derive(Debug, Clone, PartialEq)]
pub struct AzimuthController {
    params: AzimuthControllerParams,
    gains: AzimuthGains,
    cascade: Cascade,
}

impl AzimuthController {
    /// Validates the parameters and designs the gains.
    pub fn new(params: AzimuthControllerParams) -> Result<Self, ParameterError> {
        params.validate()?;
        let v = &params.cascade.velocity_loop;
        let velocity = VelocityGains::design(
            v.crossover_hz,
            v.integral_corner_ratio,
            params.drive.total_inertia_at_motor_kg_m2(),
            v.proportional_gain_override_nm_s_per_rad,
            v.integral_corner_override_hz,
        );
        let cascade = Cascade::new(&params.cascade, params.drive.torque_limit_nm());
        let gains = AzimuthGains {
            velocity,
            position_proportional_per_s: cascade.position_loop().proportional_gain(),
            position_integral_per_s2: cascade.position_loop().integral_gain(),
            differential_nm_s_per_rad: differential_gain(&params.differential_loop, params.drive.motor_inertia_kg_m2),
        };
        Ok(Self { params, gains, cascade })
    }

    pub fn params(&self) -> &AzimuthControllerParams {
        &self.params
    }

    pub fn gains(&self) -> &AzimuthGains {
        &self.gains
    }

    /// Forgets all history: the next sample starts as the first one did.
    pub fn reset(&mut self) {
        self.cascade = Cascade::new(&self.params.cascade, self.params.drive.torque_limit_nm());
    }

    /// Executes one sample with the measurements taken at its instant. The currents are meant
    /// to be applied `delay_samples` samples later (see [`crate::timing`]).
    pub fn sample(&mut self, inputs: &AzimuthInputs) -> AzimuthOutputs {
        let drive = &self.params.drive;
        let speeds = inputs.motor_speed_rad_per_s;
        let out = self.cascade.sample(
            &CascadeInput {
                mode: inputs.mode,
                command_position: inputs.position_command_deg.to_radians(),
                command_velocity: inputs.command_velocity_deg_per_s.to_radians(),
                velocity_mode_command: inputs.velocity_mode_command_deg_per_s.to_radians(),
                open_loop_torque: 2.0 * drive.torque_constant_nm_per_a * inputs.open_loop_current_a,
                axis_position: inputs.encoder_position_deg.to_radians(),
                motor_speed: 0.5 * (speeds[0] + speeds[1]),
                gear_ratio: drive.gear_ratio,
                total_inertia: drive.total_inertia_at_motor_kg_m2(),
                gains: self.gains.velocity,
            },
            |_| 0.0,
        );
        let [t1, t2] = split_torque(out.torque, &self.params.torque_bias);
        let bias = t1 - 0.5 * out.torque;
        let delta = differential_torque(speeds, self.gains.differential_nm_s_per_rad, &self.params.differential_loop);
        let limit = drive.current_limit_a;
        let current = |torque: f64| (torque / drive.torque_constant_nm_per_a).clamp(-limit, limit);
        AzimuthOutputs {
            current_command_a: [current(t1 + delta), current(t2 - delta)],
            bias_torque_nm: bias,
            differential_torque_nm: delta,
            status: AxisStatus::new(&out, inputs.position_command_deg, inputs.encoder_position_deg),
        }
    }

    /// The linear model of the velocity loop with the gains, filters, sample time and delay in
    /// use (for the closed-loop Bode plots).
    pub fn velocity_loop_model(&self) -> VelocityLoopModel {
        VelocityLoopModel::new(&self.params.cascade, self.gains.velocity, self.cascade.speed_filter().clone())
    }

    /// The linear model of the position loop around the velocity loop.
    pub fn position_loop_model(&self) -> PositionLoopModel {
        PositionLoopModel {
            velocity: self.velocity_loop_model(),
            proportional_gain_per_s: self.gains.position_proportional_per_s,
            integral_gain_per_s2: self.gains.position_integral_per_s2,
            gear_ratio: self.params.drive.gear_ratio,
            total_inertia_kg_m2: self.params.drive.total_inertia_at_motor_kg_m2(),
            velocity_feedforward: self.params.cascade.feedforward.velocity_enabled,
            acceleration_feedforward: self.params.cascade.feedforward.acceleration_enabled,
        }
    }

    /// Everything that determines the future outputs (not the parameters).
    pub fn save_state(&self) -> CascadeState {
        self.cascade.saved_state()
    }

    /// Restores what [`save_state`](Self::save_state) returned for a controller with the same
    /// parameters. On error the controller is unchanged.
    pub fn load_state(&mut self, state: CascadeState) -> Result<(), StateError> {
        self.cascade.restore(state)
    }
}

impl SampledController for AzimuthController {
    type Inputs = AzimuthInputs;
    type Outputs = AzimuthOutputs;

    fn sampling(&self) -> SamplingParams {
        self.params.cascade.sampling
    }

    fn sample(&mut self, inputs: &AzimuthInputs) -> AzimuthOutputs {
        AzimuthController::sample(self, inputs)
    }

    fn idle_outputs(&self) -> AzimuthOutputs {
        AzimuthOutputs::default()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn inputs(mode: ControlMode) -> AzimuthInputs {
        AzimuthInputs { mode, position_command_deg: 10.0, encoder_position_deg: 10.0, ..AzimuthInputs::default() }
    }

    #[test]
    fn motor_currents_carry_the_total_torque_and_the_bias() {
        let mut c = AzimuthController::new(AzimuthControllerParams::default()).unwrap();
        let kt = c.params().drive.torque_constant_nm_per_a;
        for current in [0.0, 0.5, 2.0, 6.0] {
            let out = c.sample(&AzimuthInputs { open_loop_current_a: current, ..inputs(ControlMode::OpenLoopCurrent) });
            let total = out.status.torque_command_nm;
            assert!((total - 2.0 * kt * current).abs() < 1e-12);
            let [i1, i2] = out.current_command_a;
            assert!(((i1 + i2) * kt - total).abs() < 1e-12, "currents {i1}, {i2} for {total} N m");
            assert!(((i1 - i2) * kt / 2.0 - out.bias_torque_nm).abs() < 1e-12);
        }
        // At rest the motors oppose each other with the full bias.
        let out = c.sample(&AzimuthInputs { open_loop_current_a: 0.0, ..inputs(ControlMode::OpenLoopCurrent) });
        let bias = c.params().torque_bias.bias_torque_nm;
        assert_eq!(out.current_command_a, [bias / kt, -bias / kt]);
    }

    #[test]
    fn currents_never_exceed_the_limit() {
        let mut c = AzimuthController::new(AzimuthControllerParams::default()).unwrap();
        let limit = c.params().drive.current_limit_a;
        let out = c.sample(&AzimuthInputs { open_loop_current_a: 100.0, ..inputs(ControlMode::OpenLoopCurrent) });
        assert!(out.current_command_a.iter().all(|i| i.abs() <= limit));
        assert!(out.status.torque_limited);
        // A huge speed error in velocity mode saturates the velocity loop, not beyond.
        let out = c.sample(&AzimuthInputs { motor_speed_rad_per_s: [-500.0, -500.0], ..inputs(ControlMode::Velocity) });
        assert!(out.current_command_a.iter().all(|i| i.abs() <= limit));
    }

    #[test]
    fn designed_gains_follow_the_drive_model_and_overrides_win() {
        let c = AzimuthController::new(AzimuthControllerParams::default()).unwrap();
        let j = c.params().drive.total_inertia_at_motor_kg_m2();
        let g = c.gains();
        assert!((g.velocity.proportional_nm_s_per_rad - std::f64::consts::TAU * 10.0 * j).abs() < 1e-12);
        assert!((g.position_proportional_per_s - std::f64::consts::TAU * 0.75).abs() < 1e-12);
        assert_eq!(g.position_integral_per_s2, 0.0);
        let mut p = AzimuthControllerParams::default();
        p.cascade.velocity_loop.proportional_gain_override_nm_s_per_rad = Some(1.0);
        p.cascade.position_loop.proportional_gain_override_per_s = Some(3.0);
        p.differential_loop.gain_override_nm_s_per_rad = Some(0.25);
        let g = *AzimuthController::new(p).unwrap().gains();
        assert_eq!(
            (g.velocity.proportional_nm_s_per_rad, g.position_proportional_per_s, g.differential_nm_s_per_rad),
            (1.0, 3.0, 0.25)
        );
    }

    #[test]
    fn reset_makes_the_controller_start_over() {
        let mut c = AzimuthController::new(AzimuthControllerParams::default()).unwrap();
        let fresh = c.clone();
        for _ in 0..100 {
            c.sample(&AzimuthInputs { position_command_deg: 11.0, ..inputs(ControlMode::Position) });
        }
        assert_ne!(c, fresh);
        c.reset();
        assert_eq!(c, fresh);
    }

    #[test]
    fn a_state_with_other_speed_filters_is_rejected_and_changes_nothing() {
        let mut c = AzimuthController::new(AzimuthControllerParams::default()).unwrap();
        let before = c.clone();
        let mut state = c.save_state();
        state.last_torque = 1.0;
        state.speed_filter.notch = if state.speed_filter.notch.is_some() { None } else { Some([0.0; 2]) };
        assert!(c.load_state(state).is_err());
        assert_eq!(c, before);
    }
}
