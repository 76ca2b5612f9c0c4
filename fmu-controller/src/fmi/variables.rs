//! The variables both controller FMUs share, declared once: a macro adds them to each axis's
//! variable table with that axis's slew limits as start values.

/// Declares a controller's variables: the shared inputs, status outputs and cascade
/// parameters, followed by the axis's own. `$vmax` and `$amax` are the axis's slew speed
/// (deg/s) and profiled acceleration (deg/s^2).
#[macro_export]
macro_rules! controller_variables {
    ($(#[$meta:meta])* pub enum $name:ident ($vmax:expr, $amax:expr) { $($own:tt)* }) => {
        fmu_runtime::declare_variables! {
            $(#[$meta])*
            pub enum $name {
                Mode = Var::enumeration("mode", &$crate::fmi::CONTROL_MODE).input().start_integer(1)
                    .description("Control mode: position (Fig. 3, default), velocity (identification with the position loop open), open_loop_current (velocity controller off)."),
                PositionCommand = Var::real("command.position", "deg").input().start(0.0).min(-$crate::fmi::common::MAX_POSITION_DEG).max($crate::fmi::common::MAX_POSITION_DEG)
                    .description("Position command from the pointing model (interpolated by the master)."),
                CommandVelocity = Var::real("command.velocity", "deg/s").input().start(0.0).min(-$crate::fmi::common::MAX_AXIS_SPEED_DEG_PER_S).max($crate::fmi::common::MAX_AXIS_SPEED_DEG_PER_S)
                    .description("Rate of the position command (derivative of the pointing table); the velocity feedforward while tracking, 0 for a fixed target."),
                VelocityModeCommand = Var::real("command.velocity_mode", "deg/s").input().start(0.0).min(-$crate::fmi::common::MAX_AXIS_SPEED_DEG_PER_S).max($crate::fmi::common::MAX_AXIS_SPEED_DEG_PER_S)
                    .description("Axis speed command in velocity mode."),
                OpenLoopCurrent = Var::real("command.open_loop_current", "A").input().start(0.0).min(-$crate::fmi::common::MAX_CURRENT).max($crate::fmi::common::MAX_CURRENT)
                    .description("Current command per motor in open_loop_current mode."),
                MeasuredPosition = Var::real("measured.position", "deg").input().start(0.0).min(-$crate::fmi::common::MAX_POSITION_DEG).max($crate::fmi::common::MAX_POSITION_DEG)
                    .description("Axis encoder position."),
                StatusReferencePosition = Var::real("status.reference_position", "deg").output()
                    .description("Reference the position loop follows: the profile during a step, the command while tracking."),
                StatusReferenceVelocity = Var::real("status.reference_velocity", "deg/s").output()
                    .description("Reference velocity (velocity feedforward)."),
                StatusReferenceAcceleration = Var::real("status.reference_acceleration", "deg/s2").output()
                    .description("Reference acceleration (acceleration feedforward)."),
                StatusPositionError = Var::real("status.position_error", "arcsec").output()
                    .description("Reference minus encoder position."),
                StatusCommandError = Var::real("status.command_error", "arcsec").output()
                    .description("Position command minus encoder position (the axis pointing error)."),
                StatusVelocityReference = Var::real("status.velocity_reference", "deg/s").output()
                    .description("Velocity reference handed to the velocity loop."),
                StatusMeasuredVelocity = Var::real("status.measured_velocity", "deg/s").output()
                    .description("Measured axis speed (motor speed over the gear ratio)."),
                StatusTorqueCommand = Var::real("status.torque_command", "N.m").output()
                    .description("Total motor torque command of the velocity loop, feedforwards included."),
                StatusProfiling = Var::boolean("status.profiling").output().description("True while the profiler executes a step."),
                StatusTorqueLimited = Var::boolean("status.torque_limited").output().description("True when the torque limit cut the velocity loop's command."),
                StatusHolding = Var::boolean("status.holding").output().description("True while the anti-limit-cycle hold freezes the integrators."),
                SampleTime = Var::real("sampling.sample_time", "s").parameter().start(1e-3).min(1e-5).max(0.1)
                    .description("Controller sample time Ts; samples fall on t0 + k Ts whatever the communication step (all samples inside a step see the inputs held over it)."),
                DelaySamples = Var::integer("sampling.delay_samples").parameter().start_integer(1).range_integer(0, 64)
                    .description("Computation/transport delay in samples: outputs computed at t_k are applied from t_k + delay Ts."),
                ProfilerEnabled = Var::boolean("profiler.enabled").parameter().start_boolean(true)
                    .description("Command profiler for position steps (off: steps go straight to the position loop and overshoot)."),
                ProfilerMaxVelocity = Var::real("profiler.max_velocity", "deg/s").parameter().start($vmax).min(0.0).max($crate::fmi::common::MAX_AXIS_SPEED_DEG_PER_S)
                    .description("Speed limit of profiled steps."),
                ProfilerMaxAcceleration = Var::real("profiler.max_acceleration", "deg/s2").parameter().start($amax).min(0.0).max($crate::fmi::common::MAX_AXIS_ACCELERATION)
                    .description("Acceleration limit of profiled steps."),
                ProfilerJerkLimit = Var::real("profiler.jerk_limit", "deg/s3").parameter().start(0.0).min(0.0).max($crate::fmi::common::MAX_AXIS_JERK)
                    .description("Jerk limit of profiled steps; 0 is off."),
                ProfilerStepThreshold = Var::real("profiler.step_threshold", "deg").parameter().start(0.002).min(0.0).max(360.0)
                    .description("A command jump larger than this (from the reference's prediction) starts a profiled step; smaller changes are tracked."),
                VelocityFeedforward = Var::boolean("feedforward.velocity").parameter().start_boolean(true)
                    .description("Adds the reference velocity to the position loop's output."),
                AccelerationFeedforward = Var::boolean("feedforward.acceleration").parameter().start_boolean(true)
                    .description("Adds J_total N a_ref to the torque command."),
                PositionBandwidth = Var::real("position_loop.bandwidth", "Hz").parameter().start(0.75).min(0.0).max($crate::fmi::common::MAX_LOOP_FREQUENCY)
                    .description("Closed-loop bandwidth the position gain is designed for (0.5-1 Hz in the paper)."),
                PositionGainOverride = Var::real("position_loop.gain_override", "1/s").parameter().start(0.0).min(0.0).max($crate::fmi::common::MAX_POSITION_GAIN)
                    .description("Position gain Kp; 0 uses the gain designed from the bandwidth."),
                PositionIntegrator = Var::boolean("position_loop.integrator").parameter().start_boolean(false)
                    .description("Adds a small integral action to the position loop."),
                PositionIntegralCorner = Var::real("position_loop.integral_corner", "Hz").parameter().start(0.05).min(0.0).max($crate::fmi::common::MAX_LOOP_FREQUENCY)
                    .description("Corner frequency of the position integral action."),
                PositionMaxVelocity = Var::real("position_loop.max_velocity", "deg/s").parameter().start(1.05 * $vmax).min(0.0).max($crate::fmi::common::MAX_AXIS_SPEED_DEG_PER_S)
                    .description("Limit on the velocity reference."),
                PositionMaxAcceleration = Var::real("position_loop.max_acceleration", "deg/s2").parameter().start(2.0 * $amax).min(0.0).max($crate::fmi::common::MAX_AXIS_ACCELERATION)
                    .description("Limit on the rate of change of the velocity reference."),
                VelocityCrossover = Var::real("velocity_loop.crossover", "Hz").parameter().start(10.0).min(0.0).max($crate::fmi::common::MAX_LOOP_FREQUENCY)
                    .description("Crossover the velocity PI is designed for, Kv = 2 pi f J_total (closed loop about 11-12.5 Hz)."),
                VelocityIntegralRatio = Var::real("velocity_loop.integral_corner_ratio", "1").parameter().start(5.0).min(0.1).max(1e3)
                    .description("Crossover over the PI's integral corner frequency."),
                VelocityGainOverride = Var::real("velocity_loop.gain_override", "N.m.s/rad").parameter().start(0.0).min(0.0).max($crate::fmi::common::MAX_SPEED_GAIN)
                    .description("Velocity gain Kv at the motor; 0 uses the designed gain."),
                VelocityIntegralOverride = Var::real("velocity_loop.integral_corner_override", "Hz").parameter().start(0.0).min(0.0).max($crate::fmi::common::MAX_LOOP_FREQUENCY)
                    .description("Integral corner of the velocity PI; 0 uses crossover / ratio."),
                VelocityIntegrator = Var::boolean("velocity_loop.integrator").parameter().start_boolean(true)
                    .description("Integral action of the velocity loop."),
                AntiWindup = Var::boolean("velocity_loop.anti_windup").parameter().start_boolean(true)
                    .description("Stops the velocity integrator from winding up while the torque is limited."),
                SpeedLowPass = Var::real("velocity_loop.speed_low_pass", "Hz").parameter().start(0.0).min(0.0).max($crate::fmi::common::MAX_LOOP_FREQUENCY)
                    .description("First-order low-pass on the measured speed; 0 is off."),
                NotchFrequency = Var::real("velocity_loop.notch_frequency", "Hz").parameter().start(0.0).min(0.0).max($crate::fmi::common::MAX_LOOP_FREQUENCY)
                    .description("Notch on the measured speed at the drive resonance; 0 is off."),
                NotchDamping = Var::real("velocity_loop.notch_damping", "1").parameter().start(0.5).min(0.01).max(10.0)
                    .description("Damping of the notch's poles (its width)."),
                NotchDepth = Var::real("velocity_loop.notch_depth", "1").parameter().start(0.1).min(0.0).max(1.0)
                    .description("Gain of the notch at its frequency."),
                AntiLimitCycle = Var::boolean("anti_limit_cycle.enabled").parameter().start_boolean(true)
                    .description("Freezes the integrators once the axis has stopped near a stationary target, so stiction cannot make it hunt."),
                HoldEntry = Var::real("anti_limit_cycle.hold_entry_error", "arcsec").parameter().start(2.0).min(0.0).max($crate::fmi::common::MAX_HOLD_ERROR_ARCSEC)
                    .description("The hold engages at rest within this position error."),
                HoldRelease = Var::real("anti_limit_cycle.hold_release_error", "arcsec").parameter().start(4.0).min(0.0).max($crate::fmi::common::MAX_HOLD_ERROR_ARCSEC)
                    .description("The hold releases beyond this position error (hysteresis)."),
                HoldMotionBand = Var::real("anti_limit_cycle.hold_motion_band", "arcsec").parameter().start(0.5).min(0.0)
                    .description("The hold also releases once the measured position has moved by more than this since the hold began: a held axis that moves is pushed (by wind), not stuck, and needs its integrators. Estimate: 25 times a realistic encoder's reading noise (0.02 arcsec), 13 counts of a 25-bit encoder; range 0.2-2 arcsec (above the noise and count, well below the 4 arcsec release)."),
                RestTime = Var::real("anti_limit_cycle.rest_time", "s").parameter().start(0.25).min(0.0).max(60.0)
                    .description("The axis must have been at rest this long before the hold engages: friction sticks an axis for good, while a wind-driven axis only passes through zero speed and a noisy speed signal dips below the rest speed for single samples. Estimate, range 0.05-1 s."),
                $($own)*
                // The mode's Integer twin (appended after every axis's own variables, so that
                // existing value references keep their numbers).
                ModeNumber = Var::integer("mode_number").input().start_integer(0).range_integer(0, 3)
                    .description("mode as an Integer, for masters that ignore FMI enumerations (libcosim and ecos do): 1 position, 2 velocity, 3 open_loop_current; 0 (the default) leaves the choice to mode. When it is not 0 it wins."),
            }
        }

        impl $name {
            pub const CASCADE: $crate::fmi::common::CascadeVars<$name> = $crate::fmi::common::CascadeVars {
                sample_time: $name::SampleTime,
                delay_samples: $name::DelaySamples,
                profiler_enabled: $name::ProfilerEnabled,
                profiler_max_velocity: $name::ProfilerMaxVelocity,
                profiler_max_acceleration: $name::ProfilerMaxAcceleration,
                profiler_jerk_limit: $name::ProfilerJerkLimit,
                profiler_step_threshold: $name::ProfilerStepThreshold,
                velocity_feedforward: $name::VelocityFeedforward,
                acceleration_feedforward: $name::AccelerationFeedforward,
                position_bandwidth: $name::PositionBandwidth,
                position_gain_override: $name::PositionGainOverride,
                position_integrator: $name::PositionIntegrator,
                position_integral_corner: $name::PositionIntegralCorner,
                position_max_velocity: $name::PositionMaxVelocity,
                position_max_acceleration: $name::PositionMaxAcceleration,
                velocity_crossover: $name::VelocityCrossover,
                velocity_integral_ratio: $name::VelocityIntegralRatio,
                velocity_gain_override: $name::VelocityGainOverride,
                velocity_integral_override: $name::VelocityIntegralOverride,
                velocity_integrator: $name::VelocityIntegrator,
                anti_windup: $name::AntiWindup,
                speed_low_pass: $name::SpeedLowPass,
                notch_frequency: $name::NotchFrequency,
                notch_damping: $name::NotchDamping,
                notch_depth: $name::NotchDepth,
                anti_limit_cycle: $name::AntiLimitCycle,
                hold_entry: $name::HoldEntry,
                hold_release: $name::HoldRelease,
                hold_motion_band: $name::HoldMotionBand,
                rest_time: $name::RestTime,
            };

            pub const STATUS: $crate::fmi::common::StatusVars<$name> = $crate::fmi::common::StatusVars {
                reference_position: $name::StatusReferencePosition,
                reference_velocity: $name::StatusReferenceVelocity,
                reference_acceleration: $name::StatusReferenceAcceleration,
                position_error: $name::StatusPositionError,
                command_error: $name::StatusCommandError,
                velocity_reference: $name::StatusVelocityReference,
                measured_velocity: $name::StatusMeasuredVelocity,
                torque_command: $name::StatusTorqueCommand,
                profiling: $name::StatusProfiling,
                torque_limited: $name::StatusTorqueLimited,
                holding: $name::StatusHolding,
            };

            /// The control mode input (its Integer twin wins unless it is 0).
            pub fn mode(values: &fmu_runtime::Values<$name>) -> $crate::ControlMode {
                let index = match values.integer($name::ModeNumber) {
                    0 => values.integer($name::Mode),
                    number => number,
                };
                $crate::ControlMode::from_index(index).unwrap_or($crate::ControlMode::Position)
            }
        }
    };
}
