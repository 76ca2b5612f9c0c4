//! The elevation plant as an FMI 2.0 co-simulation model: its variables and how they map onto
//! [`ElevationParams`], [`ElevationInputs`] and [`ElevationOutputs`].

use fmu_runtime::{Context, Model, ModelInfo, Notes, StateError, Values};

use super::PlantFmuError;
use crate::drivetrain::DriveState;
use crate::error::PlantError;

use super::common::{
    model_info, plant_step_pieces, plant_variables, sensor_text as T, FrictionVars, MotorVars, NumericsVars,
    SensorVars, MAX_AXIAL_DAMPING, MAX_AXIAL_STIFFNESS, MAX_CURRENT_LOOP_BANDWIDTH, MAX_SPEED_NOISE, MIN_MOTOR_INERTIA,
    TINY,
};
use super::common::{
    MAX_AXIAL_BACKLASH, MAX_COGGING, MAX_COGGING_PERIOD, MAX_CURRENT, MAX_GEAR_RATIO, MAX_GEOMETRY_LENGTH,
    MAX_LOAD_INERTIA, MAX_LOAD_TORQUE, MAX_MOTOR_FRICTION, MAX_MOTOR_INERTIA, MAX_MOTOR_VISCOUS, MAX_PATH_DAMPING,
    MAX_PERIOD_DEG, MAX_PHASE_DEG, MAX_SCREW_LEAD, MAX_STRIBECK_VELOCITY, MAX_TORQUE_CONSTANT,
    MAX_TORQUE_CONSTANT_SCALE,
};
use crate::params::{FrictionParams, PeriodicTorqueParams};
use crate::sensors::SensorParams;
use crate::{ElevationInputs, ElevationParams, ElevationPlant, JackscrewParams};

plant_variables! {
    /// Variables of the elevation plant FMU. Motor-side quantities are at the motor shaft;
    /// inertia and load torques are about the elevation axis; jackscrew quantities are axial.
    pub enum ElVar {
        own {
            // Inputs.
            CurrentCommand = Var::real("motor.current_command", "A").input().start(0.0).min(-MAX_CURRENT).max(MAX_CURRENT)
                .description("Current command to the elevation drive, before its current loop; clamped to motor.current_limit."),
            DisturbanceTorque = Var::real("load.disturbance_torque", "N.m").input().start(0.0).min(-MAX_LOAD_TORQUE).max(MAX_LOAD_TORQUE)
                .description("External torque about the elevation axis (wind); positive raises the dish."),
            // Outputs.
            EncoderPosition = Var::real("axis.encoder_position", "deg").output()
                .description("Elevation encoder reading (on the pivot): the true angle plus the encoder errors (encoder.*), counted to encoder.bits per turn as encoder.count_mode says."),
            AxisPosition = Var::real("axis.position", "deg").output().description("True elevation angle of the dish."),
            AxisSpeed = Var::real("axis.speed", "deg/s").output().description("Elevation speed of the dish."),
            MotorSpeed = Var::real("motor.speed", "rad/s").output().description("Speed signal of the elevation motor at its shaft: the true speed plus motor.speed_noise_rms noise (none by default)."),
            MotorCurrent = Var::real("motor.current", "A").output().description("Motor current (output of the current loop)."),
            MotorTorque = Var::real("motor.torque", "N.m").output().description("Electromagnetic motor torque, K_phi times the current."),
            DriveTorque = Var::real("drive.torque", "N.m").output().description("Torque the jackscrew puts on the dish about the elevation axis."),
            ScrewForce = Var::real("jackscrew.force", "N").output().description("Axial force in the jackscrew (positive pushes the dish up)."),
            Ratio = Var::real("drive.ratio", "1").output().description("Transmission ratio N(el) seen at the motor, motor rad per axis rad, at the current angle."),
            ActuatorLength = Var::real("jackscrew.length", "m").output().description("Length of the jackscrew actuator between its attachments."),
            AntiResonance = Var::real("drive.anti_resonance_frequency", "Hz").output()
                .description("Undamped anti-resonance sqrt(K_s/J_L)/(2 pi) of the drive at the current angle."),
            // Motor.
            MInertia = Var::real("motor.inertia", "kg.m2").parameter().start(0.002).min(MIN_MOTOR_INERTIA).max(MAX_MOTOR_INERTIA)
                .description("Inertia J_M of the motor with its gearbox input stage."),
            MViscous = Var::real("motor.viscous_friction", "N.m.s/rad").parameter().start(5.0e-4).min(0.0).max(MAX_MOTOR_VISCOUS)
                .description("Viscous friction B_M of motor and gearbox, at the motor."),
            MCoulomb = Var::real("motor.coulomb_friction", "N.m").parameter().start(0.15).min(0.0).max(MAX_MOTOR_FRICTION)
                .description("Sliding friction of motor and gearbox, at the motor."),
            MStatic = Var::real("motor.static_friction", "N.m").parameter().start(0.2).min(0.0).max(MAX_MOTOR_FRICTION)
                .description("Breakaway friction of motor and gearbox, at the motor (at least the sliding friction)."),
            MStribeck = Var::real("motor.stribeck_velocity", "rad/s").parameter().start(0.0).min(0.0).max(MAX_STRIBECK_VELOCITY)
                .description("Stribeck velocity of the motor friction; 0 switches the Stribeck curve off."),
            MAsymmetry = Var::real("motor.friction_asymmetry", "1").parameter().start(0.0).min(-0.99).max(0.99)
                .description("Direction asymmetry of the motor friction."),
            MTorqueConstant = Var::real("motor.torque_constant", "N.m/A").parameter().start(0.8).min(TINY).max(MAX_TORQUE_CONSTANT)
                .description("Torque constant K_phi."),
            MTorqueScale = Var::real("motor.torque_constant_scale", "1").parameter().start(1.0).min(TINY).max(MAX_TORQUE_CONSTANT_SCALE)
                .description("Multiplier on the torque constant (a torque-constant error); 1 is nominal."),
            MCurrentLimit = Var::real("motor.current_limit", "A").parameter().start(15.0).min(TINY).max(MAX_CURRENT)
                .description("Current limit: the command is clamped to +/- this."),
            MBandwidth = Var::real("motor.current_loop_bandwidth", "Hz").parameter().start(100.0).min(TINY).max(MAX_CURRENT_LOOP_BANDWIDTH)
                .description("Closed-loop bandwidth of the current loop (first-order lag)."),
            MDelay = Var::real("motor.command_delay", "s").parameter().start(0.0).min(0.0).max(1.0)
                .description("Pure time delay on the current command; 0 is off."),
            MCoggingAmplitude = Var::real("motor.cogging_amplitude", "N.m").parameter().start(0.0).min(-MAX_COGGING).max(MAX_COGGING)
                .description("Amplitude of the motor's cogging torque; 0 is off."),
            MCoggingPeriod = Var::real("motor.cogging_period", "1").parameter().start(1.0).min(1e-9).max(MAX_COGGING_PERIOD)
                .description("Period of the cogging torque in motor revolutions."),
            MCoggingPhase = Var::real("motor.cogging_phase", "deg").parameter().start(0.0).min(-MAX_PHASE_DEG).max(MAX_PHASE_DEG)
                .description("Phase of the cogging torque at motor angle 0."),
            // Jackscrew.
            DishRadius = Var::real("jackscrew.dish_attachment_radius", "m").parameter().start(2.0).min(TINY).max(MAX_GEOMETRY_LENGTH)
                .description("Distance from the elevation pivot to the actuator's attachment on the dish. With the other geometry parameters it must keep the lever arm and the nut on the screw over the whole travel."),
            YokeRadius = Var::real("jackscrew.yoke_attachment_radius", "m").parameter().start(3.6).min(TINY).max(MAX_GEOMETRY_LENGTH)
                .description("Distance from the elevation pivot to the actuator's trunnion on the yoke. With the other geometry parameters it must keep the lever arm and the nut on the screw over the whole travel."),
            AttachmentAngle = Var::real("jackscrew.attachment_angle_at_zero_elevation", "deg").parameter().start(20.0).min(-180.0).max(180.0)
                .description("Angle at the pivot between the two attachment radii at 0 deg elevation; it grows one-for-one with elevation."),
            Lead = Var::real("jackscrew.lead", "m").parameter().start(0.02).min(TINY).max(MAX_SCREW_LEAD)
                .description("Screw lead: nut travel per screw revolution."),
            GearboxRatio = Var::real("jackscrew.gearbox_ratio", "1").parameter().start(28.0).min(0.1).max(MAX_GEAR_RATIO)
                .description("Gearbox ratio between motor and screw, motor revolutions per screw revolution. At least 0.1: the screw's stiffness and damping reach the motor divided by its square, and near 1e-3 the drive would become faster than the 1e10 1/s its discretisation resolves."),
            ScrewLength = Var::real("jackscrew.length_between_bearings", "m").parameter().start(3.5).min(TINY).max(MAX_GEOMETRY_LENGTH)
                .description("Length of screw between its two axial bearings. With the other geometry parameters it must keep the nut on the screw over the whole travel."),
            NutOffset = Var::real("jackscrew.nut_offset", "m").parameter().start(1.57).min(-MAX_GEOMETRY_LENGTH).max(MAX_GEOMETRY_LENGTH)
                .description("Actuator length minus the nut's distance from the first bearing."),
            AxialRigidity = Var::real("jackscrew.axial_rigidity", "N").parameter().start(1.65e9).min(TINY).max(MAX_AXIAL_STIFFNESS)
                .description("Axial rigidity E A of the screw's root section."),
            FixedBothEnds = Var::boolean("jackscrew.fixed_at_both_ends").parameter().start_boolean(true)
                .description("True if the screw is held axially at both ends (both segments carry load in parallel)."),
            SeriesStiffness = Var::real("jackscrew.series_stiffness", "N/m").parameter().start(5.0e9).min(TINY).max(MAX_AXIAL_STIFFNESS)
                .description("Axial stiffness of everything in series with the screw (bearings, nut, housing, trunnion)."),
            AxialDamping = Var::real("jackscrew.axial_damping", "N.s/m").parameter().start(1.4e6).min(0.0).max(MAX_AXIAL_DAMPING)
                .description("Axial damping of the drive path. With axial backlash it must be positive, and large enough that the fastest rate stays below 1e10 1/s."),
            AxialBacklash = Var::real("jackscrew.axial_backlash", "m").parameter().start(0.0).min(0.0).max(MAX_AXIAL_BACKLASH)
                .description("Axial free play of the nut; 0 for the preloaded nut."),
            ScrewCoulomb = Var::real("jackscrew.coulomb_friction", "N.m").parameter().start(8.0).min(0.0).max(MAX_MOTOR_FRICTION)
                .description("Sliding friction of the preloaded nut and screw bearings, at the screw."),
            ScrewStatic = Var::real("jackscrew.static_friction", "N.m").parameter().start(10.0).min(0.0).max(MAX_MOTOR_FRICTION)
                .description("Breakaway friction of the preloaded nut and screw bearings, at the screw (at least the sliding friction)."),
            ScrewStribeck = Var::real("jackscrew.stribeck_velocity", "rad/s").parameter().start(0.0).min(0.0).max(MAX_STRIBECK_VELOCITY)
                .description("Stribeck velocity of the screw friction (screw speed); 0 switches the curve off."),
            ScrewAsymmetry = Var::real("jackscrew.friction_asymmetry", "1").parameter().start(0.0).min(-0.99).max(0.99)
                .description("Direction asymmetry of the screw friction (raising versus lowering)."),
            // Load.
            DishInertia = Var::real("load.inertia", "kg.m2").parameter().start(3.5e5).min(1.0).max(MAX_LOAD_INERTIA)
                .description("Inertia of the elevation structure about the elevation axis (constant: the dish is balanced about the pivot). At least 1 kg m2, far below any dish; near 1e-4 kg m2 the drive would become faster than the 1e10 1/s its discretisation resolves."),
            PivotCoulomb = Var::real("pivot.coulomb_friction", "N.m").parameter().start(500.0).min(0.0).max(MAX_LOAD_TORQUE)
                .description("Sliding friction of the elevation pivot bearings, about the axis."),
            PivotStatic = Var::real("pivot.static_friction", "N.m").parameter().start(650.0).min(0.0).max(MAX_LOAD_TORQUE)
                .description("Breakaway friction of the elevation pivot bearings, about the axis (at least the sliding friction)."),
            PivotStribeck = Var::real("pivot.stribeck_velocity", "rad/s").parameter().start(0.0).min(0.0).max(MAX_STRIBECK_VELOCITY)
                .description("Stribeck velocity of the pivot friction; 0 switches the curve off."),
            PivotAsymmetry = Var::real("pivot.friction_asymmetry", "1").parameter().start(0.0).min(-0.99).max(0.99)
                .description("Direction asymmetry of the pivot friction."),
            PivotViscous = Var::real("pivot.viscous_friction", "N.m.s/rad").parameter().start(0.0).min(0.0).max(MAX_PATH_DAMPING)
                .description("Viscous friction of the pivot bearings about the axis (0 in the paper's model)."),
            UnbalanceMoment = Var::real("load.unbalance_moment", "N.m").parameter().start(0.0).min(-MAX_LOAD_TORQUE).max(MAX_LOAD_TORQUE)
                .description("Gravity unbalance m g r; the torque is -m g r cos(el + phase) (positive: nose-heavy). 0 is balanced, as designed."),
            UnbalancePhase = Var::real("load.unbalance_phase", "deg").parameter().start(0.0).min(-MAX_PHASE_DEG).max(MAX_PHASE_DEG)
                .description("Phase of the unbalance torque."),
            TorqueOffset = Var::real("load.torque_offset", "N.m").parameter().start(0.0).min(-MAX_LOAD_TORQUE).max(MAX_LOAD_TORQUE)
                .description("Constant torque on the load about the axis; 0 is off."),
            PeriodicAmplitude = Var::real("load.periodic_torque_amplitude", "N.m").parameter().start(0.0).min(-MAX_LOAD_TORQUE).max(MAX_LOAD_TORQUE)
                .description("Amplitude of a torque on the load that repeats with the elevation angle; 0 is off."),
            PeriodicPeriod = Var::real("load.periodic_torque_period", "deg").parameter().start(360.0).min(1e-6).max(MAX_PERIOD_DEG)
                .description("Period of the position-periodic load torque in axis degrees."),
            PeriodicPhase = Var::real("load.periodic_torque_phase", "deg").parameter().start(0.0).min(-MAX_PHASE_DEG).max(MAX_PHASE_DEG)
                .description("Phase of the position-periodic load torque at elevation 0."),
            TravelMin = Var::real("travel.min", "deg").parameter().start(15.0).min(-90.0).max(180.0)
                .description("Lower end of travel; angle-dependent parameters are held at their end values beyond it (no end stops are modelled)."),
            TravelMax = Var::real("travel.max", "deg").parameter().start(92.0).min(-90.0).max(180.0)
                .description("Upper end of travel."),
            GeometryFrozen = Var::boolean("geometry.frozen").parameter().start_boolean(false)
                .description("Freeze ratio, stiffness, reflected inertia and kinematics at geometry.frozen_elevation: the axis is then linear time-invariant."),
            FrozenElevation = Var::real("geometry.frozen_elevation", "deg").parameter().start(15.0).min(-90.0).max(180.0)
                .description("Elevation at which the geometry is frozen when geometry.frozen (or linear_configuration) is set."),
            // Sensing, configuration and numerics.
            EncoderBits = Var::integer("encoder.bits").parameter().start_integer(25).range_integer(0, 40)
                .description("Resolution of the elevation encoder in bits per turn; 0 means unquantised."),
            InitialPosition = Var::real("initial_position", "deg").parameter().start(45.0).min(0.0).max(100.0)
                .description("Elevation at which the axis starts, at rest."),
            Linear = Var::boolean("linear_configuration").parameter().start_boolean(false)
                .description("If true, the plant is exactly the paper's linear Eq. 1 model at geometry.frozen_elevation: friction (except B_M), backlash, saturation, delay, cogging, extra torques and quantisation and all sensor errors are ignored."),
            ParameterFile = Var::string("parameter_file").parameter().start_string("")
                .description("A parameter file (name = value lines) applied when this is set; relative paths are looked up in the FMU's resources folder (for example linear.params)."),
            GridCell = Var::real("numerics.parameter_grid_cell", "deg").parameter().start(0.25).min(1e-6).max(10.0)
                .description("Elevation cell within which stiffness, ratio and reflected inertia are frozen (error measured in docs/plant-model.md)."),
            NonlinearSubstep = Var::real("numerics.nonlinear_substep", "s").parameter().start(1e-4).min(1e-7).max(1.0)
                .description("Internal sub-step over which Stribeck, cogging, unbalance and periodic torques are held constant (used only when those are on)."),
            EventResolution = Var::real("numerics.event_time_resolution", "s").parameter().start(1e-6).min(1e-9).max(1e-3)
                .description("Time resolution to which stick/slip events are localised."),
            EventCheckInterval = Var::real("numerics.event_check_interval", "s").parameter().start(1e-3).min(1e-6).max(1.0)
                .description("Longest interval between checks for mode switches, at least numerics.event_time_resolution; longer communication steps are cut into pieces (at 1e-6 s a 1 ms step is already 1000 of them)."),
            CacheCapacity = Var::integer("numerics.cache_capacity").parameter().start_integer(64).range_integer(8, 4096)
                .description("Discretisations kept per cache generation (memory stays bounded whatever the step sizes)."),
            // Sensors (appended: existing value references keep their numbers). Every default is the
            // ideal encoder and noise-free speed signals, which reproduce the plant before the sensor model.
        }
        speed_noise {
            MSpeedNoise = Var::real("motor.speed_noise_rms", "rad/s").parameter().start(0.0).min(0.0).max(MAX_SPEED_NOISE)
                .description(T::SPEED_NOISE),
        }
        more {
        }
    }
}

const MOTOR: MotorVars<ElVar> = MotorVars {
    inertia: ElVar::MInertia,
    viscous_friction: ElVar::MViscous,
    coulomb_friction: ElVar::MCoulomb,
    static_friction: ElVar::MStatic,
    stribeck_velocity: ElVar::MStribeck,
    friction_asymmetry: ElVar::MAsymmetry,
    torque_constant: ElVar::MTorqueConstant,
    torque_constant_scale: ElVar::MTorqueScale,
    current_limit: ElVar::MCurrentLimit,
    current_loop_bandwidth: ElVar::MBandwidth,
    command_delay: ElVar::MDelay,
    cogging_amplitude: ElVar::MCoggingAmplitude,
    cogging_period: ElVar::MCoggingPeriod,
    cogging_phase: ElVar::MCoggingPhase,
    presliding_stiffness: None,
    presliding_damping: None,
};

const SCREW: FrictionVars<ElVar> = FrictionVars {
    coulomb: ElVar::ScrewCoulomb,
    static_: ElVar::ScrewStatic,
    stribeck_velocity: ElVar::ScrewStribeck,
    asymmetry: ElVar::ScrewAsymmetry,
};

const PIVOT: FrictionVars<ElVar> = FrictionVars {
    coulomb: ElVar::PivotCoulomb,
    static_: ElVar::PivotStatic,
    stribeck_velocity: ElVar::PivotStribeck,
    asymmetry: ElVar::PivotAsymmetry,
};

const NUMERICS: NumericsVars<ElVar> = NumericsVars {
    grid_cell: ElVar::GridCell,
    nonlinear_substep: ElVar::NonlinearSubstep,
    event_resolution: ElVar::EventResolution,
    event_check_interval: ElVar::EventCheckInterval,
    cache_capacity: ElVar::CacheCapacity,
};

const SENSORS: SensorVars<ElVar, 1> = SensorVars {
    count_mode: ElVar::EncoderCountMode,
    count_mode_number: ElVar::EncoderCountModeNumber,
    graduation: [
        (ElVar::Graduation1Amplitude, ElVar::Graduation1Harmonic, ElVar::Graduation1Phase),
        (ElVar::Graduation2Amplitude, ElVar::Graduation2Harmonic, ElVar::Graduation2Phase),
        (ElVar::Graduation3Amplitude, ElVar::Graduation3Harmonic, ElVar::Graduation3Phase),
    ],
    line_count: ElVar::LineCount,
    interpolation: [
        (ElVar::Interpolation1Amplitude, ElVar::Interpolation1Phase),
        (ElVar::Interpolation2Amplitude, ElVar::Interpolation2Phase),
    ],
    eccentricity: (ElVar::EccentricityAmplitude, ElVar::EccentricityPhase),
    encoder_noise: ElVar::EncoderNoise,
    speed_noise: [ElVar::MSpeedNoise],
    seed: ElVar::SensorSeed,
    sample_period: ElVar::SensorSamplePeriod,
};

/// The plant parameters the variable values describe.
pub fn elevation_params(v: &Values<ElVar>) -> ElevationParams {
    let linear = v.boolean(ElVar::Linear);
    let mut params = ElevationParams {
        motor: MOTOR.read(v),
        jackscrew: JackscrewParams {
            dish_attachment_radius_m: v.real(ElVar::DishRadius),
            yoke_attachment_radius_m: v.real(ElVar::YokeRadius),
            attachment_angle_at_zero_elevation_deg: v.real(ElVar::AttachmentAngle),
            screw_lead_m: v.real(ElVar::Lead),
            gearbox_ratio: v.real(ElVar::GearboxRatio),
            screw_length_between_bearings_m: v.real(ElVar::ScrewLength),
            nut_offset_m: v.real(ElVar::NutOffset),
            screw_axial_rigidity_n: v.real(ElVar::AxialRigidity),
            screw_fixed_at_both_ends: v.boolean(ElVar::FixedBothEnds),
            series_stiffness_n_per_m: v.real(ElVar::SeriesStiffness),
            axial_damping_n_s_per_m: v.real(ElVar::AxialDamping),
            axial_backlash_m: v.real(ElVar::AxialBacklash),
            screw_friction: SCREW.read(v),
        },
        dish_inertia_kg_m2: v.real(ElVar::DishInertia),
        pivot_friction: PIVOT.read(v),
        pivot_viscous_friction_nm_s_per_rad: v.real(ElVar::PivotViscous),
        unbalance_moment_nm: v.real(ElVar::UnbalanceMoment),
        unbalance_phase_deg: v.real(ElVar::UnbalancePhase),
        torque_offset_nm: v.real(ElVar::TorqueOffset),
        periodic_torque: PeriodicTorqueParams {
            amplitude_nm: v.real(ElVar::PeriodicAmplitude),
            period_deg: v.real(ElVar::PeriodicPeriod),
            phase_deg: v.real(ElVar::PeriodicPhase),
        },
        travel_min_deg: v.real(ElVar::TravelMin),
        travel_max_deg: v.real(ElVar::TravelMax),
        geometry_frozen: v.boolean(ElVar::GeometryFrozen),
        frozen_geometry_elevation_deg: v.real(ElVar::FrozenElevation),
        encoder_bits: v.integer(ElVar::EncoderBits) as u32,
        sensors: SENSORS.read(v),
        numerics: NUMERICS.read(v),
    };
    if linear {
        // Eq. 1 has the viscous motor friction B_M and nothing else that is nonlinear or
        // time-varying: keep the master's linear parameters, drop the rest.
        params.motor = params.motor.linearised();
        params.jackscrew.axial_backlash_m = 0.0;
        params.jackscrew.screw_friction = FrictionParams::NONE;
        params.pivot_friction = FrictionParams::NONE;
        params.pivot_viscous_friction_nm_s_per_rad = 0.0;
        params.unbalance_moment_nm = 0.0;
        params.torque_offset_nm = 0.0;
        params.periodic_torque = PeriodicTorqueParams::NONE;
        params.geometry_frozen = true;
        params.encoder_bits = 0;
        params.sensors = SensorParams::default();
    }
    params
}

/// The elevation plant FMU.
pub struct ElevationPlantModel {
    plant: Option<ElevationPlant>,
}

impl ElevationPlantModel {
    fn write_outputs(plant: &ElevationPlant, v: &mut Values<ElVar>) {
        let o = plant.outputs();
        v.set_real(ElVar::EncoderPosition, o.encoder_position_deg);
        v.set_real(ElVar::EncoderError, o.encoder_error_arcsec);
        v.set_real(ElVar::AxisPosition, o.axis_position_deg);
        v.set_real(ElVar::AxisSpeed, o.axis_speed_deg_per_s);
        v.set_real(ElVar::MotorSpeed, o.motor_speed_rad_per_s);
        v.set_real(ElVar::MotorCurrent, o.motor_current_a);
        v.set_real(ElVar::MotorTorque, o.motor_torque_nm);
        v.set_real(ElVar::DriveTorque, o.drive_torque_nm);
        v.set_real(ElVar::ScrewForce, o.screw_force_n);
        v.set_real(ElVar::Ratio, o.transmission_ratio);
        v.set_real(ElVar::ActuatorLength, o.actuator_length_m);
        // The drive the simulation uses now: frozen at the centre of the current elevation cell,
        // or at the frozen angle with a frozen geometry.
        v.set_real(ElVar::AntiResonance, plant.two_mass_in_use().anti_resonance_hz());
    }

    fn build(v: &Values<ElVar>) -> Result<ElevationPlant, PlantError> {
        let mut plant = ElevationPlant::new(elevation_params(v))?;
        plant.set_initial_state(v.real(ElVar::InitialPosition).to_radians())?;
        Ok(plant)
    }
}

impl Model for ElevationPlantModel {
    type Var = ElVar;
    type Error = PlantFmuError;

    fn info() -> ModelInfo {
        model_info(
            "ElevationPlant",
            "MeerKAT elevation drive: one servo motor with a 100 Hz current loop driving the balanced dish through a preloaded jackscrew whose length, stiffness and transmission ratio vary with elevation (two-mass model of the paper's Fig. 4 and corrected Eq. 1), with friction, saturation and a quantised encoder.",
        )
    }

    fn new(_values: &Values<ElVar>, _context: &Context) -> Result<Self, PlantFmuError> {
        Ok(ElevationPlantModel { plant: None })
    }

    fn initialize(
        &mut self,
        values: &mut Values<ElVar>,
        _context: &Context,
        _notes: &mut Notes,
    ) -> Result<(), PlantFmuError> {
        let plant = Self::build(values)?;
        Self::write_outputs(&plant, values);
        self.plant = Some(plant);
        Ok(())
    }

    fn do_step(
        &mut self,
        values: &mut Values<ElVar>,
        _time: f64,
        step: f64,
        _notes: &mut Notes,
    ) -> Result<(), PlantFmuError> {
        // Not `ok_or`: it would build the error at every step and drop it again.
        let Some(plant) = self.plant.as_mut() else { return Err(PlantFmuError::NotInitialised) };
        let inputs = ElevationInputs {
            current_command_a: values.real(ElVar::CurrentCommand),
            disturbance_torque_nm: values.real(ElVar::DisturbanceTorque),
        };
        plant.step(&inputs, step)?;
        Self::write_outputs(plant, values);
        Ok(())
    }

    fn step_pieces(values: &Values<ElVar>, step: f64) -> (f64, &'static str) {
        let stribeck =
            [ElVar::MStribeck, ElVar::ScrewStribeck, ElVar::PivotStribeck].iter().any(|&v| values.real(v) > 0.0);
        let torques = [ElVar::MCoggingAmplitude, ElVar::PeriodicAmplitude, ElVar::UnbalanceMoment]
            .iter()
            .any(|&v| values.real(v) != 0.0);
        plant_step_pieces(
            step,
            values.real(ElVar::EventCheckInterval),
            values.real(ElVar::NonlinearSubstep),
            stribeck || torques,
        )
    }

    fn string_changed(
        &mut self,
        var: ElVar,
        values: &mut Values<ElVar>,
        context: &Context,
    ) -> Result<(), PlantFmuError> {
        if var == ElVar::ParameterFile {
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

    fn load_state(&mut self, state: Option<DriveState>, values: &Values<ElVar>) -> Result<(), StateError> {
        self.plant = if let Some(state) = state {
            let mut plant = Self::build(values).map_err(StateError::model)?;
            plant.load_state(state)?;
            Some(plant)
        } else {
            None
        };
        Ok(())
    }
}
