//! The elevation controller: the shared cascade on the single motor, with gains and
//! feedforward that follow the jackscrew's angle-dependent transmission ratio, and the
//! direction-dependent friction-torque feedforward.
//!
//! The ratio `N(el)` changes by about 30 % over the travel, and with it the inertia reflected
//! to the motor. The controller evaluates both at the measured elevation every sample, so the
//! velocity loop keeps its designed crossover and the velocity reference is converted to motor
//! speed with the right ratio (a constant ratio would leave a tracking error proportional to
//! the ratio's error times the tracking rate).

use fmu_runtime::state::StateError;
use serde::{Deserialize, Serialize};

use crate::cascade::{Cascade, CascadeInput, CascadeState, ControlMode};
use crate::friction_feedforward::friction_feedforward;
use crate::linear::{PositionLoopModel, VelocityLoopModel};
use crate::params::{ElevationControllerParams, ParameterError, SamplingParams};
use crate::status::AxisStatus;
use crate::timing::SampledController;
use crate::velocity_loop::VelocityGains;

/// Measurements and commands of one elevation sample.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ElevationInputs {
    /// What the controller does with the commands below.
    pub mode: ControlMode,
    /// Position command, deg.
    pub position_command_deg: f64,
    /// Command velocity, the derivative of the pointing table, deg/s.
    pub command_velocity_deg_per_s: f64,
    /// Axis velocity command in velocity mode, deg/s.
    pub velocity_mode_command_deg_per_s: f64,
    /// Motor current in open-loop current mode, A.
    pub open_loop_current_a: f64,
    /// Axis encoder position, deg.
    pub encoder_position_deg: f64,
    /// Motor speed, rad/s, positive raising the dish.
    pub motor_speed_rad_per_s: f64,
}

/// What one elevation sample produces.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct ElevationOutputs {
    /// Motor current command, A, limited to the current limit.
    pub current_command_a: f64,
    /// Friction feedforward torque included in the torque command, N m at the motor.
    pub friction_feedforward_nm: f64,
    /// Transmission ratio used at this sample, motor rad per axis rad.
    pub gear_ratio: f64,
    /// Reference, errors and flags.
    pub status: AxisStatus,
}

/// The elevation axis controller. See the module documentation.
#[derive(Debug, Clone)]
pub struct ElevationController {
    params: ElevationControllerParams,
    cascade: Cascade,
    /// Ratio, inertia and gains at the last encoder reading (bit pattern): the geometry costs
    /// trigonometry, and the quantised encoder repeats its reading from sample to sample.
    scheduled: Option<(u64, f64, f64, VelocityGains)>,
}

/// Two controllers are equal when their parameters and states are; the schedule cache is a
/// pure function of the parameters and does not count.
impl PartialEq for ElevationController {
    fn eq(&self, other: &Self) -> bool {
        self.params == other.params && self.cascade == other.cascade
    }
}

impl ElevationController {
    /// Validates the parameters.
    pub fn new(params: ElevationControllerParams) -> Result<Self, ParameterError> {
        params.validate()?;
        let cascade = Cascade::new(&params.cascade, params.drive.torque_limit_nm());
        Ok(Self { params, cascade, scheduled: None })
    }

    pub fn params(&self) -> &ElevationControllerParams {
        &self.params
    }

    /// The velocity-loop gains at an elevation (deg): designed on the inertia there.
    pub fn velocity_gains_at(&self, elevation_deg: f64) -> VelocityGains {
        let v = &self.params.cascade.velocity_loop;
        VelocityGains::design(
            v.crossover_hz,
            v.integral_corner_ratio,
            self.params.drive.total_inertia_at_motor_kg_m2(elevation_deg),
            v.proportional_gain_override_nm_s_per_rad,
            v.integral_corner_override_hz,
        )
    }

    /// Position loop proportional gain, 1/s.
    pub fn position_gain_per_s(&self) -> f64 {
        self.cascade.position_loop().proportional_gain()
    }

    /// Forgets all history: the next sample starts as the first one did.
    pub fn reset(&mut self) {
        self.cascade = Cascade::new(&self.params.cascade, self.params.drive.torque_limit_nm());
    }

    /// Executes one sample with the measurements taken at its instant.
    pub fn sample(&mut self, inputs: &ElevationInputs) -> ElevationOutputs {
        let elevation = inputs.encoder_position_deg;
        let (gear_ratio, total_inertia, gains) = match self.scheduled {
            Some((bits, n, j, g)) if bits == elevation.to_bits() => (n, j, g),
            _ => {
                let drive = &self.params.drive;
                let scheduled = (
                    drive.gear_ratio_at(elevation),
                    drive.total_inertia_at_motor_kg_m2(elevation),
                    self.velocity_gains_at(elevation),
                );
                self.scheduled = Some((elevation.to_bits(), scheduled.0, scheduled.1, scheduled.2));
                scheduled
            }
        };
        let drive = &self.params.drive;
        let friction = &self.params.friction_feedforward;
        let out = self.cascade.sample(
            &CascadeInput {
                mode: inputs.mode,
                command_position: inputs.position_command_deg.to_radians(),
                command_velocity: inputs.command_velocity_deg_per_s.to_radians(),
                velocity_mode_command: inputs.velocity_mode_command_deg_per_s.to_radians(),
                open_loop_torque: drive.torque_constant_nm_per_a * inputs.open_loop_current_a,
                axis_position: elevation.to_radians(),
                motor_speed: inputs.motor_speed_rad_per_s,
                gear_ratio,
                total_inertia,
                gains,
            },
            |velocity| friction_feedforward(velocity, friction),
        );
        let limit = drive.current_limit_a;
        ElevationOutputs {
            current_command_a: (out.torque / drive.torque_constant_nm_per_a).clamp(-limit, limit),
            friction_feedforward_nm: out.extra_feedforward,
            gear_ratio,
            status: AxisStatus::new(&out, inputs.position_command_deg, inputs.encoder_position_deg),
        }
    }

    /// The linear model of the velocity loop at an elevation (deg).
    pub fn velocity_loop_model_at(&self, elevation_deg: f64) -> VelocityLoopModel {
        VelocityLoopModel::new(
            &self.params.cascade,
            self.velocity_gains_at(elevation_deg),
            self.cascade.speed_filter().clone(),
        )
    }

    /// The linear model of the position loop at an elevation (deg).
    pub fn position_loop_model_at(&self, elevation_deg: f64) -> PositionLoopModel {
        PositionLoopModel {
            velocity: self.velocity_loop_model_at(elevation_deg),
            proportional_gain_per_s: self.cascade.position_loop().proportional_gain(),
            integral_gain_per_s2: self.cascade.position_loop().integral_gain(),
            gear_ratio: self.params.drive.gear_ratio_at(elevation_deg),
            total_inertia_kg_m2: self.params.drive.total_inertia_at_motor_kg_m2(elevation_deg),
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

impl SampledController for ElevationController {
    type Inputs = ElevationInputs;
    type Outputs = ElevationOutputs;

    fn sampling(&self) -> SamplingParams {
        self.params.cascade.sampling
    }

    fn sample(&mut self, inputs: &ElevationInputs) -> ElevationOutputs {
        ElevationController::sample(self, inputs)
    }

    fn idle_outputs(&self) -> ElevationOutputs {
        ElevationOutputs { gear_ratio: self.params.drive.gear_ratio_at(90.0), ..ElevationOutputs::default() }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn velocity_gain_follows_the_inertia_reflected_through_the_angle_dependent_ratio() {
        let c = ElevationController::new(ElevationControllerParams::default()).unwrap();
        let drive = &c.params().drive;
        for el in [15.0, 45.0, 88.0] {
            let expected = std::f64::consts::TAU * 10.0 * drive.total_inertia_at_motor_kg_m2(el);
            assert!((c.velocity_gains_at(el).proportional_nm_s_per_rad - expected).abs() < 1e-12);
        }
        let (low, high) = (c.velocity_gains_at(45.0), c.velocity_gains_at(88.0));
        assert!(high.proportional_nm_s_per_rad > 1.2 * low.proportional_nm_s_per_rad);
    }

    #[test]
    fn velocity_reference_is_converted_with_the_ratio_at_the_measured_angle() {
        // In velocity mode at rest, after a first sample at zero command (which leaves the
        // integral at zero), a command v gives the speed error N(el) v, so the proportional
        // torque Kv N(el) v reveals the ratio in use.
        let mut params = ElevationControllerParams::default();
        params.cascade.feedforward.acceleration_enabled = false;
        params.cascade.velocity_loop.velocity_mode_acceleration_limited = false;
        params.friction_feedforward.enabled = false;
        for el in [20.0, 80.0] {
            let mut c = ElevationController::new(params).unwrap();
            let v = 0.01;
            let at_rest =
                ElevationInputs { mode: ControlMode::Velocity, encoder_position_deg: el, ..ElevationInputs::default() };
            assert_eq!(c.sample(&at_rest).status.torque_command_nm, 0.0);
            let out = c.sample(&ElevationInputs { velocity_mode_command_deg_per_s: v, ..at_rest });
            let expected = c.velocity_gains_at(el).proportional_nm_s_per_rad
                * c.params().drive.gear_ratio_at(el)
                * f64::to_radians(v);
            assert!((out.status.torque_command_nm - expected).abs() < 1e-12 * expected.abs(), "el {el}");
            assert_eq!(out.gear_ratio, c.params().drive.gear_ratio_at(el));
        }
    }

    #[test]
    fn friction_feedforward_follows_the_reference_direction() {
        let mut c = ElevationController::new(ElevationControllerParams::default()).unwrap();
        let ff = c.params().friction_feedforward;
        let track = |c: &mut ElevationController, rate: f64| {
            let mut out = ElevationOutputs::default();
            for k in 0..10 {
                out = c.sample(&ElevationInputs {
                    position_command_deg: 45.0 + rate * k as f64 * 1e-3,
                    command_velocity_deg_per_s: rate,
                    encoder_position_deg: 45.0,
                    ..ElevationInputs::default()
                });
            }
            out.friction_feedforward_nm
        };
        assert_eq!(track(&mut c, 0.004), ff.raising_torque_nm);
        c.reset();
        assert_eq!(track(&mut c, -0.004), -ff.lowering_torque_nm);
        c.reset();
        assert_eq!(track(&mut c, 0.0), 0.0);
    }

    #[test]
    fn saved_state_replays_the_outputs_bitwise() {
        let mut a = ElevationController::new(ElevationControllerParams::default()).unwrap();
        let input = |k: usize| ElevationInputs {
            position_command_deg: 50.0,
            encoder_position_deg: 45.0 + 1e-4 * k as f64,
            motor_speed_rad_per_s: 2.0 * (k as f64 * 0.01).sin(),
            ..ElevationInputs::default()
        };
        for k in 0..500 {
            a.sample(&input(k));
        }
        let mut b = ElevationController::new(ElevationControllerParams::default()).unwrap();
        b.load_state(a.save_state()).unwrap();
        assert_eq!(a, b);
        for k in 500..2000 {
            let (oa, ob) = (a.sample(&input(k)), b.sample(&input(k)));
            assert_eq!(oa.current_command_a.to_bits(), ob.current_command_a.to_bits());
            assert_eq!(oa.status, ob.status);
        }
    }
}
