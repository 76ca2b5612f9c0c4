//! The cascade both axes share (Fig. 3 without the axis-specific parts): command profiler,
//! position loop, velocity and acceleration feedforward, velocity loop, and the switching
//! between position, velocity and open-loop current mode.
//!
//! Mode changes are bumpless: entering position mode restarts the profiler from the measured
//! position and speed (so a running axis is braked along a profile, not stopped by a jump),
//! the velocity reference's rate limiter continues from the last velocity reference (or from
//! the measured speed after open-loop mode), and leaving open-loop mode sets the velocity
//! integrator so that the torque carries on from the last open-loop torque.

use fmu_runtime::state::StateError;
use serde::{Deserialize, Serialize};

use crate::filters::{SpeedFilter, SpeedFilterState};
use crate::params::CascadeParams;
use crate::position_loop::{PositionLoop, PositionLoopState};
use crate::profiler::{CommandProfiler, ProfilerState, Reference};
use crate::velocity_loop::{VelocityGains, VelocityLoop};

/// What the controller does with its commands.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub enum ControlMode {
    /// Position control of Fig. 3: profiler, position loop, velocity loop (the default).
    #[default]
    Position,
    /// The velocity loop follows the velocity-mode command directly (position loop and
    /// profiler idle), for closed-loop identification of the velocity loop.
    Velocity,
    /// The velocity controller is off and the open-loop current command goes to the drives,
    /// as in the paper's open-loop identification.
    OpenLoopCurrent,
}

impl ControlMode {
    /// The mode's number for an FMI enumeration: 1 position, 2 velocity, 3 open-loop current.
    pub fn index(self) -> i32 {
        match self {
            ControlMode::Position => 1,
            ControlMode::Velocity => 2,
            ControlMode::OpenLoopCurrent => 3,
        }
    }

    /// The mode with the given FMI enumeration number.
    pub fn from_index(index: i32) -> Option<Self> {
        match index {
            1 => Some(ControlMode::Position),
            2 => Some(ControlMode::Velocity),
            3 => Some(ControlMode::OpenLoopCurrent),
            _ => None,
        }
    }
}

/// One sample's measurements and commands in SI units, with the drive quantities the axis
/// computed for this sample.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct CascadeInput {
    pub mode: ControlMode,
    pub command_position: f64,
    pub command_velocity: f64,
    pub velocity_mode_command: f64,
    /// Total open-loop torque, N m at the motor.
    pub open_loop_torque: f64,
    pub axis_position: f64,
    /// The motor speed the velocity loop controls (mean of the motors), rad/s.
    pub motor_speed: f64,
    pub gear_ratio: f64,
    /// Total inertia at the motor, kg m^2, for the acceleration feedforward.
    pub total_inertia: f64,
    pub gains: VelocityGains,
}

/// What the cascade produced at one sample.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub(crate) struct CascadeOutput {
    /// Total torque command after the limit, N m at the motor.
    pub torque: f64,
    pub torque_limited: bool,
    pub reference: Reference,
    /// Velocity reference handed to the velocity loop, axis rad/s.
    pub velocity_reference: f64,
    pub holding: bool,
    /// The axis-specific feedforward torque (elevation friction), N m.
    pub extra_feedforward: f64,
    /// Measured axis speed (motor speed over the gear ratio), rad/s.
    pub measured_axis_velocity: f64,
}

/// See the module documentation.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Cascade {
    params: CascadeParams,
    torque_limit: f64,
    profiler: CommandProfiler,
    position_loop: PositionLoop,
    velocity_loop: VelocityLoop,
    speed_filter: SpeedFilter,
    /// Mode of the previous sample; `None` before the first sample.
    mode: Option<ControlMode>,
    /// Torque command of the previous sample, N m.
    last_torque: f64,
}

impl Cascade {
    pub fn new(params: &CascadeParams, torque_limit_nm: f64) -> Self {
        let ts = params.sampling.sample_time_s;
        let v = &params.velocity_loop;
        Self {
            params: *params,
            torque_limit: torque_limit_nm,
            profiler: CommandProfiler::new(
                &params.profiler,
                ts,
                params.position_loop.max_acceleration_deg_per_s2.to_radians(),
            ),
            position_loop: PositionLoop::new(&params.position_loop, &params.anti_limit_cycle, ts),
            velocity_loop: VelocityLoop::new(ts, torque_limit_nm, v.integrator_enabled, v.anti_windup_enabled),
            speed_filter: SpeedFilter::new(v, ts),
            mode: None,
            last_torque: 0.0,
        }
    }

    pub fn position_loop(&self) -> &PositionLoop {
        &self.position_loop
    }

    pub fn speed_filter(&self) -> &SpeedFilter {
        &self.speed_filter
    }

    pub fn sample(&mut self, input: &CascadeInput, extra_feedforward: impl FnOnce(f64) -> f64) -> CascadeOutput {
        let p = &self.params;
        let ts = p.sampling.sample_time_s;
        let previous_mode = self.mode.replace(input.mode);
        if previous_mode.is_none() {
            self.speed_filter.settle_at(input.motor_speed);
        }
        let filtered_speed = self.speed_filter.process(input.motor_speed);
        let measured_axis_velocity = input.motor_speed / input.gear_ratio;
        let entering = previous_mode != Some(input.mode);

        let (reference, velocity_reference, acceleration_feedforward, direction_velocity, holding) = match input.mode {
            ControlMode::OpenLoopCurrent => {
                let torque = input.open_loop_torque.clamp(-self.torque_limit, self.torque_limit);
                self.last_torque = torque;
                return CascadeOutput {
                    torque,
                    torque_limited: torque != input.open_loop_torque,
                    reference: Reference {
                        position: input.axis_position,
                        velocity: measured_axis_velocity,
                        acceleration: 0.0,
                        stepping: false,
                    },
                    velocity_reference: measured_axis_velocity,
                    holding: false,
                    extra_feedforward: 0.0,
                    measured_axis_velocity,
                };
            }
            ControlMode::Position => {
                if entering {
                    self.profiler.restart_from(input.axis_position, measured_axis_velocity);
                    let start = if previous_mode == Some(ControlMode::Velocity) {
                        self.position_loop.velocity_reference()
                    } else {
                        measured_axis_velocity
                    };
                    self.position_loop.restart(start);
                }
                let reference = self.profiler.update(input.command_position, input.command_velocity);
                let feedforward_velocity = if p.feedforward.velocity_enabled { reference.velocity } else { 0.0 };
                let stationary = !reference.stepping
                    && reference.velocity.abs() <= p.anti_limit_cycle.stationary_velocity_deg_per_s.to_radians();
                let at_rest = measured_axis_velocity.abs() <= p.anti_limit_cycle.rest_speed_deg_per_s.to_radians();
                let out = self.position_loop.update(
                    reference.position,
                    input.axis_position,
                    feedforward_velocity,
                    stationary,
                    at_rest,
                    !reference.stepping,
                );
                let acceleration = if p.feedforward.acceleration_enabled { reference.acceleration } else { 0.0 };
                (reference, out.velocity_reference, acceleration, reference.velocity, out.holding)
            }
            ControlMode::Velocity => {
                if entering {
                    let start = if previous_mode == Some(ControlMode::Position) {
                        self.position_loop.velocity_reference()
                    } else {
                        measured_axis_velocity
                    };
                    self.position_loop.restart(start);
                }
                let before = self.position_loop.velocity_reference();
                let velocity_reference = if p.velocity_loop.velocity_mode_acceleration_limited {
                    self.position_loop.limit(input.velocity_mode_command)
                } else {
                    self.position_loop.limit_velocity_only(input.velocity_mode_command)
                };
                let acceleration =
                    if p.feedforward.acceleration_enabled { (velocity_reference - before) / ts } else { 0.0 };
                let reference = Reference {
                    position: input.axis_position,
                    velocity: velocity_reference,
                    acceleration,
                    stepping: false,
                };
                (reference, velocity_reference, acceleration, velocity_reference, false)
            }
        };

        let speed_error = input.gear_ratio * velocity_reference - filtered_speed;
        let extra = extra_feedforward(direction_velocity);
        let feedforward = input.total_inertia * input.gear_ratio * acceleration_feedforward + extra;
        let from_open_loop = matches!(previous_mode, None | Some(ControlMode::OpenLoopCurrent));
        if from_open_loop {
            self.velocity_loop.match_output(self.last_torque, &input.gains, speed_error, feedforward);
        }
        let out = self.velocity_loop.update(&input.gains, speed_error, feedforward, holding);
        self.last_torque = out.torque;
        CascadeOutput {
            torque: out.torque,
            torque_limited: out.limited,
            reference,
            velocity_reference,
            holding,
            extra_feedforward: extra,
            measured_axis_velocity,
        }
    }

    pub fn saved_state(&self) -> CascadeState {
        CascadeState {
            mode: self.mode,
            last_torque: self.last_torque,
            profiler: self.profiler.saved_state(),
            position_loop: self.position_loop.saved_state(),
            velocity_integral: self.velocity_loop.saved_state(),
            speed_filter: self.speed_filter.saved_state(),
        }
    }

    /// Restores what [`saved_state`](Self::saved_state) returned for a cascade with the same
    /// parameters; on error `self` is unchanged.
    pub fn restore(&mut self, state: CascadeState) -> Result<(), StateError> {
        let CascadeState { mode, last_torque, profiler, position_loop, velocity_integral, speed_filter } = state;
        self.speed_filter.restore(speed_filter)?;
        self.mode = mode;
        self.last_torque = last_torque;
        self.profiler.restore(profiler);
        self.position_loop.restore(position_loop);
        self.velocity_loop.restore(velocity_integral);
        Ok(())
    }
}

/// What an FMU state holds of a controller: its cascade's state.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct CascadeState {
    /// Mode of the previous sample; `None` before the first sample.
    pub mode: Option<ControlMode>,
    /// Torque command of the previous sample, N m.
    pub last_torque: f64,
    pub profiler: ProfilerState,
    pub position_loop: PositionLoopState,
    /// The velocity loop's integral term, N m.
    pub velocity_integral: f64,
    pub speed_filter: SpeedFilterState,
}
