//! The azimuth plant as an FMI 2.0 co-simulation model: its variables and how they map onto
//! [`AzimuthParams`], [`AzimuthInputs`] and [`AzimuthOutputs`].

use fmu_runtime::{Context, Model, ModelInfo, Notes, StateError, Values};

use super::PlantFmuError;
use crate::drivetrain::DriveState;
use crate::error::PlantError;

use super::common::{
    model_info, plant_step_pieces, plant_variables, sensor_text as T, FrictionVars, MotorVars, NumericsVars,
    SensorVars, MAX_CURRENT_LOOP_BANDWIDTH, MAX_PATH_DAMPING, MAX_PATH_STIFFNESS, MAX_SPEED_NOISE, MIN_MOTOR_INERTIA,
    TINY,
};
use super::common::{
    MAX_BACKLASH_ARCSEC, MAX_COGGING, MAX_COGGING_PERIOD, MAX_CURRENT, MAX_GEAR_RATIO, MAX_LOAD_INERTIA,
    MAX_LOAD_TORQUE, MAX_MOTOR_FRICTION, MAX_MOTOR_INERTIA, MAX_MOTOR_VISCOUS, MAX_PERIOD_DEG, MAX_PHASE_DEG,
    MAX_STRIBECK_VELOCITY, MAX_TORQUE_CONSTANT, MAX_TORQUE_CONSTANT_SCALE,
};
use crate::params::PeriodicTorqueParams;
use crate::{AzimuthInputs, AzimuthParams, AzimuthPlant};

const ARCSEC: f64 = std::f64::consts::PI / (180.0 * 3600.0);

plant_variables! {
    /// Variables of the azimuth plant FMU. Motor-side quantities are at the motor shaft;
    /// stiffness, damping, inertia and load torques are about the azimuth axis.
    pub enum AzVar {
        own {
            // Inputs.
            Current1Command = Var::real("motor1.current_command", "A").input().start(0.0).min(-MAX_CURRENT).max(MAX_CURRENT)
                .description("Current command to drive 1, before its current loop; clamped to motor1.current_limit."),
            Current2Command = Var::real("motor2.current_command", "A").input().start(0.0).min(-MAX_CURRENT).max(MAX_CURRENT)
                .description("Current command to drive 2, before its current loop; clamped to motor2.current_limit."),
            DisturbanceTorque = Var::real("load.disturbance_torque", "N.m").input().start(0.0).min(-MAX_LOAD_TORQUE).max(MAX_LOAD_TORQUE)
                .description("External torque about the azimuth axis (wind); positive drives positive azimuth."),
            Elevation = Var::real("elevation", "deg").input().start(45.0).min(-10.0).max(120.0)
                .description("Elevation angle of the dish, which sets the load inertia about the azimuth axis."),
            // Outputs.
            EncoderPosition = Var::real("axis.encoder_position", "deg").output()
                .description("Azimuth encoder reading: the true angle plus the encoder errors (encoder.*), counted to encoder.bits per turn as encoder.count_mode says."),
            AxisPosition = Var::real("axis.position", "deg").output()
                .description("True azimuth angle of the load (not quantised)."),
            AxisSpeed = Var::real("axis.speed", "deg/s").output().description("Azimuth speed of the load."),
            Motor1Speed = Var::real("motor1.speed", "rad/s").output().description("Speed signal of motor 1 at its shaft: the true speed plus motor1.speed_noise_rms noise (none by default)."),
            Motor2Speed = Var::real("motor2.speed", "rad/s").output().description("Speed signal of motor 2 at its shaft: the true speed plus motor2.speed_noise_rms noise (none by default)."),
            Motor1Current = Var::real("motor1.current", "A").output().description("Current of motor 1 (output of its current loop)."),
            Motor2Current = Var::real("motor2.current", "A").output().description("Current of motor 2 (output of its current loop)."),
            Motor1Torque = Var::real("motor1.torque", "N.m").output().description("Electromagnetic torque of motor 1, K_phi times its current."),
            Motor2Torque = Var::real("motor2.torque", "N.m").output().description("Electromagnetic torque of motor 2, K_phi times its current."),
            Pinion1Torque = Var::real("pinion1.torque", "N.m").output().description("Torque pinion 1 puts on the bull gear, about the azimuth axis."),
            Pinion2Torque = Var::real("pinion2.torque", "N.m").output().description("Torque pinion 2 puts on the bull gear, about the azimuth axis."),
            Pinion1Flank = Var::integer("pinion1.flank").output()
                .description("Flank of pinion 1 in contact: +1 driving positive, -1 driving negative, 0 in the backlash gap."),
            Pinion2Flank = Var::integer("pinion2.flank").output()
                .description("Flank of pinion 2 in contact: +1 driving positive, -1 driving negative, 0 in the backlash gap."),
            LoadInertia = Var::real("load.inertia", "kg.m2").output().depends_on(&[AzVar::Elevation as u32])
                .description("Inertia about the azimuth axis that the dynamics use at the current elevation input: its value at the centre of the input's parameter-grid cell (numerics.parameter_grid_cell)."),
            AntiResonance = Var::real("drive.anti_resonance_frequency", "Hz").output().depends_on(&[AzVar::Elevation as u32])
                .description("Undamped anti-resonance sqrt(K_s/J_L)/(2 pi) of the drive that the dynamics use at the current elevation input: stiffness and inertia at the centre of the input's parameter-grid cell."),
            // Gearing and paths.
            GearRatio = Var::real("gear.ratio", "1").parameter().start(9000.0).min(1.0).max(MAX_GEAR_RATIO)
                .description("Gear ratio of each drive, motor rad per axis rad (gearbox times bull gear over pinion)."),
            Pinion1Stiffness = Var::real("pinion1.stiffness", "N.m/rad").parameter().start(7.3e9).min(TINY).max(MAX_PATH_STIFFNESS)
                .description("Stiffness of drive path 1 about the axis (gearbox, pinion, teeth, bull gear); the paper measured up to 30 % spread. Must be positive."),
            Pinion2Stiffness = Var::real("pinion2.stiffness", "N.m/rad").parameter().start(7.3e9).min(TINY).max(MAX_PATH_STIFFNESS)
                .description("Stiffness of drive path 2 about the axis. Must be positive."),
            Pinion1Damping = Var::real("pinion1.damping", "N.m.s/rad").parameter().start(5.3e6).min(0.0).max(MAX_PATH_DAMPING)
                .description("Viscous damping of drive path 1 about the axis (the paper's K_cv, per path). With backlash it must be positive, and at least the stiffness times 1e-10 s (the spring relaxes through it in the gap)."),
            Pinion2Damping = Var::real("pinion2.damping", "N.m.s/rad").parameter().start(5.3e6).min(0.0).max(MAX_PATH_DAMPING)
                .description("Viscous damping of drive path 2 about the axis. With backlash it must be positive, and at least the stiffness times 1e-10 s."),
            Pinion1Backlash = Var::real("pinion1.backlash", "arcsec").parameter().start(20.626480624709636).min(0.0).max(MAX_BACKLASH_ARCSEC)
                .description("Total free play of pinion 1 on the bull gear, about the axis."),
            Pinion2Backlash = Var::real("pinion2.backlash", "arcsec").parameter().start(20.626480624709636).min(0.0).max(MAX_BACKLASH_ARCSEC)
                .description("Total free play of pinion 2 on the bull gear, about the axis."),
            // Load.
            TurningHeadInertia = Var::real("load.turning_head_inertia", "kg.m2").parameter().start(5.5e5).min(0.0).max(MAX_LOAD_INERTIA)
                .description("Inertia of the turning head (yoke, drives, cable wrap) about the azimuth axis. It and the smaller of the two elevation-structure inertias must not both be 0."),
            CrossInertia = Var::real("load.elevation_structure_cross_inertia", "kg.m2").parameter().start(2.0e5).min(0.0).max(MAX_LOAD_INERTIA)
                .description("Inertia of the elevation structure about its axis perpendicular to boresight and elevation axis (vertical at 0 deg elevation)."),
            BoresightInertia = Var::real("load.elevation_structure_boresight_inertia", "kg.m2").parameter().start(4.0e5).min(0.0).max(MAX_LOAD_INERTIA)
                .description("Inertia of the elevation structure about its boresight (vertical at 90 deg elevation)."),
            BearingCoulomb = Var::real("bearing.coulomb_friction", "N.m").parameter().start(1500.0).min(0.0).max(MAX_LOAD_TORQUE)
                .description("Sliding friction of the azimuth bearing and cable wrap, about the axis."),
            BearingStatic = Var::real("bearing.static_friction", "N.m").parameter().start(2000.0).min(0.0).max(MAX_LOAD_TORQUE)
                .description("Breakaway friction of the azimuth bearing and cable wrap (at least the sliding friction)."),
            BearingStribeck = Var::real("bearing.stribeck_velocity", "rad/s").parameter().start(0.0).min(0.0).max(MAX_STRIBECK_VELOCITY)
                .description("Stribeck velocity of the bearing friction at the axis; 0 switches the Stribeck curve off."),
            BearingAsymmetry = Var::real("bearing.friction_asymmetry", "1").parameter().start(0.0).min(-0.99).max(0.99)
                .description("Direction asymmetry a of the bearing friction: (1+a) times nominal moving positive, (1-a) moving negative."),
            BearingViscous = Var::real("bearing.viscous_friction", "N.m.s/rad").parameter().start(0.0).min(0.0).max(MAX_PATH_DAMPING)
                .description("Viscous friction of the azimuth bearing about the axis (0 in the paper's model)."),
            TorqueOffset = Var::real("load.torque_offset", "N.m").parameter().start(0.0).min(-MAX_LOAD_TORQUE).max(MAX_LOAD_TORQUE)
                .description("Constant torque on the load about the axis (for example a cable-wrap preload)."),
            PeriodicAmplitude = Var::real("load.periodic_torque_amplitude", "N.m").parameter().start(0.0).min(-MAX_LOAD_TORQUE).max(MAX_LOAD_TORQUE)
                .description("Amplitude of a torque on the load that repeats with the azimuth angle (gear ripple, tilted-axis unbalance); 0 is off."),
            PeriodicPeriod = Var::real("load.periodic_torque_period", "deg").parameter().start(360.0).min(1e-6).max(MAX_PERIOD_DEG)
                .description("Period of the position-periodic load torque in axis degrees."),
            PeriodicPhase = Var::real("load.periodic_torque_phase", "deg").parameter().start(0.0).min(-MAX_PHASE_DEG).max(MAX_PHASE_DEG)
                .description("Phase of the position-periodic load torque at azimuth 0."),
            // Motor 1.
            M1Inertia = Var::real("motor1.inertia", "kg.m2").parameter().start(0.006).min(MIN_MOTOR_INERTIA).max(MAX_MOTOR_INERTIA)
                .description("Inertia J_M of motor 1 with its gearbox input stage."),
            M1Viscous = Var::real("motor1.viscous_friction", "N.m.s/rad").parameter().start(1.0e-3).min(0.0).max(MAX_MOTOR_VISCOUS)
                .description("Viscous friction B_M of motor 1 and its gearbox, at the motor."),
            M1Coulomb = Var::real("motor1.coulomb_friction", "N.m").parameter().start(0.3).min(0.0).max(MAX_MOTOR_FRICTION)
                .description("Sliding friction of motor 1 and its gearbox, at the motor."),
            M1Static = Var::real("motor1.static_friction", "N.m").parameter().start(0.4).min(0.0).max(MAX_MOTOR_FRICTION)
                .description("Breakaway friction of motor 1 and its gearbox, at the motor (at least the sliding friction)."),
            M1Stribeck = Var::real("motor1.stribeck_velocity", "rad/s").parameter().start(0.0).min(0.0).max(MAX_STRIBECK_VELOCITY)
                .description("Stribeck velocity of motor 1's friction; 0 switches the Stribeck curve off."),
            M1Asymmetry = Var::real("motor1.friction_asymmetry", "1").parameter().start(0.0).min(-0.99).max(0.99)
                .description("Direction asymmetry of motor 1's friction."),
            M1TorqueConstant = Var::real("motor1.torque_constant", "N.m/A").parameter().start(0.8).min(TINY).max(MAX_TORQUE_CONSTANT)
                .description("Torque constant K_phi of motor 1."),
            M1TorqueScale = Var::real("motor1.torque_constant_scale", "1").parameter().start(1.0).min(TINY).max(MAX_TORQUE_CONSTANT_SCALE)
                .description("Multiplier on motor 1's torque constant (a torque-constant error); 1 is nominal."),
            M1CurrentLimit = Var::real("motor1.current_limit", "A").parameter().start(15.0).min(TINY).max(MAX_CURRENT)
                .description("Current limit of drive 1: the command is clamped to +/- this."),
            M1Bandwidth = Var::real("motor1.current_loop_bandwidth", "Hz").parameter().start(100.0).min(TINY).max(MAX_CURRENT_LOOP_BANDWIDTH)
                .description("Closed-loop bandwidth of drive 1's current loop (first-order lag)."),
            M1Delay = Var::real("motor1.command_delay", "s").parameter().start(0.0).min(0.0).max(1.0)
                .description("Pure time delay on motor 1's current command; 0 is off."),
            M1CoggingAmplitude = Var::real("motor1.cogging_amplitude", "N.m").parameter().start(0.0).min(-MAX_COGGING).max(MAX_COGGING)
                .description("Amplitude of motor 1's cogging torque; 0 is off."),
            M1CoggingPeriod = Var::real("motor1.cogging_period", "1").parameter().start(1.0).min(1e-9).max(MAX_COGGING_PERIOD)
                .description("Period of motor 1's cogging torque in motor revolutions (1/48 for 48 slots)."),
            M1CoggingPhase = Var::real("motor1.cogging_phase", "deg").parameter().start(0.0).min(-MAX_PHASE_DEG).max(MAX_PHASE_DEG)
                .description("Phase of motor 1's cogging torque at motor angle 0."),
            // Motor 2.
            M2Inertia = Var::real("motor2.inertia", "kg.m2").parameter().start(0.006).min(MIN_MOTOR_INERTIA).max(MAX_MOTOR_INERTIA)
                .description("Inertia J_M of motor 2 with its gearbox input stage."),
            M2Viscous = Var::real("motor2.viscous_friction", "N.m.s/rad").parameter().start(1.0e-3).min(0.0).max(MAX_MOTOR_VISCOUS)
                .description("Viscous friction B_M of motor 2 and its gearbox, at the motor."),
            M2Coulomb = Var::real("motor2.coulomb_friction", "N.m").parameter().start(0.3).min(0.0).max(MAX_MOTOR_FRICTION)
                .description("Sliding friction of motor 2 and its gearbox, at the motor."),
            M2Static = Var::real("motor2.static_friction", "N.m").parameter().start(0.4).min(0.0).max(MAX_MOTOR_FRICTION)
                .description("Breakaway friction of motor 2 and its gearbox, at the motor (at least the sliding friction)."),
            M2Stribeck = Var::real("motor2.stribeck_velocity", "rad/s").parameter().start(0.0).min(0.0).max(MAX_STRIBECK_VELOCITY)
                .description("Stribeck velocity of motor 2's friction; 0 switches the Stribeck curve off."),
            M2Asymmetry = Var::real("motor2.friction_asymmetry", "1").parameter().start(0.0).min(-0.99).max(0.99)
                .description("Direction asymmetry of motor 2's friction."),
            M2TorqueConstant = Var::real("motor2.torque_constant", "N.m/A").parameter().start(0.8).min(TINY).max(MAX_TORQUE_CONSTANT)
                .description("Torque constant K_phi of motor 2."),
            M2TorqueScale = Var::real("motor2.torque_constant_scale", "1").parameter().start(1.0).min(TINY).max(MAX_TORQUE_CONSTANT_SCALE)
                .description("Multiplier on motor 2's torque constant (a torque-constant error); 1 is nominal."),
            M2CurrentLimit = Var::real("motor2.current_limit", "A").parameter().start(15.0).min(TINY).max(MAX_CURRENT)
                .description("Current limit of drive 2: the command is clamped to +/- this."),
            M2Bandwidth = Var::real("motor2.current_loop_bandwidth", "Hz").parameter().start(100.0).min(TINY).max(MAX_CURRENT_LOOP_BANDWIDTH)
                .description("Closed-loop bandwidth of drive 2's current loop (first-order lag)."),
            M2Delay = Var::real("motor2.command_delay", "s").parameter().start(0.0).min(0.0).max(1.0)
                .description("Pure time delay on motor 2's current command; 0 is off."),
            M2CoggingAmplitude = Var::real("motor2.cogging_amplitude", "N.m").parameter().start(0.0).min(-MAX_COGGING).max(MAX_COGGING)
                .description("Amplitude of motor 2's cogging torque; 0 is off."),
            M2CoggingPeriod = Var::real("motor2.cogging_period", "1").parameter().start(1.0).min(1e-9).max(MAX_COGGING_PERIOD)
                .description("Period of motor 2's cogging torque in motor revolutions."),
            M2CoggingPhase = Var::real("motor2.cogging_phase", "deg").parameter().start(0.0).min(-MAX_PHASE_DEG).max(MAX_PHASE_DEG)
                .description("Phase of motor 2's cogging torque at motor angle 0."),
            // Sensing, configuration and numerics.
            EncoderBits = Var::integer("encoder.bits").parameter().start_integer(25).range_integer(0, 40)
                .description("Resolution of the azimuth encoder in bits per turn; 0 means unquantised."),
            InitialPosition = Var::real("initial_position", "deg").parameter().start(0.0).min(-185.0).max(275.0)
                .description("Azimuth at which the axis starts, at rest, pinions centred in their backlash."),
            Linear = Var::boolean("linear_configuration").parameter().start_boolean(false)
                .description("If true, the plant is exactly the paper's linear Eq. 1 model: Coulomb/static friction, backlash, saturation, delay, cogging, extra torques, quantisation and all sensor errors are ignored."),
            ParameterFile = Var::string("parameter_file").parameter().start_string("")
                .description("A parameter file (name = value lines) applied when this is set; relative paths are looked up in the FMU's resources folder (for example linear.params)."),
            GridCell = Var::real("numerics.parameter_grid_cell", "deg").parameter().start(0.25).min(1e-6).max(10.0)
                .description("Elevation cell within which the load inertia is frozen at the cell centre (error measured in docs/plant-model.md)."),
            NonlinearSubstep = Var::real("numerics.nonlinear_substep", "s").parameter().start(1e-4).min(1e-7).max(1.0)
                .description("Internal sub-step over which Stribeck, cogging and periodic torques are held constant (used only when those are on)."),
            EventResolution = Var::real("numerics.event_time_resolution", "s").parameter().start(1e-6).min(1e-9).max(1e-3)
                .description("Time resolution to which stick/slip and backlash contact events are localised."),
            EventCheckInterval = Var::real("numerics.event_check_interval", "s").parameter().start(1e-3).min(1e-6).max(1.0)
                .description("Longest interval between checks for mode switches, at least numerics.event_time_resolution; longer communication steps are cut into pieces (at 1e-6 s a 1 ms step is already 1000 of them)."),
            CacheCapacity = Var::integer("numerics.cache_capacity").parameter().start_integer(64).range_integer(8, 4096)
                .description("Discretisations kept per cache generation (memory stays bounded whatever the step sizes)."),
            // Presliding friction of the motors (appended: existing value references keep their numbers).
            M1PreslidingStiffness = Var::real("motor1.presliding_stiffness", "N.m/rad").parameter().start(0.0).min(0.0).max(MAX_PATH_STIFFNESS)
                .description("Presliding (bristle) stiffness of motor 1's friction: while sticking, the motor is held by this spring to a friction anchor and slips when its torque reaches the breakaway level; 0 is a rigid stick."),
            M1PreslidingDamping = Var::real("motor1.presliding_damping", "N.m.s/rad").parameter().start(0.0).min(0.0).max(MAX_PATH_DAMPING)
                .description("Damping of motor 1's presliding spring (used only with a presliding stiffness)."),
            M2PreslidingStiffness = Var::real("motor2.presliding_stiffness", "N.m/rad").parameter().start(0.0).min(0.0).max(MAX_PATH_STIFFNESS)
                .description("Presliding (bristle) stiffness of motor 2's friction: while sticking, the motor is held by this spring to a friction anchor and slips when its torque reaches the breakaway level; 0 is a rigid stick."),
            M2PreslidingDamping = Var::real("motor2.presliding_damping", "N.m.s/rad").parameter().start(0.0).min(0.0).max(MAX_PATH_DAMPING)
                .description("Damping of motor 2's presliding spring (used only with a presliding stiffness)."),
            // Sensors (appended: existing value references keep their numbers). Every default is the
            // ideal encoder and noise-free speed signals, which reproduce the plant before the sensor model.
        }
        speed_noise {
            M1SpeedNoise = Var::real("motor1.speed_noise_rms", "rad/s").parameter().start(0.0).min(0.0).max(MAX_SPEED_NOISE)
                .description(T::SPEED_NOISE),
            M2SpeedNoise = Var::real("motor2.speed_noise_rms", "rad/s").parameter().start(0.0).min(0.0).max(MAX_SPEED_NOISE)
                .description(T::SPEED_NOISE),
        }
        more {
            StiffnessVariation = Var::real("pinion.stiffness_variation", "1").parameter().start(0.0).min(-0.9).max(0.9)
                .description("Relative change of both paths' stiffness over the elevation travel, linear in elevation: the stiffness at el is pinion<k>.stiffness times 1 + v (el - 51.5 deg) / 73 deg (1 - v/2 at 15 deg, 1 + v/2 at 88 deg). The paper measured anti-resonance mismatches implying up to 30 % over the travel (sign and shape unknown); 0, the paper's single K_s, by default."),
        }
    }
}

const MOTOR1: MotorVars<AzVar> = MotorVars {
    inertia: AzVar::M1Inertia,
    viscous_friction: AzVar::M1Viscous,
    coulomb_friction: AzVar::M1Coulomb,
    static_friction: AzVar::M1Static,
    stribeck_velocity: AzVar::M1Stribeck,
    friction_asymmetry: AzVar::M1Asymmetry,
    torque_constant: AzVar::M1TorqueConstant,
    torque_constant_scale: AzVar::M1TorqueScale,
    current_limit: AzVar::M1CurrentLimit,
    current_loop_bandwidth: AzVar::M1Bandwidth,
    command_delay: AzVar::M1Delay,
    cogging_amplitude: AzVar::M1CoggingAmplitude,
    cogging_period: AzVar::M1CoggingPeriod,
    cogging_phase: AzVar::M1CoggingPhase,
    presliding_stiffness: Some(AzVar::M1PreslidingStiffness),
    presliding_damping: Some(AzVar::M1PreslidingDamping),
};

const MOTOR2: MotorVars<AzVar> = MotorVars {
    inertia: AzVar::M2Inertia,
    viscous_friction: AzVar::M2Viscous,
    coulomb_friction: AzVar::M2Coulomb,
    static_friction: AzVar::M2Static,
    stribeck_velocity: AzVar::M2Stribeck,
    friction_asymmetry: AzVar::M2Asymmetry,
    torque_constant: AzVar::M2TorqueConstant,
    torque_constant_scale: AzVar::M2TorqueScale,
    current_limit: AzVar::M2CurrentLimit,
    current_loop_bandwidth: AzVar::M2Bandwidth,
    command_delay: AzVar::M2Delay,
    cogging_amplitude: AzVar::M2CoggingAmplitude,
    cogging_period: AzVar::M2CoggingPeriod,
    cogging_phase: AzVar::M2CoggingPhase,
    presliding_stiffness: Some(AzVar::M2PreslidingStiffness),
    presliding_damping: Some(AzVar::M2PreslidingDamping),
};

const BEARING: FrictionVars<AzVar> = FrictionVars {
    coulomb: AzVar::BearingCoulomb,
    static_: AzVar::BearingStatic,
    stribeck_velocity: AzVar::BearingStribeck,
    asymmetry: AzVar::BearingAsymmetry,
};

const NUMERICS: NumericsVars<AzVar> = NumericsVars {
    grid_cell: AzVar::GridCell,
    nonlinear_substep: AzVar::NonlinearSubstep,
    event_resolution: AzVar::EventResolution,
    event_check_interval: AzVar::EventCheckInterval,
    cache_capacity: AzVar::CacheCapacity,
};

const SENSORS: SensorVars<AzVar, 2> = SensorVars {
    count_mode: AzVar::EncoderCountMode,
    count_mode_number: AzVar::EncoderCountModeNumber,
    graduation: [
        (AzVar::Graduation1Amplitude, AzVar::Graduation1Harmonic, AzVar::Graduation1Phase),
        (AzVar::Graduation2Amplitude, AzVar::Graduation2Harmonic, AzVar::Graduation2Phase),
        (AzVar::Graduation3Amplitude, AzVar::Graduation3Harmonic, AzVar::Graduation3Phase),
    ],
    line_count: AzVar::LineCount,
    interpolation: [
        (AzVar::Interpolation1Amplitude, AzVar::Interpolation1Phase),
        (AzVar::Interpolation2Amplitude, AzVar::Interpolation2Phase),
    ],
    eccentricity: (AzVar::EccentricityAmplitude, AzVar::EccentricityPhase),
    encoder_noise: AzVar::EncoderNoise,
    speed_noise: [AzVar::M1SpeedNoise, AzVar::M2SpeedNoise],
    seed: AzVar::SensorSeed,
    sample_period: AzVar::SensorSamplePeriod,
};

/// The plant parameters the variable values describe.
pub fn azimuth_params(v: &Values<AzVar>) -> AzimuthParams {
    let params = AzimuthParams {
        gear_ratio: v.real(AzVar::GearRatio),
        motors: [MOTOR1.read(v), MOTOR2.read(v)],
        path_stiffness_nm_per_rad: [v.real(AzVar::Pinion1Stiffness), v.real(AzVar::Pinion2Stiffness)],
        path_damping_nm_s_per_rad: [v.real(AzVar::Pinion1Damping), v.real(AzVar::Pinion2Damping)],
        pinion_backlash_rad: [v.real(AzVar::Pinion1Backlash) * ARCSEC, v.real(AzVar::Pinion2Backlash) * ARCSEC],
        turning_head_inertia_kg_m2: v.real(AzVar::TurningHeadInertia),
        elevation_structure_cross_inertia_kg_m2: v.real(AzVar::CrossInertia),
        elevation_structure_boresight_inertia_kg_m2: v.real(AzVar::BoresightInertia),
        bearing_friction: BEARING.read(v),
        bearing_viscous_friction_nm_s_per_rad: v.real(AzVar::BearingViscous),
        torque_offset_nm: v.real(AzVar::TorqueOffset),
        periodic_torque: PeriodicTorqueParams {
            amplitude_nm: v.real(AzVar::PeriodicAmplitude),
            period_deg: v.real(AzVar::PeriodicPeriod),
            phase_deg: v.real(AzVar::PeriodicPhase),
        },
        encoder_bits: v.integer(AzVar::EncoderBits) as u32,
        sensors: SENSORS.read(v),
        numerics: NUMERICS.read(v),
        stiffness_variation_over_elevation: v.real(AzVar::StiffnessVariation),
    };
    if v.boolean(AzVar::Linear) {
        let mut linear = AzimuthParams::linear();
        // Keep every linear parameter the master chose; drop only what Eq. 1 does not have.
        linear.gear_ratio = params.gear_ratio;
        linear.motors = params.motors.map(|m| m.linearised());
        linear.path_stiffness_nm_per_rad = params.path_stiffness_nm_per_rad;
        linear.stiffness_variation_over_elevation = params.stiffness_variation_over_elevation;
        linear.path_damping_nm_s_per_rad = params.path_damping_nm_s_per_rad;
        linear.turning_head_inertia_kg_m2 = params.turning_head_inertia_kg_m2;
        linear.elevation_structure_cross_inertia_kg_m2 = params.elevation_structure_cross_inertia_kg_m2;
        linear.elevation_structure_boresight_inertia_kg_m2 = params.elevation_structure_boresight_inertia_kg_m2;
        linear.numerics = params.numerics;
        return linear;
    }
    params
}

/// The azimuth plant FMU.
pub struct AzimuthPlantModel {
    plant: Option<AzimuthPlant>,
    /// The elevation input the feedthrough outputs were last computed for (bit pattern).
    feedthrough_elevation: Option<u64>,
}

impl AzimuthPlantModel {
    fn write_outputs(plant: &AzimuthPlant, v: &mut Values<AzVar>) {
        let o = plant.outputs();
        v.set_real(AzVar::EncoderPosition, o.encoder_position_deg);
        v.set_real(AzVar::EncoderError, o.encoder_error_arcsec);
        v.set_real(AzVar::AxisPosition, o.axis_position_deg);
        v.set_real(AzVar::AxisSpeed, o.axis_speed_deg_per_s);
        v.set_real(AzVar::Motor1Speed, o.motor_speed_rad_per_s[0]);
        v.set_real(AzVar::Motor2Speed, o.motor_speed_rad_per_s[1]);
        v.set_real(AzVar::Motor1Current, o.motor_current_a[0]);
        v.set_real(AzVar::Motor2Current, o.motor_current_a[1]);
        v.set_real(AzVar::Motor1Torque, o.motor_torque_nm[0]);
        v.set_real(AzVar::Motor2Torque, o.motor_torque_nm[1]);
        v.set_real(AzVar::Pinion1Torque, o.pinion_torque_nm[0]);
        v.set_real(AzVar::Pinion2Torque, o.pinion_torque_nm[1]);
        v.set_integer(AzVar::Pinion1Flank, o.pinion_flank[0]);
        v.set_integer(AzVar::Pinion2Flank, o.pinion_flank[1]);
    }

    /// The outputs that follow the elevation input, recomputed only when it changed.
    fn write_feedthrough(&mut self, v: &mut Values<AzVar>) {
        let elevation = v.real(AzVar::Elevation);
        if self.feedthrough_elevation == Some(elevation.to_bits()) {
            return;
        }
        let Some(plant) = &self.plant else { return };
        let params = plant.params();
        // What the dynamics use: the values at the centre of the elevation's parameter cell.
        let frozen = params.frozen_elevation_deg(elevation);
        v.set_real(AzVar::LoadInertia, params.axis_inertia_kg_m2(frozen));
        v.set_real(AzVar::AntiResonance, params.anti_resonance_hz(frozen));
        self.feedthrough_elevation = Some(elevation.to_bits());
    }

    fn build(v: &Values<AzVar>) -> Result<AzimuthPlant, PlantError> {
        let mut plant = AzimuthPlant::new(azimuth_params(v))?;
        plant.set_initial_state(v.real(AzVar::InitialPosition).to_radians())?;
        Ok(plant)
    }
}

impl Model for AzimuthPlantModel {
    type Var = AzVar;
    type Error = PlantFmuError;

    fn info() -> ModelInfo {
        model_info(
            "AzimuthPlant",
            "MeerKAT azimuth drive: two servo motors with 100 Hz current loops, each driving the load through its own compliant pinion path with backlash (two-mass model of the paper's Fig. 4 and corrected Eq. 1), friction, saturation and a quantised encoder. Load inertia follows the elevation input.",
        )
    }

    fn new(_values: &Values<AzVar>, _context: &Context) -> Result<Self, PlantFmuError> {
        Ok(AzimuthPlantModel { plant: None, feedthrough_elevation: None })
    }

    fn initialize(
        &mut self,
        values: &mut Values<AzVar>,
        _context: &Context,
        _notes: &mut Notes,
    ) -> Result<(), PlantFmuError> {
        let plant = Self::build(values)?;
        Self::write_outputs(&plant, values);
        self.plant = Some(plant);
        self.feedthrough_elevation = None;
        self.write_feedthrough(values);
        Ok(())
    }

    fn do_step(
        &mut self,
        values: &mut Values<AzVar>,
        _time: f64,
        step: f64,
        notes: &mut Notes,
    ) -> Result<(), PlantFmuError> {
        // Not `ok_or`: it would build the error at every step and drop it again.
        let Some(plant) = self.plant.as_mut() else { return Err(PlantFmuError::NotInitialised) };
        let inputs = AzimuthInputs {
            current_command_a: [values.real(AzVar::Current1Command), values.real(AzVar::Current2Command)],
            disturbance_torque_nm: values.real(AzVar::DisturbanceTorque),
            elevation_deg: values.real(AzVar::Elevation),
        };
        // The flanks before the step are read from the values: the previous step wrote them.
        let flanks_before = [values.integer(AzVar::Pinion1Flank), values.integer(AzVar::Pinion2Flank)];
        plant.step(&inputs, step)?;
        Self::write_outputs(plant, values);
        if notes.events_enabled() {
            let flanks = [values.integer(AzVar::Pinion1Flank), values.integer(AzVar::Pinion2Flank)];
            for k in 0..2 {
                if flanks[k] != flanks_before[k] {
                    notes.event(format!("pinion {} flank {} -> {}", k + 1, flanks_before[k], flanks[k]));
                }
            }
        }
        Ok(())
    }

    fn step_pieces(values: &Values<AzVar>, step: f64) -> (f64, &'static str) {
        let stribeck =
            [AzVar::BearingStribeck, AzVar::M1Stribeck, AzVar::M2Stribeck].iter().any(|&v| values.real(v) > 0.0);
        let torques = [AzVar::M1CoggingAmplitude, AzVar::M2CoggingAmplitude, AzVar::PeriodicAmplitude]
            .iter()
            .any(|&v| values.real(v) != 0.0);
        plant_step_pieces(
            step,
            values.real(AzVar::EventCheckInterval),
            values.real(AzVar::NonlinearSubstep),
            stribeck || torques,
        )
    }

    fn update_feedthrough(&mut self, values: &mut Values<AzVar>) {
        self.write_feedthrough(values);
    }

    fn string_changed(
        &mut self,
        var: AzVar,
        values: &mut Values<AzVar>,
        context: &Context,
    ) -> Result<(), PlantFmuError> {
        if var == AzVar::ParameterFile {
            fmu_runtime::params::load_file::<Self>(var, values, context)?;
        }
        Ok(())
    }

    /// The drive's state; none before initialisation.
    type State = Option<DriveState>;

    fn save_state(&self) -> Option<DriveState> {
        self.plant.as_ref().map(|plant| plant.save_state())
    }

    fn save_state_into(&self, state: &mut Option<DriveState>) {
        match (&self.plant, state.as_mut()) {
            (Some(plant), Some(kept)) => plant.save_state_into(kept),
            _ => *state = self.save_state(),
        }
    }

    fn load_state(&mut self, state: Option<DriveState>, values: &Values<AzVar>) -> Result<(), StateError> {
        self.plant = if let Some(state) = state {
            let mut plant = Self::build(values).map_err(StateError::model)?;
            plant.load_state(state)?;
            Some(plant)
        } else {
            None
        };
        self.feedthrough_elevation = None;
        Ok(())
    }
}
