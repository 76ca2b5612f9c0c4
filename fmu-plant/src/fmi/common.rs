//! Pieces shared by the two plant FMUs: motor and friction parameter groups read from the
//! variable values, the sensor parameters, the parameter-file hook and the model information.

use fmu_runtime::{DefaultExperiment, EnumerationType, ModelInfo, Values, VariableSet};

use crate::params::{CoggingParams, FrictionParams, MotorParams, NumericsParams};
use crate::sensors::{CountMode, EncoderErrors, PeriodicError, SensorParams};
use fmu_runtime::seed::seed_from_fmi_integer;

// Declared bounds. FMI 2.0 bounds are inclusive, so a parameter that must be positive cannot
// declare min = 0 (which the plant would then refuse): it declares the bound below. Upper
// bounds keep each parameter, varied alone from the defaults, far inside the range where the
// exact discretisation is accurate (fastest rate at most 1e10 1/s, docs/plant-model.md
// section 7): the audit found that 1e308 N m/rad, 1e308 N m s/rad or 1e300 Hz, then within
// the declared ranges, gave NaN outputs. Combinations of extremes are refused at
// initialisation with the rate named.

/// Declared minimum of a parameter that must be positive and has no smaller meaningful bound
/// (a torque constant, a current limit, a length): any positive value works, so the bound only
/// says "greater than 0" in terms a master can read.
pub const TINY: f64 = 1e-9;

/// Smallest motor inertia, kg m^2: the rotor of the smallest servo motors. With the largest
/// path damping the fastest rate is then 1.2e7 1/s, three decades inside the plant's bound.
pub const MIN_MOTOR_INERTIA: f64 = 1e-6;

/// Largest path stiffness about the azimuth axis, N m/rad: 137 times the default, an
/// anti-resonance near 260 Hz, which no drive of a 13.5 m dish reaches.
pub const MAX_PATH_STIFFNESS: f64 = 1e12;

/// Largest path damping about the azimuth axis, N m s/rad: 190 times the default, an
/// anti-resonance damped some ten times beyond critical.
pub const MAX_PATH_DAMPING: f64 = 1e9;

/// Largest current-loop bandwidth, Hz: 100 times the default and above the switching
/// frequency of servo amplifiers, which bounds any real current loop.
pub const MAX_CURRENT_LOOP_BANDWIDTH: f64 = 1e4;

/// Largest axial stiffness of the jackscrew parts, N/m (and N for the rigidity E A): 200 to 600
/// times the defaults, the rigidity of a steel bar of 5 m^2 section.
pub const MAX_AXIAL_STIFFNESS: f64 = 1e12;

/// Largest axial damping of the jackscrew, N s/m: 700 times the default.
pub const MAX_AXIAL_DAMPING: f64 = 1e9;

// Bounds added so that every parameter and input has a declared range that says what is
// physical (docs/fmu-robustness.md): each is far beyond any drive of a 13-15 m dish, so no real
// configuration meets it, and near enough that no value inside it is a denormal or 1e308
// stand-in that would overflow the arithmetic. Each was run at its bound, varied alone from
// the defaults (the tests of `super`).

/// Largest current command or current limit, A: ten kiloamperes, a hundred times the servo
/// drives of a radio telescope.
pub const MAX_CURRENT: f64 = 1e4;

/// Largest external or internal load torque about an axis, N m (disturbance input, torque
/// offset, periodic and unbalance torques, bearing friction): 1e8 N m, some hundred times the
/// survival wind torque of a 13.5 m dish (estimate, order 1e6 N m).
pub const MAX_LOAD_TORQUE: f64 = 1e8;

/// Largest gear or gearbox ratio.
pub const MAX_GEAR_RATIO: f64 = 1e6;

/// Largest backlash of a pinion, arcsec (one degree).
pub const MAX_BACKLASH_ARCSEC: f64 = 3600.0;

/// Largest load inertia about an axis, kg m^2: a thousand times the MeerKAT dish's.
pub const MAX_LOAD_INERTIA: f64 = 1e9;

/// Largest motor inertia, kg m^2: ten times the rotor of the largest servo motors.
pub const MAX_MOTOR_INERTIA: f64 = 10.0;

/// Largest Stribeck velocity, rad/s.
pub const MAX_STRIBECK_VELOCITY: f64 = 1e3;

/// Largest viscous friction of a motor, N m s/rad.
pub const MAX_MOTOR_VISCOUS: f64 = 10.0;

/// Largest friction torque at a motor or screw, N m.
pub const MAX_MOTOR_FRICTION: f64 = 1e3;

/// Largest torque constant, N m/A, and largest scale of it.
pub const MAX_TORQUE_CONSTANT: f64 = 100.0;
pub const MAX_TORQUE_CONSTANT_SCALE: f64 = 10.0;

/// Largest cogging torque amplitude, N m (either sign), and cogging period (per motor turn).
pub const MAX_COGGING: f64 = 1e3;
pub const MAX_COGGING_PERIOD: f64 = 1e6;

/// Largest phase either way, deg: ten turns, so that a phase fitted without wrapping (the
/// validation tool's) still fits; any phase has an equal one within one turn.
pub const MAX_PHASE_DEG: f64 = 3600.0;

/// Longest period of a position-periodic load torque, deg (ten turns).
pub const MAX_PERIOD_DEG: f64 = 3600.0;

/// Largest length of the elevation drive's geometry, m (radii, screw length, nut offset).
pub const MAX_GEOMETRY_LENGTH: f64 = 100.0;

/// Largest screw lead, m per revolution.
pub const MAX_SCREW_LEAD: f64 = 1.0;

/// Largest axial free play of the nut, m.
pub const MAX_AXIAL_BACKLASH: f64 = 0.1;

/// The value references of one motor's parameters.
pub struct MotorVars<V> {
    pub inertia: V,
    pub viscous_friction: V,
    pub coulomb_friction: V,
    pub static_friction: V,
    pub stribeck_velocity: V,
    pub friction_asymmetry: V,
    pub torque_constant: V,
    pub torque_constant_scale: V,
    pub current_limit: V,
    pub current_loop_bandwidth: V,
    pub command_delay: V,
    pub cogging_amplitude: V,
    pub cogging_period: V,
    pub cogging_phase: V,
    /// The presliding element (the azimuth motors have one; None reads as a rigid stick).
    pub presliding_stiffness: Option<V>,
    pub presliding_damping: Option<V>,
}

impl<V: VariableSet> MotorVars<V> {
    pub fn read(&self, v: &Values<V>) -> MotorParams {
        MotorParams {
            inertia_kg_m2: v.real(self.inertia),
            viscous_friction_nm_s_per_rad: v.real(self.viscous_friction),
            friction: FrictionParams {
                coulomb_nm: v.real(self.coulomb_friction),
                static_nm: v.real(self.static_friction),
                stribeck_velocity_rad_per_s: v.real(self.stribeck_velocity),
                asymmetry: v.real(self.friction_asymmetry),
            },
            torque_constant_nm_per_a: v.real(self.torque_constant),
            torque_constant_scale: v.real(self.torque_constant_scale),
            current_limit_a: v.real(self.current_limit),
            current_loop_bandwidth_hz: v.real(self.current_loop_bandwidth),
            current_command_delay_s: v.real(self.command_delay),
            cogging: CoggingParams {
                amplitude_nm: v.real(self.cogging_amplitude),
                period_motor_revolutions: v.real(self.cogging_period),
                phase_deg: v.real(self.cogging_phase),
            },
            presliding_stiffness_nm_per_rad: self.presliding_stiffness.map_or(0.0, |r| v.real(r)),
            presliding_damping_nm_s_per_rad: self.presliding_damping.map_or(0.0, |r| v.real(r)),
        }
    }
}

/// The value references of a Coulomb/static/Stribeck friction element.
pub struct FrictionVars<V> {
    pub coulomb: V,
    pub static_: V,
    pub stribeck_velocity: V,
    pub asymmetry: V,
}

impl<V: VariableSet> FrictionVars<V> {
    pub fn read(&self, v: &Values<V>) -> FrictionParams {
        FrictionParams {
            coulomb_nm: v.real(self.coulomb),
            static_nm: v.real(self.static_),
            stribeck_velocity_rad_per_s: v.real(self.stribeck_velocity),
            asymmetry: v.real(self.asymmetry),
        }
    }
}

/// The value references of the numerical-scheme settings.
pub struct NumericsVars<V> {
    pub grid_cell: V,
    pub nonlinear_substep: V,
    pub event_resolution: V,
    pub event_check_interval: V,
    pub cache_capacity: V,
}

impl<V: VariableSet> NumericsVars<V> {
    pub fn read(&self, v: &Values<V>) -> NumericsParams {
        NumericsParams {
            parameter_grid_cell_deg: v.real(self.grid_cell),
            nonlinear_substep_s: v.real(self.nonlinear_substep),
            event_time_resolution_s: v.real(self.event_resolution),
            event_check_interval_s: v.real(self.event_check_interval),
            cache_capacity: v.integer(self.cache_capacity) as usize,
        }
    }
}

/// The work of a plant step of `step` seconds in pieces (what the drive train cuts a step
/// into): pieces of at most `numerics.event_check_interval`, and of at most
/// `numerics.nonlinear_substep` when torques that are not piecewise linear are on (cogging,
/// periodic or unbalance torques, a Stribeck curve; `needs_substeps`).
pub fn plant_step_pieces(
    step: f64,
    event_check_interval: f64,
    substep: f64,
    needs_substeps: bool,
) -> (f64, &'static str) {
    if needs_substeps {
        (
            (step / substep.min(event_check_interval)).ceil(),
            "pieces of numerics.nonlinear_substep, with cogging, periodic or unbalance torques or a Stribeck curve on",
        )
    } else {
        ((step / event_check_interval).ceil(), "pieces of numerics.event_check_interval")
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

/// How the encoder counts (`encoder.count_mode`).
pub static COUNT_MODE: EnumerationType = EnumerationType {
    name: "EncoderCountMode",
    description: "How the encoder turns an angle into whole counts.",
    items: &[
        (
            "truncate",
            "Round down to whole counts: mean error minus half a count (the behaviour before the sensor model).",
        ),
        ("round", "Round to the nearest count: mean error zero."),
    ],
};

/// Descriptions shared by the two plants' sensor variables (one text, two tables).
pub mod sensor_text {
    pub const COUNT_MODE_NUMBER: &str = "encoder.count_mode as an Integer, for masters that ignore FMI enumerations (libcosim and ecos do): 1 truncate, 2 round; 0 (the default) leaves the choice to encoder.count_mode. When it is not 0 it wins.";
    pub const ENCODER_ERROR: &str =
        "Encoder reading minus true axis angle: the sum of the encoder's errors and its count, for an error budget.";
    pub const GRADUATION_AMPLITUDE: &str = "Amplitude of one harmonic of the graduation error A sin(n theta + phi) of the encoder ring (theta the true axis angle); 0 is off. Heidenhain ring encoders: graduation accuracy +/-1.5 to +/-1.9 arcsec (docs/plant-model.md, Sensors).";
    pub const GRADUATION_HARMONIC: &str = "Harmonic number n of this graduation error, cycles per turn: its period is 360 deg / n (n = encoder.line_count for an error at the line spacing).";
    pub const GRADUATION_PHASE: &str = "Phase phi of this graduation error at axis angle 0.";
    pub const LINE_COUNT: &str =
        "Signal periods (lines) of the encoder per turn: the interpolation error repeats every 360 deg / this.";
    pub const INTERPOLATION1_AMPLITUDE: &str = "Amplitude of the interpolation error at the signal period (360 deg / encoder.line_count), from signal offsets; 0 is off. Heidenhain: about 1 % of the signal period.";
    pub const INTERPOLATION2_AMPLITUDE: &str = "Amplitude of the interpolation error at half the signal period, from amplitude and phase mismatch of the two signals; 0 is off.";
    pub const INTERPOLATION_PHASE: &str =
        "Phase of this interpolation error at axis angle 0, in degrees of its own cycle.";
    pub const ECCENTRICITY_AMPLITUDE: &str = "Amplitude of the once-per-revolution error of a graduation mounted off the axis by e: 412 e/D arcsec with e in um and the graduation diameter D in mm (single read head); 0 is off.";
    pub const ECCENTRICITY_PHASE: &str = "Phase of the eccentricity error at axis angle 0.";
    pub const ENCODER_NOISE: &str = "RMS of the encoder's white reading noise, one Gaussian sample per sensors.sample_period (held in between), reproducible from sensors.seed; 0 is off.";
    pub const SPEED_NOISE: &str = "RMS of the white noise on this motor's speed signal (the speed output the controller reads), at the motor, one Gaussian sample per sensors.sample_period, reproducible from sensors.seed; 0 is off.";
    pub const SEED: &str = "Seed of the sensors' noise sequences: the same seed gives the same noise whatever the communication step size.";
    pub const SAMPLE_PERIOD: &str = "Sample period of the sensors' noise: each sample is held this long, independent of the communication step (default: the controller's 1 ms).";
}

/// Largest encoder error amplitude or noise RMS, arcsec: one degree, far beyond any working
/// angle encoder.
pub const MAX_ENCODER_ERROR_ARCSEC: f64 = 3600.0;

/// Largest speed-signal noise RMS, rad/s at the motor (about 10^4 rpm).
pub const MAX_SPEED_NOISE: f64 = 1000.0;

/// The value references of an axis's sensor parameters (`P` motors).
pub struct SensorVars<V, const P: usize> {
    pub count_mode: V,
    /// The same setting as an Integer, for masters that ignore enumerations (0: as
    /// `count_mode` says).
    pub count_mode_number: V,
    /// Amplitude, harmonic number and phase of each graduation harmonic.
    pub graduation: [(V, V, V); 3],
    pub line_count: V,
    /// Amplitude and phase of the interpolation error at the signal period and at half of it.
    pub interpolation: [(V, V); 2],
    pub eccentricity: (V, V),
    pub encoder_noise: V,
    pub speed_noise: [V; P],
    pub seed: V,
    pub sample_period: V,
}

impl<V: VariableSet, const P: usize> SensorVars<V, P> {
    pub fn read(&self, v: &Values<V>) -> SensorParams<P> {
        let periodic = |amplitude: V, cycles: f64, phase: V| PeriodicError {
            amplitude_arcsec: v.real(amplitude),
            cycles_per_turn: cycles,
            phase_deg: v.real(phase),
        };
        let lines = f64::from(v.integer(self.line_count));
        SensorParams {
            encoder: EncoderErrors {
                count_mode: CountMode::from_index(match v.integer(self.count_mode_number) {
                    0 => v.integer(self.count_mode),
                    number => number,
                })
                .unwrap_or_default(),
                graduation: self.graduation.map(|(a, n, p)| periodic(a, f64::from(v.integer(n)), p)),
                interpolation: [0, 1].map(|k| {
                    let (a, p) = self.interpolation[k];
                    periodic(a, (k + 1) as f64 * lines, p)
                }),
                eccentricity: periodic(self.eccentricity.0, 1.0, self.eccentricity.1),
                noise_rms_arcsec: v.real(self.encoder_noise),
            },
            motor_speed_noise_rms_rad_per_s: self.speed_noise.map(|n| v.real(n)),
            seed: seed_from_fmi_integer(v.integer(self.seed)),
            sample_period_s: v.real(self.sample_period),
        }
    }
}

/// Declares a plant's variable table with the sensor variables both axes share written here once
/// (the encoder's errors, counting and noise, the sensors' seed and sample period, the count
/// mode's Integer twin). The groups keep every value reference where it was when the sensor model
/// was appended to each table: the axis's `own` variables, the shared encoder block, the axis's
/// `speed_noise` variables (one per motor), the seed and sample period, `more` of the axis's own,
/// and the Integer twin last.
macro_rules! plant_variables {
    ($(#[$meta:meta])* pub enum $name:ident {
        own { $($own:tt)* }
        speed_noise { $($speed_noise:tt)* }
        more { $($more:tt)* }
    }) => {
        fmu_runtime::declare_variables! {
            $(#[$meta])*
            pub enum $name {
                $($own)*
                EncoderError = Var::real("axis.encoder_error", "arcsec").output().description($crate::fmi::common::sensor_text::ENCODER_ERROR),
                EncoderCountMode = Var::enumeration("encoder.count_mode", &$crate::fmi::common::COUNT_MODE).parameter().start_integer(1)
                    .description("How the encoder counts: truncate (round down, as before the sensor model) or round to the nearest count."),
                Graduation1Amplitude = Var::real("encoder.graduation_error1_amplitude", "arcsec").parameter().start(0.0).min(0.0).max($crate::fmi::common::MAX_ENCODER_ERROR_ARCSEC)
                    .description($crate::fmi::common::sensor_text::GRADUATION_AMPLITUDE),
                Graduation1Harmonic = Var::integer("encoder.graduation_error1_harmonic").parameter().start_integer(2).range_integer(1, 100_000_000)
                    .description($crate::fmi::common::sensor_text::GRADUATION_HARMONIC),
                Graduation1Phase = Var::real("encoder.graduation_error1_phase", "deg").parameter().start(0.0).min(-$crate::fmi::common::MAX_PHASE_DEG).max($crate::fmi::common::MAX_PHASE_DEG)
                    .description($crate::fmi::common::sensor_text::GRADUATION_PHASE),
                Graduation2Amplitude = Var::real("encoder.graduation_error2_amplitude", "arcsec").parameter().start(0.0).min(0.0).max($crate::fmi::common::MAX_ENCODER_ERROR_ARCSEC)
                    .description($crate::fmi::common::sensor_text::GRADUATION_AMPLITUDE),
                Graduation2Harmonic = Var::integer("encoder.graduation_error2_harmonic").parameter().start_integer(3).range_integer(1, 100_000_000)
                    .description($crate::fmi::common::sensor_text::GRADUATION_HARMONIC),
                Graduation2Phase = Var::real("encoder.graduation_error2_phase", "deg").parameter().start(0.0).min(-$crate::fmi::common::MAX_PHASE_DEG).max($crate::fmi::common::MAX_PHASE_DEG)
                    .description($crate::fmi::common::sensor_text::GRADUATION_PHASE),
                Graduation3Amplitude = Var::real("encoder.graduation_error3_amplitude", "arcsec").parameter().start(0.0).min(0.0).max($crate::fmi::common::MAX_ENCODER_ERROR_ARCSEC)
                    .description($crate::fmi::common::sensor_text::GRADUATION_AMPLITUDE),
                Graduation3Harmonic = Var::integer("encoder.graduation_error3_harmonic").parameter().start_integer(4).range_integer(1, 100_000_000)
                    .description($crate::fmi::common::sensor_text::GRADUATION_HARMONIC),
                Graduation3Phase = Var::real("encoder.graduation_error3_phase", "deg").parameter().start(0.0).min(-$crate::fmi::common::MAX_PHASE_DEG).max($crate::fmi::common::MAX_PHASE_DEG)
                    .description($crate::fmi::common::sensor_text::GRADUATION_PHASE),
                LineCount = Var::integer("encoder.line_count").parameter().start_integer(32768).range_integer(1, 100_000_000)
                    .description($crate::fmi::common::sensor_text::LINE_COUNT),
                Interpolation1Amplitude = Var::real("encoder.interpolation_error1_amplitude", "arcsec").parameter().start(0.0).min(0.0).max($crate::fmi::common::MAX_ENCODER_ERROR_ARCSEC)
                    .description($crate::fmi::common::sensor_text::INTERPOLATION1_AMPLITUDE),
                Interpolation1Phase = Var::real("encoder.interpolation_error1_phase", "deg").parameter().start(0.0).min(-$crate::fmi::common::MAX_PHASE_DEG).max($crate::fmi::common::MAX_PHASE_DEG)
                    .description($crate::fmi::common::sensor_text::INTERPOLATION_PHASE),
                Interpolation2Amplitude = Var::real("encoder.interpolation_error2_amplitude", "arcsec").parameter().start(0.0).min(0.0).max($crate::fmi::common::MAX_ENCODER_ERROR_ARCSEC)
                    .description($crate::fmi::common::sensor_text::INTERPOLATION2_AMPLITUDE),
                Interpolation2Phase = Var::real("encoder.interpolation_error2_phase", "deg").parameter().start(0.0).min(-$crate::fmi::common::MAX_PHASE_DEG).max($crate::fmi::common::MAX_PHASE_DEG)
                    .description($crate::fmi::common::sensor_text::INTERPOLATION_PHASE),
                EccentricityAmplitude = Var::real("encoder.eccentricity_error_amplitude", "arcsec").parameter().start(0.0).min(0.0).max($crate::fmi::common::MAX_ENCODER_ERROR_ARCSEC)
                    .description($crate::fmi::common::sensor_text::ECCENTRICITY_AMPLITUDE),
                EccentricityPhase = Var::real("encoder.eccentricity_error_phase", "deg").parameter().start(0.0).min(-$crate::fmi::common::MAX_PHASE_DEG).max($crate::fmi::common::MAX_PHASE_DEG)
                    .description($crate::fmi::common::sensor_text::ECCENTRICITY_PHASE),
                EncoderNoise = Var::real("encoder.noise_rms", "arcsec").parameter().start(0.0).min(0.0).max($crate::fmi::common::MAX_ENCODER_ERROR_ARCSEC)
                    .description($crate::fmi::common::sensor_text::ENCODER_NOISE),
                $($speed_noise)*
                SensorSeed = Var::integer("sensors.seed").parameter().start_integer(1).description($crate::fmi::common::sensor_text::SEED),
                SensorSamplePeriod = Var::real("sensors.sample_period", "s").parameter().start(1e-3).min(1e-6).max(1.0)
                    .description($crate::fmi::common::sensor_text::SAMPLE_PERIOD),
                $($more)*
                EncoderCountModeNumber = Var::integer("encoder.count_mode_number").parameter().start_integer(0).range_integer(0, 2)
                    .description($crate::fmi::common::sensor_text::COUNT_MODE_NUMBER),
            }
        }
    };
}
pub(crate) use plant_variables;
