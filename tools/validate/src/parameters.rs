//! The plant's parameter set: the names, units and meaning of every parameter in one table, and
//! the `name = value  # unit, comment` text format that the validate tool reads and writes and
//! the plant FMU loads through a string parameter.
//!
//! The parameter set describes one drive axis (single-axis, axis-side values, the form the
//! equation-error regressors are written in). [`FMU_MAPPING`] is the one table that maps each
//! of its parameters onto the variables of the plant FMU (`AzimuthPlant`), and
//! [`fmu_parameter_entries`] implements it: the corrected model is written as an FMU parameter
//! file (`fmu_runtime::params` format) that the FMU loads through its `parameter_file`
//! variable, so "the model with the added effect" is a usable FMU. Every name is a constant in
//! [`names`] and every piece of code refers to the constant, so renaming a parameter is one
//! edit here.

use std::path::Path;

/// Names of the single-axis parameters. Rename here only; [`FMU_MAPPING`] says which plant-FMU
/// variables each one sets.
pub mod names {
    pub const GEAR_RATIO: &str = "gear.ratio";
    pub const MOTOR_INERTIA: &str = "motor.inertia";
    pub const TORQUE_CONSTANT: &str = "motor.torque_constant";
    pub const LOAD_INERTIA: &str = "load.inertia";
    pub const STIFFNESS: &str = "path.stiffness";
    pub const DAMPING: &str = "path.damping";
    pub const VISCOUS: &str = "friction.viscous";
    pub const COULOMB: &str = "friction.coulomb";
    pub const STATIC: &str = "friction.static";
    pub const STRIBECK_VELOCITY: &str = "friction.stribeck_velocity";
    pub const ASYMMETRY: &str = "friction.asymmetry";
    pub const TORQUE_OFFSET: &str = "effect.torque_offset";
    pub const UNBALANCE_TORQUE: &str = "effect.unbalance_torque";
    pub const UNBALANCE_PHASE: &str = "effect.unbalance_phase";
    pub const DELAY: &str = "effect.delay";
    pub const TORQUE_CONSTANT_SCALE: &str = "effect.torque_constant_scale";
    pub const COGGING_AMPLITUDE: &str = "effect.cogging_amplitude";
    pub const COGGING_PERIOD: &str = "effect.cogging_period";
    pub const COGGING_PHASE: &str = "effect.cogging_phase";
    pub const BACKLASH_WIDTH: &str = "backlash.width";
    pub const PRESLIDING_STIFFNESS: &str = "friction.presliding_stiffness";
    pub const PRESLIDING_DAMPING: &str = "friction.presliding_damping";
    pub const CURRENT_LOOP_BANDWIDTH: &str = "motor.current_loop_bandwidth";
}

/// What one parameter means. Torques, stiffness, damping and load inertia are on the axis
/// (load) side of the gearbox; the motor inertia and torque constant are on the motor side, as
/// data sheets give them. Angles and speeds are axis-side.
#[derive(Debug, Clone, Copy)]
pub struct ParameterInfo {
    pub name: &'static str,
    pub unit: &'static str,
    pub description: &'static str,
    /// The value that means "effect absent".
    pub neutral: f64,
    /// The power of length in the parameter's unit on a linear axis (kg m^2 is kg at unit
    /// radius: 2; N m is N: 1; rad/s is m/s: -1): how its value changes when the plant FMU
    /// measures a linear axis's travel in another length unit ([`in_fmu_length_unit`]).
    pub length_power: i32,
}

/// Every parameter the model knows, in the order the files list them.
pub const PARAMETERS: [ParameterInfo; 23] = [
    ParameterInfo { name: names::GEAR_RATIO, unit: "-", description: "gear ratio, motor turns per axis turn", neutral: 1.0, length_power: 0 },
    ParameterInfo { name: names::MOTOR_INERTIA, unit: "kg m^2", description: "motor rotor inertia (motor side, all motors together)", neutral: 0.0, length_power: 2 },
    ParameterInfo { name: names::TORQUE_CONSTANT, unit: "N m/A", description: "motor torque constant (per motor)", neutral: 1.0, length_power: 1 },
    ParameterInfo { name: names::LOAD_INERTIA, unit: "kg m^2", description: "load inertia about the axis", neutral: 0.0, length_power: 2 },
    ParameterInfo { name: names::STIFFNESS, unit: "N m/rad", description: "drive path stiffness, axis side", neutral: 0.0, length_power: 2 },
    ParameterInfo { name: names::DAMPING, unit: "N m s/rad", description: "drive path damping, axis side", neutral: 0.0, length_power: 2 },
    ParameterInfo { name: names::VISCOUS, unit: "N m s/rad", description: "viscous friction at the motor, referred to the axis", neutral: 0.0, length_power: 2 },
    ParameterInfo { name: names::COULOMB, unit: "N m", description: "Coulomb friction at the motor, referred to the axis", neutral: 0.0, length_power: 1 },
    ParameterInfo { name: names::STATIC, unit: "N m", description: "breakaway (static) friction level; equal to Coulomb means no Stribeck hump", neutral: 0.0, length_power: 1 },
    ParameterInfo { name: names::STRIBECK_VELOCITY, unit: "rad/s", description: "Stribeck velocity of exp(-(w/ws)^2), axis side", neutral: 0.01, length_power: -1 },
    ParameterInfo { name: names::ASYMMETRY, unit: "-", description: "friction asymmetry a (the plant FMU's form): both friction levels are (1 + a) times nominal moving forward and (1 - a) times moving backward", neutral: 0.0, length_power: 0 },
    ParameterInfo { name: names::TORQUE_OFFSET, unit: "N m", description: "constant torque the drive must supply to the load (cable drag, preload, sensor offset), axis side; the FMU's load.torque_offset is its negative", neutral: 0.0, length_power: 1 },
    ParameterInfo { name: names::UNBALANCE_TORQUE, unit: "N m", description: "unbalance torque amplitude m g r: the load needs T = A cos(angle + phase) to hold it", neutral: 0.0, length_power: 1 },
    ParameterInfo { name: names::UNBALANCE_PHASE, unit: "rad", description: "unbalance phase; the angle is the axis (load) angle", neutral: 0.0, length_power: 0 },
    ParameterInfo { name: names::DELAY, unit: "s", description: "delay of the applied torque behind the logged current/torque", neutral: 0.0, length_power: 0 },
    ParameterInfo { name: names::TORQUE_CONSTANT_SCALE, unit: "-", description: "true torque constant / nominal torque constant", neutral: 1.0, length_power: 0 },
    ParameterInfo { name: names::COGGING_AMPLITUDE, unit: "N m", description: "position-periodic torque amplitude: T = A sin(2 pi angle/period + phase), angle = motor angle referred to the axis", neutral: 0.0, length_power: 1 },
    ParameterInfo { name: names::COGGING_PERIOD, unit: "rad", description: "period of the position-periodic torque in axis-referred motor angle", neutral: 0.0, length_power: -1 },
    ParameterInfo { name: names::COGGING_PHASE, unit: "rad", description: "phase of the position-periodic torque", neutral: 0.0, length_power: 0 },
    ParameterInfo { name: names::BACKLASH_WIDTH, unit: "rad", description: "total lost motion (dead zone width) of the drive path, axis side", neutral: 0.0, length_power: -1 },
    ParameterInfo { name: names::PRESLIDING_STIFFNESS, unit: "N m/rad", description: "presliding (bristle) stiffness of the motor friction while it sticks, referred to the axis; 0 is a rigid stick", neutral: 0.0, length_power: 2 },
    ParameterInfo { name: names::PRESLIDING_DAMPING, unit: "N m s/rad", description: "damping of the presliding spring, referred to the axis", neutral: 0.0, length_power: 2 },
    ParameterInfo { name: names::CURRENT_LOOP_BANDWIDTH, unit: "Hz", description: "bandwidth of the drive's current loop (first order); used only when the log holds the current command, to turn it into the current the motors carried", neutral: 0.0, length_power: 0 },
];

/// Looks up the description of a known parameter.
pub fn info(name: &str) -> Option<&'static ParameterInfo> {
    PARAMETERS.iter().find(|p| p.name == name)
}

/// How the log drives the plant FMU's two motor inputs.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FmuDrive {
    /// One motor (or a log whose motors are summed): the two FMU motors are identical
    /// half-motors, each commanded with the whole logged current or torque. With equal
    /// commands, identical halves and identical initial states the two-motor plant is exactly
    /// the single-motor axis (tested in fmu-plant; a symmetric backlash stays symmetric).
    Mirrored,
    /// The log has two motors: FMU motor k is commanded with log motor k, so a torque bias
    /// between them acts as on the real azimuth drive.
    TwoMotors,
}

/// What the log's command column is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FmuInput {
    /// Measured motor current, A: the FMU's torque constant is the parameter set's.
    Current,
    /// Measured motor-side torque, N m: the FMU's "current" is the torque and its torque
    /// constant is 1 N m per unit (shared between the half-motors when mirrored).
    Torque,
}

/// The settings of the FMU that depend on the log rather than on the model.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FmuConfig {
    pub drive: FmuDrive,
    pub input: FmuInput,
    /// Sample interval of the log (s): it sets the current-loop bandwidth, which must be far
    /// above the log's bandwidth because the log holds the measured (not commanded) current,
    /// and the stiffness that emulates a rigid drive when the set has none.
    pub sample_interval: f64,
    /// The log's length (metres of a linear axis's travel; radians of a rotary one) that one
    /// radian of the FMU stands for: 1 for a rotary axis, a power of ten chosen by
    /// [`fmu_length_unit`] for a linear one, so that a carriage's mass and friction fall within
    /// the ranges the FMU declares for a motor.
    pub length_unit: f64,
}

impl FmuConfig {
    /// Bandwidth of the FMU's current loop (Hz): 1000 times the sample rate, so its lag
    /// (1/(2 pi f)) is below 2e-4 of a sample, but at most the largest bandwidth the plant
    /// declares (10 kHz, a lag of 16 us: below 0.01 of a sample at 500 Hz, 0.004 at 250 Hz).
    /// The logged current is what the motor carried; the FMU's first-order current loop must
    /// pass it (nearly) unchanged.
    pub fn current_loop_hz(&self) -> f64 {
        (1000.0 / self.sample_interval).min(declared_maximum("motor1.current_loop_bandwidth"))
    }

    /// Frequency (Hz) of the drive-path mode that emulates a rigid drive when the parameter
    /// set has no stiffness: 5 times the sample rate (10 times the Nyquist frequency), so the
    /// compliance is invisible in the sampled outputs. The FMU's exact zero-order-hold
    /// discretisation stays exact at any stiffness.
    pub fn rigid_mode_hz(&self) -> f64 {
        5.0 / self.sample_interval
    }
}

/// The FMU length unit for a log ([`FmuConfig::length_unit`]). A rotary axis is simulated in
/// its own radians. A linear axis is read as an axis of unit radius (1 m is 1 rad), where a
/// 95 kg carriage on a direct drive becomes a 95 kg m^2 "motor", beyond any motor the FMU
/// declares; simulated with its travel in units of 0.1 m, 1 cm, ... instead (the same motion
/// in another length unit: masses times the unit squared, forces times the unit), it is an
/// ordinary drive. The unit is the largest power of ten at most 1 m for which the motor's
/// inertia, viscous friction and friction levels, as the FMU gets them, stay under a tenth of
/// the maxima it declares.
pub fn fmu_length_unit(linear: bool, params: &ParameterSet) -> f64 {
    if !linear {
        return 1.0;
    }
    let gear = params.value(names::GEAR_RATIO).abs().max(f64::MIN_POSITIVE);
    let coulomb = params.value(names::COULOMB).abs();
    let friction = params.get(names::STATIC).map_or(coulomb, f64::abs).max(coulomb);
    // (motor-side value at a unit of 1 m, the power of the unit it scales with, FMU variable)
    let motor_side = [
        (params.value(names::MOTOR_INERTIA).abs() / 2.0, 2, "motor1.inertia"),
        (params.value(names::VISCOUS).abs() / (2.0 * gear * gear), 2, "motor1.viscous_friction"),
        (friction / (2.0 * gear), 1, "motor1.static_friction"),
    ];
    let fits = |unit: f64| {
        motor_side.iter().all(|&(value, power, variable)| value * unit.powi(power) <= 0.1 * declared_maximum(variable))
    };
    (0..=6).map(|k| 10f64.powi(-k)).find(|&unit| fits(unit)).unwrap_or(1e-6)
}

/// The parameter set with its values in an FMU length unit of `unit` (see
/// [`FmuConfig::length_unit`]): each value times the unit to the power of length in its unit
/// ([`ParameterInfo::length_power`]); the gear ratio and the dimensionless and time values
/// stay.
pub fn in_fmu_length_unit(params: &ParameterSet, unit: f64) -> ParameterSet {
    let mut scaled = params.clone();
    if unit == 1.0 {
        return scaled;
    }
    for (name, value, _) in scaled.entries.iter_mut() {
        if let Some(info) = info(name) {
            *value *= unit.powi(info.length_power);
        }
    }
    scaled
}

/// The maximum the `AzimuthPlant` variable table declares for a real variable (infinite when
/// it declares none), so a value the tool chooses stays within what the FMU accepts.
fn declared_maximum(name: &str) -> f64 {
    use fmu_runtime::variables::{Kind, VariableSet};
    match fmu_plant::fmi::AzVar::by_name(name).map(|v| &v.var().kind) {
        Some(Kind::Real { max: Some(max), .. }) => *max,
        _ => f64::INFINITY,
    }
}

/// One row of the parameter-to-FMU mapping table.
#[derive(Debug, Clone, Copy)]
pub struct FmuMapping {
    /// Single-axis parameter names (several when they map together).
    pub parameters: &'static [&'static str],
    /// The `AzimuthPlant` variables they set (k = 1, 2: both half-motors or pinion paths).
    pub variables: &'static [&'static str],
    /// The conversion, N the gear ratio.
    pub rule: &'static str,
}

/// The mapping of the single-axis parameter set onto the `AzimuthPlant` FMU. A single-motor
/// axis is two identical half-motors, each with its own half-stiffness path; everything the
/// axis set holds for "all motors" is halved per motor. Torques and speeds on the motor side
/// are the axis-side values through the gear ratio.
pub const FMU_MAPPING: [FmuMapping; 20] = [
    FmuMapping { parameters: &[names::GEAR_RATIO], variables: &["gear.ratio"], rule: "N" },
    FmuMapping { parameters: &[names::MOTOR_INERTIA], variables: &["motor1.inertia", "motor2.inertia"], rule: "J_m/2 each" },
    FmuMapping {
        parameters: &[names::TORQUE_CONSTANT],
        variables: &["motor1.torque_constant", "motor2.torque_constant"],
        rule: "K/2 each when mirrored (each half-motor carries the whole current), K each with two logged motors; a torque log uses 1/2 (mirrored) or 1 N m per unit",
    },
    FmuMapping {
        parameters: &[names::LOAD_INERTIA],
        variables: &["load.turning_head_inertia", "load.elevation_structure_cross_inertia", "load.elevation_structure_boresight_inertia"],
        rule: "J_L, 0, 0 (the axis inertia does not depend on the elevation input)",
    },
    FmuMapping { parameters: &[names::STIFFNESS], variables: &["pinion1.stiffness", "pinion2.stiffness"], rule: "K_s/2 each (paths in parallel)" },
    FmuMapping { parameters: &[names::DAMPING], variables: &["pinion1.damping", "pinion2.damping"], rule: "D/2 each" },
    FmuMapping { parameters: &[names::VISCOUS], variables: &["motor1.viscous_friction", "motor2.viscous_friction"], rule: "B/(2 N^2) each" },
    FmuMapping { parameters: &[names::PRESLIDING_STIFFNESS], variables: &["motor1.presliding_stiffness", "motor2.presliding_stiffness"], rule: "sigma/(2 N^2) each" },
    FmuMapping { parameters: &[names::PRESLIDING_DAMPING], variables: &["motor1.presliding_damping", "motor2.presliding_damping"], rule: "c/(2 N^2) each" },
    FmuMapping { parameters: &[names::COULOMB], variables: &["motor1.coulomb_friction", "motor2.coulomb_friction"], rule: "F_c/(2 N) each" },
    FmuMapping { parameters: &[names::STATIC], variables: &["motor1.static_friction", "motor2.static_friction"], rule: "F_s/(2 N) each (F_s = F_c when not set)" },
    FmuMapping { parameters: &[names::STRIBECK_VELOCITY], variables: &["motor1.stribeck_velocity", "motor2.stribeck_velocity"], rule: "w_s N (motor rad/s)" },
    FmuMapping { parameters: &[names::ASYMMETRY], variables: &["motor1.friction_asymmetry", "motor2.friction_asymmetry"], rule: "a (same multiplicative form)" },
    FmuMapping { parameters: &[names::TORQUE_OFFSET], variables: &["load.torque_offset"], rule: "-T_0 (the FMU's offset drives the load; the axis set's is what the drive must supply)" },
    FmuMapping {
        parameters: &[names::UNBALANCE_TORQUE, names::UNBALANCE_PHASE],
        variables: &["load.periodic_torque_amplitude", "load.periodic_torque_period", "load.periodic_torque_phase"],
        rule: "A, 360 deg, phase - 90 deg: -A cos(q + phase) = A sin(q + phase - 90 deg)",
    },
    FmuMapping { parameters: &[names::DELAY], variables: &["motor1.command_delay", "motor2.command_delay"], rule: "d" },
    FmuMapping { parameters: &[names::TORQUE_CONSTANT_SCALE], variables: &["motor1.torque_constant_scale", "motor2.torque_constant_scale"], rule: "s" },
    FmuMapping {
        parameters: &[names::COGGING_AMPLITUDE, names::COGGING_PERIOD, names::COGGING_PHASE],
        variables: &[
            "motor1.cogging_amplitude",
            "motor2.cogging_amplitude",
            "motor1.cogging_period",
            "motor2.cogging_period",
            "motor1.cogging_phase",
            "motor2.cogging_phase",
        ],
        rule: "A/(2 N) each, N P/(2 pi) motor revolutions, phase + 180 deg (the FMU's cogging drives the motor)",
    },
    FmuMapping { parameters: &[names::BACKLASH_WIDTH], variables: &["pinion1.backlash", "pinion2.backlash"], rule: "b in arcsec, each (both paths have the whole dead zone)" },
    FmuMapping {
        parameters: &[names::CURRENT_LOOP_BANDWIDTH],
        variables: &["motor1.current_loop_bandwidth", "motor2.current_loop_bandwidth"],
        rule: "not passed on: a logged current command is turned into the current through it before the analysis, so the FMU's loop stays transparent",
    },
];

/// FMU variables the mapping fixes whatever the parameters: what the single-axis model does not
/// have (bearing friction: all friction is at the motor; current saturation; quantisation)
/// switched off, and the current loop made transparent.
pub const FMU_FIXED: [(&str, &str); 9] = [
    (
        "motor1.current_limit, motor2.current_limit",
        "1e4 A, the plant FMU's largest: no saturation (the log holds what the drive did)",
    ),
    (
        "motor1.current_loop_bandwidth, motor2.current_loop_bandwidth",
        "1000 x the sample rate: the log holds the measured current",
    ),
    ("bearing.coulomb_friction, bearing.static_friction", "0: all friction is at the motor"),
    ("bearing.stribeck_velocity, bearing.friction_asymmetry", "0"),
    ("bearing.viscous_friction", "0"),
    ("encoder.bits", "0: the simulated angle is compared with the logged one, whose quantisation is in the data"),
    ("linear_configuration", "false"),
    (
        "pinion stiffness and damping without path.stiffness",
        "a critically damped mode at 5 x the sample rate emulates a rigid drive",
    ),
    (
        "load.turning_head_inertia without load.inertia",
        "1e-3 of the reflected motor inertia, taken from the motors (the total is kept)",
    ),
];

/// One line of an FMU parameter file: variable name, value, comment.
pub type FmuEntry = (String, fmu_runtime::params::ParameterValue, String);

/// The FMU parameter-file entries (name, value, comment) for a parameter set, following
/// [`FMU_MAPPING`] and [`FMU_FIXED`]. Fails when the set has no gear ratio or describes a plant
/// the FMU rejects (for example static friction below Coulomb friction).
pub fn fmu_parameter_entries(params: &ParameterSet, config: &FmuConfig) -> Result<Vec<FmuEntry>, ParameterError> {
    use fmu_runtime::params::ParameterValue::Number;
    let scaled = in_fmu_length_unit(params, config.length_unit);
    let params = &scaled;
    let gear = params
        .get(names::GEAR_RATIO)
        .ok_or(ParameterError::Missing { name: names::GEAR_RATIO, reason: "the parameter set has no gear.ratio" })?;
    if gear.is_nan() || gear <= 0.0 {
        return Err(ParameterError::Unusable { message: format!("{} must be positive", names::GEAR_RATIO) });
    }
    let (motor_inertia, load_inertia) = fmu_inertias(params, gear)?;
    let path = DrivePath::of(params, motor_inertia, load_inertia, gear, config);
    let torque_constant = fmu_torque_constant(params, config)?;
    let mut out = vec![("gear.ratio".to_string(), Number(gear), "gear.ratio".to_string())];
    motor_entries(&mut out, params, config, gear, motor_inertia, torque_constant);
    pinion_entries(&mut out, params, &path);
    load_entries(&mut out, params, load_inertia);
    fixed_entries(&mut out);
    check_fmu_friction(params)?;
    Ok(out)
}

/// The motor (all motors together) and load inertias the FMU gets. The FMU needs both; a set
/// with only one gives a small share of it to the other, keeping the total.
fn fmu_inertias(params: &ParameterSet, gear: f64) -> Result<(f64, f64), ParameterError> {
    let n2 = gear * gear;
    let mut motor_inertia = params.value(names::MOTOR_INERTIA);
    let mut load_inertia = params.value(names::LOAD_INERTIA);
    if motor_inertia <= 0.0 && load_inertia <= 0.0 {
        return Err(ParameterError::Unusable {
            message: format!("the parameter set has neither {} nor {}", names::MOTOR_INERTIA, names::LOAD_INERTIA),
        });
    }
    if load_inertia <= 0.0 {
        load_inertia = 1e-3 * motor_inertia * n2;
        motor_inertia *= 1.0 - 1e-3;
    }
    if motor_inertia <= 0.0 {
        motor_inertia = 1e-3 * load_inertia / n2;
        load_inertia *= 1.0 - 1e-3;
    }
    Ok((motor_inertia, load_inertia))
}

/// The drive path the FMU gets: the set's stiffness and damping, or, without a stiffness, a
/// critically damped mode far above the log's bandwidth that emulates a rigid drive.
struct DrivePath {
    stiffness: f64,
    damping: f64,
    rigid: bool,
}

impl DrivePath {
    fn of(params: &ParameterSet, motor_inertia: f64, load_inertia: f64, gear: f64, config: &FmuConfig) -> Self {
        match params.get(names::STIFFNESS).filter(|k| *k > 0.0) {
            Some(k) => DrivePath { stiffness: k, damping: params.value(names::DAMPING), rigid: false },
            None => {
                let n2 = gear * gear;
                let reduced = motor_inertia * n2 * load_inertia / (motor_inertia * n2 + load_inertia);
                let omega = 2.0 * std::f64::consts::PI * config.rigid_mode_hz();
                DrivePath { stiffness: omega * omega * reduced, damping: 2.0 * omega * reduced, rigid: true }
            }
        }
    }
}

/// The torque constant of each FMU half-motor (see [`FMU_MAPPING`]).
fn fmu_torque_constant(params: &ParameterSet, config: &FmuConfig) -> Result<f64, ParameterError> {
    let logged = || {
        params.get(names::TORQUE_CONSTANT).ok_or(ParameterError::Missing {
            name: names::TORQUE_CONSTANT,
            reason: "the log has currents: the parameter set needs motor.torque_constant",
        })
    };
    Ok(match (config.input, config.drive) {
        (FmuInput::Current, FmuDrive::Mirrored) => logged()? / 2.0,
        (FmuInput::Current, FmuDrive::TwoMotors) => logged()?,
        // A logged torque in N m is config.length_unit FMU torque units per N m.
        (FmuInput::Torque, FmuDrive::Mirrored) => 0.5 * config.length_unit,
        (FmuInput::Torque, FmuDrive::TwoMotors) => config.length_unit,
    })
}

/// Pushes the same value for both motors or pinions: `#` in the stem is the number.
fn both(out: &mut Vec<FmuEntry>, stem: &str, value: f64, comment: &str) {
    for k in ["1", "2"] {
        out.push((stem.replacen('#', k, 1), fmu_runtime::params::ParameterValue::Number(value), comment.to_string()));
    }
}

/// The two half-motors: inertia, torque constant, friction, delay, cogging, current loop.
fn motor_entries(
    out: &mut Vec<FmuEntry>,
    params: &ParameterSet,
    config: &FmuConfig,
    gear: f64,
    motor_inertia: f64,
    torque_constant: f64,
) {
    let n2 = gear * gear;
    let coulomb = params.value(names::COULOMB);
    let static_friction = params.get(names::STATIC).unwrap_or(coulomb);
    let cogging_amplitude = params.value(names::COGGING_AMPLITUDE);
    let cogging_period = params.value(names::COGGING_PERIOD);
    let (cogging_amplitude, cogging_period_rev) = if cogging_amplitude != 0.0 && cogging_period > 0.0 {
        (cogging_amplitude / (2.0 * gear), gear * cogging_period / (2.0 * std::f64::consts::PI))
    } else {
        (0.0, 1.0)
    };
    both(out, "motor#.inertia", motor_inertia / 2.0, "motor.inertia / 2, kg m^2");
    both(out, "motor#.torque_constant", torque_constant, "motor.torque_constant per half-motor (see FMU_MAPPING)");
    both(
        out,
        "motor#.torque_constant_scale",
        params.value(names::TORQUE_CONSTANT_SCALE),
        "effect.torque_constant_scale",
    );
    both(
        out,
        "motor#.viscous_friction",
        params.value(names::VISCOUS) / (2.0 * n2),
        "friction.viscous / (2 N^2), N m s/rad at the motor",
    );
    both(
        out,
        "motor#.presliding_stiffness",
        params.value(names::PRESLIDING_STIFFNESS) / (2.0 * n2),
        "friction.presliding_stiffness / (2 N^2), N m/rad at the motor",
    );
    both(
        out,
        "motor#.presliding_damping",
        params.value(names::PRESLIDING_DAMPING) / (2.0 * n2),
        "friction.presliding_damping / (2 N^2), N m s/rad at the motor",
    );
    both(out, "motor#.coulomb_friction", coulomb / (2.0 * gear), "friction.coulomb / (2 N), N m at the motor");
    both(out, "motor#.static_friction", static_friction / (2.0 * gear), "friction.static / (2 N), N m at the motor");
    both(
        out,
        "motor#.stribeck_velocity",
        params.value(names::STRIBECK_VELOCITY) * gear,
        "friction.stribeck_velocity N, motor rad/s",
    );
    both(out, "motor#.friction_asymmetry", params.value(names::ASYMMETRY), "friction.asymmetry");
    both(out, "motor#.command_delay", params.value(names::DELAY), "effect.delay, s");
    both(out, "motor#.cogging_amplitude", cogging_amplitude, "effect.cogging_amplitude / (2 N), N m at the motor");
    both(out, "motor#.cogging_period", cogging_period_rev, "N effect.cogging_period / (2 pi), motor revolutions");
    both(
        out,
        "motor#.cogging_phase",
        (params.value(names::COGGING_PHASE) + std::f64::consts::PI).to_degrees(),
        "effect.cogging_phase + 180 deg",
    );
    both(out, "motor#.current_limit", 1e4, "no saturation (the FMU's largest limit): the log holds what the drive did");
    both(
        out,
        "motor#.current_loop_bandwidth",
        config.current_loop_hz(),
        "transparent: the log holds the measured current",
    );
}

/// The two pinion paths: half the stiffness and damping each, the whole dead zone each.
fn pinion_entries(out: &mut Vec<FmuEntry>, params: &ParameterSet, path: &DrivePath) {
    let arcsec = std::f64::consts::PI / (180.0 * 3600.0);
    let stiffness_comment = if path.rigid {
        "rigid drive emulated: a critically damped mode at 5 x the sample rate"
    } else {
        "path.stiffness / 2, N m/rad"
    };
    both(out, "pinion#.stiffness", path.stiffness / 2.0, stiffness_comment);
    both(
        out,
        "pinion#.damping",
        path.damping / 2.0,
        if path.rigid { stiffness_comment } else { "path.damping / 2, N m s/rad" },
    );
    both(out, "pinion#.backlash", params.value(names::BACKLASH_WIDTH) / arcsec, "backlash.width in arcsec, each path");
}

/// The load: its inertia (independent of the elevation input), torque offset and unbalance.
fn load_entries(out: &mut Vec<FmuEntry>, params: &ParameterSet, load_inertia: f64) {
    use fmu_runtime::params::ParameterValue::Number;
    out.push(("load.turning_head_inertia".into(), Number(load_inertia), "load.inertia, kg m^2".into()));
    out.push((
        "load.elevation_structure_cross_inertia".into(),
        Number(0.0),
        "the axis inertia does not depend on the elevation input".into(),
    ));
    out.push(("load.elevation_structure_boresight_inertia".into(), Number(0.0), String::new()));
    out.push((
        "load.torque_offset".into(),
        Number(-params.value(names::TORQUE_OFFSET)),
        "-effect.torque_offset, N m".into(),
    ));
    out.push((
        "load.periodic_torque_amplitude".into(),
        Number(params.value(names::UNBALANCE_TORQUE)),
        "effect.unbalance_torque, N m".into(),
    ));
    out.push(("load.periodic_torque_period".into(), Number(360.0), "deg: an unbalance".into()));
    out.push((
        "load.periodic_torque_phase".into(),
        Number(params.value(names::UNBALANCE_PHASE).to_degrees() - 90.0),
        "effect.unbalance_phase - 90 deg".into(),
    ));
}

/// What the single-axis model does not have, switched off ([`FMU_FIXED`]).
fn fixed_entries(out: &mut Vec<FmuEntry>) {
    use fmu_runtime::params::ParameterValue::{Boolean, Number};
    for name in [
        "bearing.coulomb_friction",
        "bearing.static_friction",
        "bearing.stribeck_velocity",
        "bearing.friction_asymmetry",
        "bearing.viscous_friction",
    ] {
        out.push((name.into(), Number(0.0), "all friction is at the motor".into()));
    }
    out.push(("encoder.bits".into(), Number(0.0), "unquantised: the log's quantisation is in the data".into()));
    out.push(("linear_configuration".into(), Boolean(false), String::new()));
}

/// The plant FMU's own friction checks, stated in the set's names.
fn check_fmu_friction(params: &ParameterSet) -> Result<(), ParameterError> {
    let coulomb = params.value(names::COULOMB);
    let static_friction = params.get(names::STATIC).unwrap_or(coulomb);
    if static_friction < coulomb {
        return Err(ParameterError::Unusable {
            message: format!(
                "{} ({static_friction}) is below {} ({coulomb}): the plant FMU needs breakaway friction at least the sliding friction",
                names::STATIC,
                names::COULOMB
            ),
        });
    }
    let asymmetry = params.value(names::ASYMMETRY);
    if asymmetry.is_nan() || asymmetry.abs() >= 0.99 {
        return Err(ParameterError::Unusable {
            message: format!("{} ({asymmetry}) must lie within +-0.99", names::ASYMMETRY),
        });
    }
    Ok(())
}

/// The FMU parameter file for a parameter set: the entries of [`fmu_parameter_entries`] after
/// a `#` header, loadable through the FMU's `parameter_file` variable.
pub fn fmu_parameter_text(params: &ParameterSet, config: &FmuConfig, header: &str) -> Result<String, ParameterError> {
    let mut text = String::new();
    for line in header.lines() {
        text.push_str(&format!("# {line}\n"));
    }
    if config.length_unit != 1.0 {
        text.push_str(&format!(
            "# A linear axis, simulated with its travel in units of {} m: one FMU radian is that length, FMU torques are newtons times it, inertias kilograms times its square.\n",
            config.length_unit
        ));
    }
    text.push_str(&fmu_runtime::params::format(&fmu_parameter_entries(params, config)?));
    Ok(text)
}

/// What is wrong with a parameter file or a parameter set. Messages name the line and the
/// parameter, so the file can be fixed.
#[derive(Debug, thiserror::Error)]
pub enum ParameterError {
    /// The `name = value` syntax itself (shared with the FMUs' parameter files).
    #[error("{0}")]
    Syntax(fmu_runtime::params::ParseError),
    /// A name the parameter set does not know, usually a misspelling.
    #[error("line {line}: unknown parameter '{name}' (the closest known one is '{closest}')")]
    UnknownKey { line: usize, name: String, closest: &'static str },
    /// A value that is not a number.
    #[error("line {line}: {name}: '{value}' is not a number")]
    NotANumber { line: usize, name: String, value: String },
    /// A value that is infinite or NaN.
    #[error("line {line}: parameter {name} is not finite")]
    NotFinite { line: usize, name: String },
    /// A unit after the value that cannot be converted to the parameter's unit.
    #[error("line {line}: {name}: unit '{unit}' cannot be converted to {expected} (write the value in {expected}, or in one of: {accepted})")]
    Unit { line: usize, name: String, unit: String, expected: &'static str, accepted: String },
    /// A value no physical drive can have.
    #[error("line {line}: {name} = {value} is impossible: {requirement}")]
    Impossible { line: usize, name: String, value: f64, requirement: &'static str },
    /// A parameter a use of the set needs and it lacks.
    #[error("{reason}")]
    Missing { name: &'static str, reason: &'static str },
    /// A set the plant FMU cannot be configured from.
    #[error("{message}")]
    Unusable { message: String },
    #[error("cannot read {path}: {reason}")]
    Read { path: std::path::PathBuf, reason: Box<fmu_runtime::files::FileError> },
    #[error("cannot write {path}")]
    Write { path: std::path::PathBuf, source: std::io::Error },
    /// An error inside a file, with the file's path.
    #[error("{path}")]
    InFile { path: std::path::PathBuf, source: Box<ParameterError> },
}

impl ParameterError {
    /// The 1-based line of the file the error is on, when it belongs to one line.
    pub fn line(&self) -> Option<usize> {
        match self {
            ParameterError::Syntax(e) => Some(e.line),
            ParameterError::UnknownKey { line, .. }
            | ParameterError::NotANumber { line, .. }
            | ParameterError::NotFinite { line, .. }
            | ParameterError::Unit { line, .. }
            | ParameterError::Impossible { line, .. } => Some(*line),
            ParameterError::InFile { source, .. } => source.line(),
            _ => None,
        }
    }
}

/// The whole cause chain as one line (`outer: inner: ...`), for callers whose errors are text.
impl From<ParameterError> for String {
    fn from(error: ParameterError) -> String {
        let mut text = error.to_string();
        let mut source = std::error::Error::source(&error);
        while let Some(cause) = source {
            text.push_str(&format!(": {cause}"));
            source = cause.source();
        }
        text
    }
}

/// Units a value may carry after its number, per parameter unit: (parameter unit, written
/// unit, factor to the parameter unit). A value without a unit is in the parameter's unit.
const VALUE_UNITS: [(&str, &str, f64); 39] = [
    ("-", "-", 1.0),
    ("Hz", "Hz", 1.0),
    // A linear axis (m, N) is an axis of unit radius: its axis-side values read as they are.
    ("kg m^2", "kg", 1.0),
    ("N m", "N", 1.0),
    ("N m", "kN", 1e3),
    ("N m/rad", "N/m", 1.0),
    ("N m s/rad", "N s/m", 1.0),
    ("rad", "m", 1.0),
    ("rad", "mm", 1e-3),
    ("rad/s", "m/s", 1.0),
    ("kg m^2", "kg m^2", 1.0),
    ("kg m^2", "kg m2", 1.0),
    ("kg m^2", "kg.m2", 1.0),
    ("N m/A", "N m/A", 1.0),
    ("N m/A", "Nm/A", 1.0),
    ("N m/A", "N.m/A", 1.0),
    ("N m", "N m", 1.0),
    ("N m", "Nm", 1.0),
    ("N m", "N.m", 1.0),
    ("N m", "kN m", 1e3),
    ("N m", "kNm", 1e3),
    ("N m/rad", "N m/rad", 1.0),
    ("N m/rad", "Nm/rad", 1.0),
    ("N m/rad", "N.m/rad", 1.0),
    ("N m/rad", "kN m/rad", 1e3),
    ("N m s/rad", "N m s/rad", 1.0),
    ("N m s/rad", "Nms/rad", 1.0),
    ("N m s/rad", "N.m.s/rad", 1.0),
    ("N m s/rad", "kN m s/rad", 1e3),
    ("rad", "rad", 1.0),
    ("rad", "mrad", 1e-3),
    ("rad", "urad", 1e-6),
    ("rad", "deg", std::f64::consts::PI / 180.0),
    ("rad", "arcsec", std::f64::consts::PI / (180.0 * 3600.0)),
    ("rad/s", "rad/s", 1.0),
    ("rad/s", "deg/s", std::f64::consts::PI / 180.0),
    ("rad/s", "rpm", 2.0 * std::f64::consts::PI / 60.0),
    ("s", "s", 1.0),
    ("s", "ms", 1e-3),
];

/// A parameter, the test its value must pass, and the requirement in words.
type Requirement = (&'static str, fn(f64) -> bool, &'static str);

/// What a parameter's value must satisfy to describe a drive that can exist: (name, test,
/// requirement). Parameters not listed may take any finite value (an offset, a phase, a delay
/// that is really a lead of the logged current).
const PHYSICAL: [Requirement; 15] = [
    (names::GEAR_RATIO, |x| x > 0.0, "a gear ratio must be positive"),
    (names::MOTOR_INERTIA, |x| x >= 0.0, "an inertia cannot be negative"),
    (names::TORQUE_CONSTANT, |x| x > 0.0, "a torque constant must be positive"),
    (names::LOAD_INERTIA, |x| x >= 0.0, "an inertia cannot be negative"),
    (names::STIFFNESS, |x| x >= 0.0, "a stiffness cannot be negative"),
    (names::DAMPING, |x| x >= 0.0, "a damping cannot be negative"),
    (names::VISCOUS, |x| x >= 0.0, "friction cannot be negative"),
    (names::COULOMB, |x| x >= 0.0, "friction cannot be negative"),
    (names::STATIC, |x| x >= 0.0, "friction cannot be negative"),
    (names::STRIBECK_VELOCITY, |x| x > 0.0, "a Stribeck velocity must be positive"),
    (names::ASYMMETRY, |x| x.abs() < 1.0, "an asymmetry must lie within +-1 (friction cannot change sign)"),
    (names::TORQUE_CONSTANT_SCALE, |x| x > 0.0, "a torque constant scale must be positive"),
    (names::COGGING_PERIOD, |x| x >= 0.0, "a period cannot be negative"),
    (names::BACKLASH_WIDTH, |x| x >= 0.0, "a dead zone cannot be narrower than nothing"),
    (names::PRESLIDING_STIFFNESS, |x| x >= 0.0, "a stiffness cannot be negative"),
];

/// The known parameter name closest to `name` (fewest single-character edits).
fn closest_known_name(name: &str) -> &'static str {
    fn edits(a: &str, b: &str) -> usize {
        let b: Vec<char> = b.chars().collect();
        let mut row: Vec<usize> = (0..=b.len()).collect();
        for (i, ca) in a.chars().enumerate() {
            let mut diagonal = row[0];
            row[0] = i + 1;
            for (j, cb) in b.iter().enumerate() {
                let next = (diagonal + usize::from(ca != *cb)).min(row[j] + 1).min(row[j + 1] + 1);
                diagonal = row[j + 1];
                row[j + 1] = next;
            }
        }
        row[b.len()]
    }
    PARAMETERS.iter().min_by_key(|p| edits(name, p.name)).map(|p| p.name).unwrap_or(names::GEAR_RATIO)
}

/// Reads one entry's value: a number, optionally followed by a unit convertible to the
/// parameter's, checked for what a drive can have.
fn entry_value(entry: &fmu_runtime::params::Entry, info: &ParameterInfo) -> Result<f64, ParameterError> {
    let (number, unit) = match entry.value.split_once(char::is_whitespace) {
        Some((number, unit)) => (number, Some(unit.trim())),
        None => (entry.value.as_str(), None),
    };
    let raw: f64 = number.parse().map_err(|_| ParameterError::NotANumber {
        line: entry.line,
        name: entry.name.clone(),
        value: entry.value.clone(),
    })?;
    if !raw.is_finite() {
        return Err(ParameterError::NotFinite { line: entry.line, name: entry.name.clone() });
    }
    let value = match unit {
        None => raw,
        Some(unit) => {
            let factor = VALUE_UNITS.iter().find(|u| u.0 == info.unit && u.1 == unit).map(|u| u.2);
            match factor {
                Some(factor) => raw * factor,
                None => {
                    let accepted: Vec<&str> = VALUE_UNITS.iter().filter(|u| u.0 == info.unit).map(|u| u.1).collect();
                    return Err(ParameterError::Unit {
                        line: entry.line,
                        name: entry.name.clone(),
                        unit: unit.to_string(),
                        expected: info.unit,
                        accepted: accepted.join(", "),
                    });
                }
            }
        }
    };
    if let Some((_, possible, requirement)) = PHYSICAL.iter().find(|p| p.0 == info.name) {
        if !possible(value) {
            return Err(ParameterError::Impossible { line: entry.line, name: entry.name.clone(), value, requirement });
        }
    }
    Ok(value)
}

/// An ordered set of named parameters with a comment each (unit first, by convention).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ParameterSet {
    entries: Vec<(String, f64, String)>,
}

impl ParameterSet {
    pub fn new() -> Self {
        Self::default()
    }

    /// The value of a parameter, if set.
    pub fn get(&self, name: &str) -> Option<f64> {
        self.entries.iter().find(|e| e.0 == name).map(|e| e.1)
    }

    /// The value of a parameter, or its neutral value (effect absent) when it is not set.
    pub fn value(&self, name: &str) -> f64 {
        self.get(name).unwrap_or_else(|| info(name).map(|i| i.neutral).unwrap_or(0.0))
    }

    /// Sets a parameter, keeping its place (and its comment) if it exists already. New known
    /// parameters get their unit and description as the comment.
    pub fn set(&mut self, name: &str, value: f64) {
        if let Some(entry) = self.entries.iter_mut().find(|e| e.0 == name) {
            entry.1 = value;
        } else {
            let comment = info(name).map(|i| format!("{}, {}", i.unit, i.description)).unwrap_or_default();
            self.entries.push((name.to_string(), value, comment));
        }
    }

    /// Sets a parameter with an explicit comment.
    pub fn set_with_comment(&mut self, name: &str, value: f64, comment: &str) {
        self.set(name, value);
        if let Some(entry) = self.entries.iter_mut().find(|e| e.0 == name) {
            entry.2 = comment.to_string();
        }
    }

    /// Names in file order.
    pub fn names(&self) -> impl Iterator<Item = &str> {
        self.entries.iter().map(|e| e.0.as_str())
    }

    /// Parses `name = value  # comment` lines (the format of `fmu_runtime::params`); blank
    /// lines and `#` lines are ignored. Every name must be a known parameter, every value a
    /// finite number (optionally with a unit convertible to the parameter's, `1.5 kN m`) that
    /// a drive can have.
    pub fn parse(text: &str) -> Result<ParameterSet, ParameterError> {
        let mut set = ParameterSet::new();
        for entry in fmu_runtime::params::entries(text).map_err(ParameterError::Syntax)? {
            let Some(info) = info(&entry.name) else {
                return Err(ParameterError::UnknownKey {
                    line: entry.line,
                    closest: closest_known_name(&entry.name),
                    name: entry.name,
                });
            };
            let value = entry_value(&entry, info)?;
            set.entries.push((entry.name, value, entry.comment));
        }
        Ok(set)
    }

    pub fn read(path: &Path) -> Result<ParameterSet, ParameterError> {
        let text =
            fmu_runtime::files::read_regular_file(path, fmu_runtime::files::MAX_PARAMETER_FILE_BYTES, "parameter set")
                .map_err(|reason| ParameterError::Read { path: path.to_path_buf(), reason: Box::new(reason) })?;
        ParameterSet::parse(&text).map_err(|e| ParameterError::InFile { path: path.to_path_buf(), source: Box::new(e) })
    }

    /// The file text: one `name = value  # comment` line per parameter, values in full precision.
    pub fn to_text(&self) -> String {
        let width = self.entries.iter().map(|e| e.0.len()).max().unwrap_or(0);
        let mut out = String::new();
        for (name, value, comment) in &self.entries {
            if comment.is_empty() {
                out.push_str(&format!("{name:width$} = {value:e}\n"));
            } else {
                out.push_str(&format!("{name:width$} = {value:e}  # {comment}\n"));
            }
        }
        out
    }

    pub fn write(&self, path: &Path, header: &str) -> Result<(), ParameterError> {
        let mut text = String::new();
        for line in header.lines() {
            text.push_str(&format!("# {line}\n"));
        }
        text.push_str(&self.to_text());
        std::fs::write(path, text).map_err(|source| ParameterError::Write { path: path.to_path_buf(), source })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parameter_names_are_unique() {
        for (i, a) in PARAMETERS.iter().enumerate() {
            assert!(PARAMETERS[..i].iter().all(|b| b.name != a.name), "{} twice", a.name);
        }
    }

    #[test]
    fn text_round_trip_keeps_order_values_and_comments() {
        let text =
            "# start\ngear.ratio = 256.9  # -, KUKA axis 1\nmotor.inertia=0.00923\n\nfriction.coulomb = 1.5e2 # N m\n";
        let set = ParameterSet::parse(text).unwrap();
        assert_eq!(set.names().collect::<Vec<_>>(), vec!["gear.ratio", "motor.inertia", "friction.coulomb"]);
        let back = ParameterSet::parse(&set.to_text()).unwrap();
        assert_eq!(back, set);
        assert_eq!(back.get("friction.coulomb"), Some(150.0));
    }

    #[test]
    fn missing_parameters_read_as_their_neutral_value() {
        let set = ParameterSet::parse("gear.ratio = 10").unwrap();
        assert_eq!(set.value(names::TORQUE_CONSTANT_SCALE), 1.0);
        assert_eq!(set.value(names::COULOMB), 0.0);
    }

    fn axis_set() -> ParameterSet {
        // An antenna-like azimuth drive (the truth generator's default plant): anti-resonance
        // near 4 Hz, reflected motor inertia about half the load inertia.
        let load_inertia = 6.0e4;
        let stiffness = load_inertia * (2.0 * std::f64::consts::PI * 4.0_f64).powi(2);
        let mut set = ParameterSet::new();
        for (name, value) in [
            (names::GEAR_RATIO, 1200.0),
            (names::MOTOR_INERTIA, 0.02),
            (names::TORQUE_CONSTANT, 2.0),
            (names::LOAD_INERTIA, load_inertia),
            (names::STIFFNESS, stiffness),
            (names::DAMPING, 2.0 * 0.04 * (stiffness * load_inertia).sqrt()),
            (names::VISCOUS, 2.0e4),
            (names::COULOMB, 3000.0),
            (names::STATIC, 4000.0),
            (names::STRIBECK_VELOCITY, 0.002),
            (names::TORQUE_CONSTANT_SCALE, 1.0),
        ] {
            set.set(name, value);
        }
        set.set(names::TORQUE_OFFSET, 250.0);
        set.set(names::UNBALANCE_TORQUE, 900.0);
        set.set(names::UNBALANCE_PHASE, 0.4);
        set.set(names::COGGING_AMPLITUDE, 120.0);
        set.set(names::COGGING_PERIOD, 0.01);
        set.set(names::COGGING_PHASE, -1.0);
        set.set(names::BACKLASH_WIDTH, 2e-5);
        set.set(names::DELAY, 0.003);
        set.set(names::ASYMMETRY, 0.05);
        set
    }

    #[test]
    fn the_fmu_mapping_covers_every_parameter_with_existing_fmu_variables() {
        use fmu_plant::fmi::AzVar;
        use fmu_runtime::VariableSet;
        for p in PARAMETERS {
            assert!(FMU_MAPPING.iter().any(|m| m.parameters.contains(&p.name)), "{} has no row in FMU_MAPPING", p.name);
        }
        for m in FMU_MAPPING {
            for v in m.variables {
                assert!(AzVar::by_name(v).is_some(), "FMU_MAPPING names {v}, which AzimuthPlant does not have");
            }
        }
    }

    #[test]
    fn a_carriage_beyond_the_fmus_motor_ranges_is_simulated_in_a_smaller_length_unit() {
        // The EMPS benchmark's published model (Janot et al. 2019): a 95.1 kg carriage on a
        // direct drive, 203.5 N s/m viscous and 20.4 N Coulomb friction, as a linear axis of
        // gear ratio 1 whose "motor" is the carriage.
        use fmu_plant::fmi::{AzVar, AzimuthPlantModel};
        let mut carriage = ParameterSet::new();
        carriage.set(names::GEAR_RATIO, 1.0);
        carriage.set(names::MOTOR_INERTIA, 95.1);
        carriage.set(names::TORQUE_CONSTANT, 35.15);
        carriage.set(names::VISCOUS, 203.5);
        carriage.set(names::COULOMB, 20.4);
        carriage.set(names::TORQUE_OFFSET, -3.4);
        let accepted = |unit: f64| {
            let config = FmuConfig {
                drive: FmuDrive::Mirrored,
                input: FmuInput::Current,
                sample_interval: 1e-3,
                length_unit: unit,
            };
            let text = fmu_parameter_text(&carriage, &config, "test").unwrap();
            let mut values = fmu_runtime::Values::<AzVar>::at_start();
            fmu_runtime::params::apply::<AzimuthPlantModel>(&text, "test", &mut values).is_ok()
        };
        assert!(!accepted(1.0), "at unit radius the carriage is beyond the FMU's motor ranges");
        let unit = fmu_length_unit(true, &carriage);
        assert_eq!(unit, 0.01);
        assert!(accepted(unit));
        assert_eq!(fmu_length_unit(false, &carriage), 1.0, "a rotary axis keeps its radians");
        let scaled = in_fmu_length_unit(&carriage, unit);
        assert!((scaled.value(names::MOTOR_INERTIA) - 95.1e-4).abs() < 1e-12);
        assert!((scaled.value(names::COULOMB) - 0.204).abs() < 1e-12);
        assert_eq!(scaled.value(names::GEAR_RATIO), 1.0);
    }

    #[test]
    fn the_written_fmu_parameter_file_is_accepted_by_the_plant_variable_table() {
        // The file goes through the same checks as the FMU's parameter_file loading: known
        // names, settable, types, ranges and the model's own checks.
        use fmu_plant::fmi::{AzVar, AzimuthPlantModel};
        for drive in [FmuDrive::Mirrored, FmuDrive::TwoMotors] {
            for input in [FmuInput::Current, FmuInput::Torque] {
                let config = FmuConfig { drive, input, sample_interval: 0.002, length_unit: 1.0 };
                let text = fmu_parameter_text(&axis_set(), &config, "test").unwrap();
                let mut values = fmu_runtime::Values::<AzVar>::at_start();
                let count = fmu_runtime::params::apply::<AzimuthPlantModel>(&text, "test", &mut values).unwrap();
                assert_eq!(count, text.lines().filter(|l| !l.starts_with('#')).count());
                let params = fmu_plant::fmi::azimuth::azimuth_params(&values);
                params.validate().unwrap();
            }
        }
    }

    #[test]
    fn the_mirrored_fmu_is_the_single_axis_with_the_same_totals() {
        // Totals of the two half-motors and paths, through the plant's own parameter struct:
        // the conversions of FMU_MAPPING, checked against the axis set one by one.
        use fmu_plant::fmi::{AzVar, AzimuthPlantModel};
        let axis = axis_set();
        let config =
            FmuConfig { drive: FmuDrive::Mirrored, input: FmuInput::Current, sample_interval: 0.002, length_unit: 1.0 };
        let mut values = fmu_runtime::Values::<AzVar>::at_start();
        fmu_runtime::params::apply::<AzimuthPlantModel>(
            &fmu_parameter_text(&axis, &config, "").unwrap(),
            "test",
            &mut values,
        )
        .unwrap();
        let p = fmu_plant::fmi::azimuth::azimuth_params(&values);
        let n = axis.value(names::GEAR_RATIO);
        let close = |a: f64, b: f64| (a - b).abs() <= 1e-12 * b.abs().max(1e-300);
        let m = p.motors;
        assert!(close(n, p.gear_ratio));
        assert!(close(m[0].inertia_kg_m2 + m[1].inertia_kg_m2, axis.value(names::MOTOR_INERTIA)));
        // Each half-motor carries the whole logged current: total torque per ampere is K.
        assert!(close(
            m[0].effective_torque_constant() + m[1].effective_torque_constant(),
            axis.value(names::TORQUE_CONSTANT)
        ));
        assert!(close(
            (m[0].viscous_friction_nm_s_per_rad + m[1].viscous_friction_nm_s_per_rad) * n * n,
            axis.value(names::VISCOUS)
        ));
        assert!(close((m[0].friction.coulomb_nm + m[1].friction.coulomb_nm) * n, axis.value(names::COULOMB)));
        assert!(close((m[0].friction.static_nm + m[1].friction.static_nm) * n, axis.value(names::STATIC)));
        assert!(close(m[0].friction.stribeck_velocity_rad_per_s / n, axis.value(names::STRIBECK_VELOCITY)));
        assert!(close(m[0].friction.asymmetry, axis.value(names::ASYMMETRY)));
        assert!(close(p.path_stiffness_nm_per_rad[0] + p.path_stiffness_nm_per_rad[1], axis.value(names::STIFFNESS)));
        assert!(close(p.path_damping_nm_s_per_rad[0] + p.path_damping_nm_s_per_rad[1], axis.value(names::DAMPING)));
        assert!(close(p.pinion_backlash_rad[0], axis.value(names::BACKLASH_WIDTH)));
        assert!(
            close(p.axis_inertia_kg_m2(10.0), axis.value(names::LOAD_INERTIA))
                && close(p.axis_inertia_kg_m2(80.0), axis.value(names::LOAD_INERTIA))
        );
        assert!(close(m[0].current_command_delay_s, axis.value(names::DELAY)));
        // Torques at sample angles: the FMU's drive the load/motor, the axis set's must be
        // supplied, so they are opposite.
        for q in [0.1, 0.7, 1.3, -2.0] {
            let unbalance = axis.value(names::UNBALANCE_TORQUE) * (q + axis.value(names::UNBALANCE_PHASE)).cos();
            assert!(
                (p.periodic_torque.torque_nm(q) + unbalance).abs() < 1e-9 * axis.value(names::UNBALANCE_TORQUE),
                "unbalance at {q}"
            );
            let qm = q + 1e-4;
            let cogging = axis.value(names::COGGING_AMPLITUDE)
                * (2.0 * std::f64::consts::PI * qm / axis.value(names::COGGING_PERIOD)
                    + axis.value(names::COGGING_PHASE))
                .sin();
            let fmu_axis_side = n * (m[0].cogging.torque_nm(n * qm) + m[1].cogging.torque_nm(n * qm));
            assert!(
                (fmu_axis_side + cogging).abs() < 1e-6 * axis.value(names::COGGING_AMPLITUDE),
                "cogging at {qm}: {fmu_axis_side} vs {cogging}"
            );
        }
        assert!(close(p.torque_offset_nm, -axis.value(names::TORQUE_OFFSET)));
    }

    #[test]
    fn malformed_lines_are_reported_with_their_line() {
        let line = |text: &str| ParameterSet::parse(text).unwrap_err().line();
        assert_eq!(line("gear.ratio = 1\nmotor.inertia 2\n"), Some(2));
        assert_eq!(line("gear.ratio = x\n"), Some(1));
        assert_eq!(line("gear.ratio = 1\ngear.ratio = 2\n"), Some(2));
        assert_eq!(line("gear.ratio = nan\n"), Some(1));
    }

    #[test]
    fn a_misspelt_key_is_named_with_the_closest_known_one() {
        let error = ParameterSet::parse("gear.ratioo = 10\n").unwrap_err();
        assert!(
            matches!(&error, ParameterError::UnknownKey { line: 1, name, closest: "gear.ratio" } if name == "gear.ratioo"),
            "{error:?}"
        );
        assert!(error.to_string().contains("closest known one is 'gear.ratio'"), "{error}");
        let error = ParameterSet::parse("gear.ratio = 10\nfriction.colomb = 3\n").unwrap_err();
        assert!(matches!(error, ParameterError::UnknownKey { line: 2, closest: names::COULOMB, .. }), "{error:?}");
    }

    #[test]
    fn physically_impossible_values_are_named_errors() {
        for (text, name) in [
            ("gear.ratio = -5", names::GEAR_RATIO),
            ("gear.ratio = 0", names::GEAR_RATIO),
            ("motor.inertia = -0.01", names::MOTOR_INERTIA),
            ("load.inertia = -1e4", names::LOAD_INERTIA),
            ("path.stiffness = -3e7", names::STIFFNESS),
            ("friction.coulomb = -1", names::COULOMB),
            ("friction.asymmetry = 1.5", names::ASYMMETRY),
        ] {
            let error = ParameterSet::parse(text).unwrap_err();
            assert!(
                matches!(&error, ParameterError::Impossible { line: 1, name: n, .. } if n == name),
                "{text}: {error:?}"
            );
            assert!(error.to_string().contains("impossible"), "{error}");
        }
        // Offsets, phases and delays may have either sign.
        assert!(ParameterSet::parse(
            "effect.torque_offset = -250\neffect.unbalance_phase = -1\neffect.delay = -0.001\n"
        )
        .is_ok());
    }

    #[test]
    fn values_with_units_are_converted_or_refused_by_name() {
        let set = ParameterSet::parse("friction.coulomb = 1.5 kN m\neffect.delay = 3 ms\nbacklash.width = 36 arcsec\n")
            .unwrap();
        assert_eq!(set.get(names::COULOMB), Some(1500.0));
        assert!((set.get(names::DELAY).unwrap() - 3e-3).abs() < 1e-18);
        assert!(
            (set.get(names::BACKLASH_WIDTH).unwrap() - 36f64 / 3600.0 * std::f64::consts::PI / 180.0).abs() < 1e-18
        );
        let error = ParameterSet::parse("gear.ratio = 10\nfriction.coulomb = 3 lbf ft\n").unwrap_err();
        assert!(
            matches!(&error, ParameterError::Unit { line: 2, unit, expected: "N m", .. } if unit == "lbf ft"),
            "{error:?}"
        );
        assert!(error.to_string().contains("cannot be converted to N m"), "{error}");
        // A unit of another dimension is refused just the same.
        assert!(matches!(ParameterSet::parse("effect.delay = 3 deg").unwrap_err(), ParameterError::Unit { .. }));
    }

    #[test]
    fn every_value_unit_belongs_to_a_parameter_unit() {
        for (unit, _, _) in VALUE_UNITS {
            assert!(PARAMETERS.iter().any(|p| p.unit == unit), "{unit} is no parameter's unit");
        }
        for p in PARAMETERS {
            assert!(
                VALUE_UNITS.iter().any(|u| u.0 == p.unit && u.1 == p.unit),
                "{}'s own unit {} is not accepted",
                p.name,
                p.unit
            );
        }
    }

    #[test]
    fn a_file_error_names_the_file_and_the_line() {
        let path = std::env::temp_dir().join(format!("b2-params-{}.params", std::process::id()));
        std::fs::write(&path, "gear.ratio = 10\ngear.ratio = -5\n").unwrap();
        let error = ParameterSet::read(&path).unwrap_err();
        std::fs::remove_file(&path).unwrap();
        assert_eq!(error.line(), Some(2));
        let text = String::from(error);
        assert!(text.contains(&path.display().to_string()) && text.contains("line 2"), "{text}");
    }
}
