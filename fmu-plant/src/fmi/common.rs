//! Pieces shared by the two plant FMUs: motor and friction parameter groups read from the
//! variable values, the parameter-file hook and the model information.

use fmu_runtime::{Context, DefaultExperiment, ModelInfo, Values, VariableSet};

use crate::params::{CoggingParams, FrictionParams, MotorParams, NumericsParams};

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

/// Loads the parameter file named by a `parameter_file` variable, resolving a relative path
/// against the FMU's resources folder (so `linear.params` finds the shipped file).
pub fn load_parameter_file<M: fmu_runtime::Model>(
    file_var: M::Var,
    values: &mut Values<M::Var>,
    context: &Context,
) -> Result<(), String> {
    let name = values.string(file_var).to_string();
    if name.is_empty() {
        return Ok(());
    }
    let path = std::path::PathBuf::from(&name);
    let path = if path.is_absolute() {
        path
    } else {
        match &context.resource_dir {
            Some(dir) => dir.join(&path),
            None => path,
        }
    };
    let text =
        std::fs::read_to_string(&path).map_err(|e| format!("cannot read parameter file {}: {e}", path.display()))?;
    fmu_runtime::params::apply::<M>(&text, &path.display().to_string(), values)?;
    Ok(())
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
