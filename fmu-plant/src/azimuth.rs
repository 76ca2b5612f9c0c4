//! The azimuth axis: two motors, each driving the turning head through its own compliant,
//! backlash-afflicted pinion on the static bull gear.
//!
//! Each motor has its own current command, so a controller can torque-bias them against each
//! other to take up the backlash, as the MeerKAT drives do. The load inertia about the azimuth
//! axis depends on elevation (an input): the elevation structure contributes its inertia about
//! the cross-elevation axis when pointing at the horizon and about its boresight at the zenith.
//! With equal currents, equal initial states and no backlash the two paths move together and
//! the model is exactly the paper's "double each motor parameter" model.

use fmu_runtime::state::StateError;

use crate::error::PlantError;

use crate::drivetrain::DriveState;
use crate::floor::floor;
use crate::sensors::{SampleClock, SensorParams, Sensors, ARCSEC, AZIMUTH_STREAMS};
use nalgebra::SVector;

use crate::analytic::TwoMassParameters;
use crate::drivetrain::{
    current_index, motor_speed_index, twist_index, BodyFriction, CellModel, CoreConfig, DriveCore, NumericsStatistics,
    LOAD_ANGLE, LOAD_SPEED,
};
use crate::params::{
    finite, finite_non_negative, finite_positive, into_result, CoggingParams, FrictionParams, MotorParams,
    NumericsParams, PeriodicTorqueParams,
};

const PATHS: usize = 2;
const STATES: usize = 2 + 4 * PATHS;
const INPUTS: usize = 2 * PATHS + 1;

/// Physical parameters of the azimuth axis. Axis-side values are about the azimuth axis.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AzimuthParams {
    /// Gear ratio of each drive, motor rad per axis rad (gearbox times bull gear over pinion).
    pub gear_ratio: f64,
    /// The two motors, each with its gearbox input stage, current loop and friction.
    pub motors: [MotorParams; 2],
    /// Stiffness of each pinion path (gearbox, pinion shaft, tooth contact, bull gear, yoke
    /// mounting) about the azimuth axis, N m/rad. The paper measured an uncertainty of up to
    /// 30 % in the azimuth stiffness: vary this to study it.
    pub path_stiffness_nm_per_rad: [f64; 2],
    /// Viscous damping of each path about the axis (the paper's `K_cv`, per path), N m s/rad.
    pub path_damping_nm_s_per_rad: [f64; 2],
    /// Backlash (total free play) of each pinion on the bull gear, rad about the axis.
    pub pinion_backlash_rad: [f64; 2],
    /// Inertia of the turning head (yoke, drives, cable wrap) about the azimuth axis, without
    /// the elevation structure, kg m^2.
    pub turning_head_inertia_kg_m2: f64,
    /// Inertia of the elevation structure (dish, backup structure, counterweights, feed boom)
    /// about its transverse axis through the pivot that is perpendicular to both the boresight
    /// and the elevation axis, kg m^2. This axis is vertical at 0 deg elevation.
    pub elevation_structure_cross_inertia_kg_m2: f64,
    /// Inertia of the elevation structure about its boresight axis through the pivot, kg m^2.
    /// The boresight is vertical at 90 deg elevation.
    pub elevation_structure_boresight_inertia_kg_m2: f64,
    /// Coulomb and static friction of the azimuth bearing and cable wrap, N m about the axis.
    pub bearing_friction: FrictionParams,
    /// Viscous friction of the azimuth bearing, N m s/rad about the axis. The paper's model
    /// has none (all viscous loss is in `B_M`), so the default is 0.
    pub bearing_viscous_friction_nm_s_per_rad: f64,
    /// Constant torque on the load, N m about the axis (for example a cable-wrap preload).
    /// 0 (the default) is off.
    pub torque_offset_nm: f64,
    /// Position-periodic torque on the load: gear ripple, or with a 360 deg period the
    /// unbalance of a tilted axis. Off by default.
    pub periodic_torque: PeriodicTorqueParams,
    /// Resolution of the axis encoder, bits per turn; 0 means unquantised.
    pub encoder_bits: u32,
    /// Encoder errors and speed-signal noise (ideal by default).
    pub sensors: SensorParams<2>,
    /// Numerical scheme settings.
    pub numerics: NumericsParams,
    /// Relative change of both paths' stiffness over the elevation travel, linear in elevation:
    /// the stiffness at `el` is the path stiffness times
    /// `1 + v (el - 51.5 deg) / 73 deg`, so it spans `1 - v/2` at 15 deg to `1 + v/2` at 88 deg.
    /// The paper measured anti-resonance mismatches that imply up to 30 % over the travel, with
    /// sign and shape unknown; 0 (the paper's single K_s) by default.
    pub stiffness_variation_over_elevation: f64,
}

impl Default for AzimuthParams {
    /// MeerKAT-like values; `docs/plant-model.md` gives the reasoning for each.
    fn default() -> Self {
        let motor = MotorParams {
            inertia_kg_m2: 0.006,
            viscous_friction_nm_s_per_rad: 1.0e-3,
            friction: FrictionParams::coulomb_and_static(0.3, 0.4),
            torque_constant_nm_per_a: 0.8,
            torque_constant_scale: 1.0,
            current_limit_a: 15.0,
            current_loop_bandwidth_hz: 100.0,
            current_command_delay_s: 0.0,
            cogging: CoggingParams::NONE,
            presliding_stiffness_nm_per_rad: 0.0,
            presliding_damping_nm_s_per_rad: 0.0,
        };
        Self {
            gear_ratio: 9000.0,
            motors: [motor; 2],
            path_stiffness_nm_per_rad: [7.3e9; 2],
            path_damping_nm_s_per_rad: [5.3e6; 2],
            pinion_backlash_rad: [1.0e-4; 2],
            turning_head_inertia_kg_m2: 5.5e5,
            elevation_structure_cross_inertia_kg_m2: 2.0e5,
            elevation_structure_boresight_inertia_kg_m2: 4.0e5,
            bearing_friction: FrictionParams::coulomb_and_static(1500.0, 2000.0),
            bearing_viscous_friction_nm_s_per_rad: 0.0,
            torque_offset_nm: 0.0,
            periodic_torque: PeriodicTorqueParams::NONE,
            encoder_bits: 25,
            sensors: SensorParams::default(),
            numerics: NumericsParams::default(),
            stiffness_variation_over_elevation: 0.0,
        }
    }
}

impl AzimuthParams {
    /// The paper's linear Eq. 1 configuration: viscous motor friction `B_M` only, no Coulomb or
    /// static friction, no backlash, no saturation, no quantisation, no extra torques.
    pub fn linear() -> Self {
        let d = Self::default();
        Self {
            motors: [d.motors[0].linearised(), d.motors[1].linearised()],
            pinion_backlash_rad: [0.0; 2],
            bearing_friction: FrictionParams::NONE,
            bearing_viscous_friction_nm_s_per_rad: 0.0,
            torque_offset_nm: 0.0,
            periodic_torque: PeriodicTorqueParams::NONE,
            encoder_bits: 0,
            sensors: SensorParams::default(),
            ..d
        }
    }

    /// Checks every field; the message names each offending field and its constraint.
    pub fn validate(&self) -> Result<(), PlantError> {
        let mut errors = Vec::new();
        finite_positive("gear_ratio", self.gear_ratio, &mut errors);
        for k in 0..PATHS {
            self.motors[k].validate(&format!("motors[{k}]"), &mut errors);
            finite_positive(&format!("path_stiffness_nm_per_rad[{k}]"), self.path_stiffness_nm_per_rad[k], &mut errors);
            // The stiffness must stay positive over the whole travel, 0 to 92 deg and beyond.
            let variation = self.stiffness_variation_over_elevation;
            if k == 0 && (variation.is_nan() || variation.abs() > 0.9) {
                errors.push(format!(
                    "stiffness_variation_over_elevation = {}: must lie within -0.9 and 0.9",
                    self.stiffness_variation_over_elevation
                ));
            }
            finite_non_negative(
                &format!("path_damping_nm_s_per_rad[{k}]"),
                self.path_damping_nm_s_per_rad[k],
                &mut errors,
            );
            finite_non_negative(&format!("pinion_backlash_rad[{k}]"), self.pinion_backlash_rad[k], &mut errors);
            if self.pinion_backlash_rad[k] > 0.0 && self.path_damping_nm_s_per_rad[k] == 0.0 {
                errors.push(format!(
                    "path_damping_nm_s_per_rad[{k}] must be positive when pinion_backlash_rad[{k}] is: \
                     the backlash model relaxes the path spring through its damper while in the gap"
                ));
            }
        }
        finite_non_negative("turning_head_inertia_kg_m2", self.turning_head_inertia_kg_m2, &mut errors);
        finite_non_negative(
            "elevation_structure_cross_inertia_kg_m2",
            self.elevation_structure_cross_inertia_kg_m2,
            &mut errors,
        );
        finite_non_negative(
            "elevation_structure_boresight_inertia_kg_m2",
            self.elevation_structure_boresight_inertia_kg_m2,
            &mut errors,
        );
        let least_inertia = self.turning_head_inertia_kg_m2
            + self.elevation_structure_cross_inertia_kg_m2.min(self.elevation_structure_boresight_inertia_kg_m2);
        if least_inertia <= 0.0 {
            errors.push("the azimuth load inertia must be positive at every elevation".into());
        }
        self.bearing_friction.validate("bearing_friction", &mut errors);
        finite_non_negative(
            "bearing_viscous_friction_nm_s_per_rad",
            self.bearing_viscous_friction_nm_s_per_rad,
            &mut errors,
        );
        finite("torque_offset_nm", self.torque_offset_nm, &mut errors);
        self.periodic_torque.validate("periodic_torque", &mut errors);
        if self.encoder_bits > 48 {
            errors.push(format!("encoder_bits ({}) must be at most 48", self.encoder_bits));
        }
        self.sensors.validate(&mut errors);
        self.numerics.validate(&mut errors);
        into_result("azimuth", errors)
    }

    /// Load inertia about the azimuth axis at an elevation, kg m^2:
    /// `J_head + I_cross cos^2(el) + I_boresight sin^2(el)`.
    pub fn axis_inertia_kg_m2(&self, elevation_deg: f64) -> f64 {
        let (s, c) = elevation_deg.to_radians().sin_cos();
        self.turning_head_inertia_kg_m2
            + self.elevation_structure_cross_inertia_kg_m2 * c * c
            + self.elevation_structure_boresight_inertia_kg_m2 * s * s
    }

    /// The paper's reflected two-mass parameters at an elevation (exact, not grid-frozen), in
    /// the doubled form: both motors together, both paths in parallel. Assumes the two drives
    /// are identical (it uses motor 0's values for both).
    pub fn two_mass_at(&self, elevation_deg: f64) -> TwoMassParameters {
        let n2 = self.gear_ratio * self.gear_ratio;
        let m = &self.motors[0];
        let stiffness = self.path_stiffness_at(elevation_deg);
        TwoMassParameters {
            motor_inertia: 2.0 * m.inertia_kg_m2,
            motor_friction: 2.0 * m.viscous_friction_nm_s_per_rad,
            shaft_stiffness: (stiffness[0] + stiffness[1]) / n2,
            cross_coupled_damping: (self.path_damping_nm_s_per_rad[0] + self.path_damping_nm_s_per_rad[1]) / n2,
            load_inertia: self.axis_inertia_kg_m2(elevation_deg) / n2,
        }
    }

    /// Both paths' stiffness at an elevation, N m/rad (see
    /// `stiffness_variation_over_elevation`).
    pub fn path_stiffness_at(&self, elevation_deg: f64) -> [f64; 2] {
        let factor = 1.0 + self.stiffness_variation_over_elevation * (elevation_deg - 51.5) / 73.0;
        self.path_stiffness_nm_per_rad.map(|k| k * factor)
    }

    /// The elevation at which the plant's dynamics evaluate the elevation-dependent parameters
    /// (load inertia, stiffness) when the elevation input is `elevation_deg`: the centre of its
    /// parameter-grid cell.
    pub fn frozen_elevation_deg(&self, elevation_deg: f64) -> f64 {
        self.cell_centre_deg(self.cell_of(elevation_deg))
    }

    /// Undamped anti-resonance `sqrt(K_s/J_L)` at an elevation, Hz.
    pub fn anti_resonance_hz(&self, elevation_deg: f64) -> f64 {
        self.two_mass_at(elevation_deg).anti_resonance_hz()
    }

    fn cell_of(&self, elevation_deg: f64) -> i64 {
        floor(elevation_deg / self.numerics.parameter_grid_cell_deg) as i64
    }

    fn cell_centre_deg(&self, cell: i64) -> f64 {
        (cell as f64 + 0.5) * self.numerics.parameter_grid_cell_deg
    }

    fn cell_model(&self, cell: i64) -> CellModel<PATHS> {
        let n2 = self.gear_ratio * self.gear_ratio;
        CellModel {
            gear_ratio: self.gear_ratio,
            load_inertia: self.axis_inertia_kg_m2(self.cell_centre_deg(cell)) / n2,
            load_viscous: self.bearing_viscous_friction_nm_s_per_rad / n2,
            motor_inertia: self.motors.map(|m| m.inertia_kg_m2),
            motor_viscous: self.motors.map(|m| m.viscous_friction_nm_s_per_rad),
            torque_per_amp: self.motors.map(|m| m.effective_torque_constant()),
            current_loop_rad_per_s: self.motors.map(|m| std::f64::consts::TAU * m.current_loop_bandwidth_hz),
            stiffness: self.path_stiffness_at(self.cell_centre_deg(cell)).map(|k| k / n2),
            damping: self.path_damping_nm_s_per_rad.map(|c| c / n2),
            presliding_stiffness: self.motors.map(|m| {
                if m.friction.is_present() {
                    m.presliding_stiffness_nm_per_rad
                } else {
                    0.0
                }
            }),
            presliding_damping: self.motors.map(|m| m.presliding_damping_nm_s_per_rad),
        }
    }

    fn core_config(&self) -> CoreConfig<PATHS> {
        CoreConfig {
            motor_friction: self.motors.map(|m| BodyFriction::single(m.friction)),
            load_friction: BodyFriction::single(self.bearing_friction),
            backlash: self.pinion_backlash_rad.map(|b| b * self.gear_ratio),
            current_limit: self.motors.map(|m| m.current_limit_a),
            command_delay: self.motors.map(|m| m.current_command_delay_s),
            substep: self.numerics.nonlinear_substep_s,
            event_resolution: self.numerics.event_time_resolution_s,
            event_check_interval: self.numerics.event_check_interval_s,
            cache_capacity: self.numerics.cache_capacity,
            position_dependent_torques: self.has_position_dependent_torques(),
            substep_torques: self.has_position_dependent_torques(),
        }
    }

    fn has_position_dependent_torques(&self) -> bool {
        self.motors.iter().any(|m| m.cogging.amplitude_nm != 0.0) || self.periodic_torque.amplitude_nm != 0.0
    }
}

/// Inputs of the azimuth plant, held constant over a step.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct AzimuthInputs {
    /// Current commands of motor 1 and motor 2, A. Positive current drives the axis towards
    /// positive azimuth.
    pub current_command_a: [f64; 2],
    /// Disturbance torque on the load about the azimuth axis (wind), N m; positive
    /// accelerates towards positive azimuth.
    pub disturbance_torque_nm: f64,
    /// Elevation angle, deg; sets the load inertia.
    pub elevation_deg: f64,
}

/// What a telescope engineer reads from the azimuth axis.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AzimuthOutputs {
    /// Axis encoder reading, deg: the true angle with the encoder's errors, counted to whole
    /// encoder counts (rounded down by default). Unwrapped (the travel, -185 to +275 deg,
    /// exceeds a turn).
    pub encoder_position_deg: f64,
    /// Encoder reading minus true angle, arcsec.
    pub encoder_error_arcsec: f64,
    /// True axis angle, deg.
    pub axis_position_deg: f64,
    /// Axis (load) speed, deg/s.
    pub axis_speed_deg_per_s: f64,
    /// Motor shaft speed signals, rad/s: the true speeds plus the speed-signal noise (none by
    /// default).
    pub motor_speed_rad_per_s: [f64; 2],
    /// Motor currents (output of the current loops), A.
    pub motor_current_a: [f64; 2],
    /// Electromagnetic motor torques `K_phi i`, N m.
    pub motor_torque_nm: [f64; 2],
    /// Torque each pinion path delivers to the load, N m about the axis.
    pub pinion_torque_nm: [f64; 2],
    /// Which flank each pinion touches: +1 the driving-positive flank, -1 the other, 0 in the
    /// backlash gap. Always +1 without backlash.
    pub pinion_flank: [i32; 2],
}

/// The azimuth drive train. See the module documentation.
#[derive(Debug, Clone)]
pub struct AzimuthPlant {
    params: AzimuthParams,
    core: DriveCore<PATHS, STATES, INPUTS>,
    sensors: Sensors<PATHS>,
}

impl AzimuthPlant {
    /// Validates the parameters and builds the plant at rest at 0 deg azimuth.
    pub fn new(params: AzimuthParams) -> Result<Self, PlantError> {
        params.validate()?;
        let cell = params.cell_of(90.0);
        let core = DriveCore::new(params.core_config(), cell, params.cell_model(cell));
        // The load inertia J_head + I_cross cos^2 + I_boresight sin^2 is extreme at 0 and at
        // 90 deg, so the drive is fastest in one of those cells.
        core.check_rates("azimuth", [0.0, 90.0].map(|el| params.cell_model(params.cell_of(el))))?;
        let sensors = Sensors::new(params.sensors, params.encoder_bits, AZIMUTH_STREAMS);
        Ok(Self { params, core, sensors })
    }

    pub fn params(&self) -> &AzimuthParams {
        &self.params
    }

    /// Puts the axis at rest at `axis_angle_rad`: untwisted paths, both pinions centred in
    /// their backlash (taking it up is the controller's torque bias), zero currents, sticking
    /// bodies where there is friction, time zero.
    pub fn set_initial_state(&mut self, axis_angle_rad: f64) -> Result<(), PlantError> {
        if !axis_angle_rad.is_finite() {
            return Err(PlantError::InitialAngleNotFinite { axis: "azimuth", angle: axis_angle_rad });
        }
        self.core.set_at_rest(axis_angle_rad * self.params.gear_ratio);
        self.sensors.set_clock(SampleClock::default());
        Ok(())
    }

    /// Advances by `h` seconds with the inputs held constant over `[t, t + h)`. On an error
    /// the state is unchanged: also when the step itself produced a non-finite state (extreme
    /// parameters or inputs), which is then undone and reported with its likely cause.
    pub fn step(&mut self, inputs: &AzimuthInputs, h: f64) -> Result<(), PlantError> {
        if !(h.is_finite() && h > 0.0) {
            return Err(PlantError::StepNotPositive { h });
        }
        let finite_inputs = inputs.current_command_a.iter().all(|c| c.is_finite())
            && inputs.disturbance_torque_nm.is_finite()
            && inputs.elevation_deg.is_finite();
        if !finite_inputs {
            return Err(PlantError::InputsNotFinite { axis: "azimuth", inputs: Box::new(*inputs) });
        }
        let checkpoint = self.core.checkpoint();
        let cell = self.params.cell_of(inputs.elevation_deg);
        if cell != self.core.cell() {
            self.core.set_cell(cell, self.params.cell_model(cell));
        }
        let params = &self.params;
        let position_torques = |x: &SVector<f64, STATES>, model: &CellModel<PATHS>| {
            let motor = [0, 1].map(|k| params.motors[k].cogging.torque_nm(x[LOAD_ANGLE] + x[twist_index(k)]));
            (motor, params.periodic_torque.torque_nm(x[LOAD_ANGLE] / model.gear_ratio))
        };
        let load_torque = inputs.disturbance_torque_nm + params.torque_offset_nm;
        self.core.step(inputs.current_command_a, load_torque, h, &position_torques);
        if !self.core.is_finite() {
            let cause = self.core.likely_cause_of_non_finite_state(&inputs.current_command_a, load_torque);
            let params = &self.params;
            self.core.rollback(checkpoint, |cell| params.cell_model(cell));
            return Err(PlantError::NonFiniteStep { axis: "azimuth", time: self.core.time(), h, cause });
        }
        self.sensors.advance(h);
        Ok(())
    }

    /// Time since the initial state, s.
    pub fn time_s(&self) -> f64 {
        self.core.time()
    }

    pub fn outputs(&self) -> AzimuthOutputs {
        let x = self.core.state();
        let n = self.params.gear_ratio;
        let axis_angle = self.core.load_angle() / n;
        let mesh = self.core.mesh();
        let encoder = self.sensors.encoder_reading_rad(axis_angle);
        AzimuthOutputs {
            encoder_position_deg: encoder.to_degrees(),
            encoder_error_arcsec: (encoder - axis_angle) / ARCSEC,
            axis_position_deg: axis_angle.to_degrees(),
            axis_speed_deg_per_s: (x[LOAD_SPEED] / n).to_degrees(),
            motor_speed_rad_per_s: [0, 1].map(|k| self.sensors.motor_speed_signal(k, x[motor_speed_index(k)])),
            motor_current_a: [0, 1].map(|k| x[current_index(k)]),
            motor_torque_nm: [0, 1].map(|k| self.core.model().torque_per_amp[k] * x[current_index(k)]),
            pinion_torque_nm: [0, 1].map(|k| self.core.path_torque(k) * n),
            pinion_flank: mesh.map(|m| m.flank_sign()),
        }
    }

    /// The reflected two-mass parameters the simulation is using now (frozen at the centre of
    /// the current elevation cell), in the doubled form.
    pub fn two_mass_in_use(&self) -> TwoMassParameters {
        let m = self.core.model();
        TwoMassParameters {
            motor_inertia: m.motor_inertia[0] + m.motor_inertia[1],
            motor_friction: m.motor_viscous[0] + m.motor_viscous[1],
            shaft_stiffness: m.stiffness[0] + m.stiffness[1],
            cross_coupled_damping: m.damping[0] + m.damping[1],
            load_inertia: m.load_inertia,
        }
    }

    /// Number of discretised systems currently cached (bounded by twice the capacity).
    pub fn cached_discretisations(&self) -> usize {
        self.core.cached_discretisations()
    }

    /// Counters of the integrator's work since construction (steps, events, extra
    /// matrix-vector products, matrix exponentials), for performance diagnosis.
    pub fn numerics_statistics(&self) -> NumericsStatistics {
        self.core.statistics()
    }

    /// Everything that affects the future (not the caches), bitwise.
    pub fn save_state(&self) -> DriveState {
        DriveState { sensor_clock: self.sensors.clock(), ..self.core.saved_state() }
    }

    /// [`save_state`](Self::save_state) written over `state`, reusing its storage.
    pub fn save_state_into(&self, state: &mut DriveState) {
        self.core.save_into(state);
        state.sensor_clock = self.sensors.clock();
    }

    /// Restores a state written by [`save_state`](Self::save_state) of a plant with the same
    /// parameters.
    pub fn load_state(&mut self, state: DriveState) -> Result<(), StateError> {
        let mut core = self.core.clone();
        let clock = state.sensor_clock;
        let cell = core.restore(state)?;
        core.set_cell(cell, self.params.cell_model(cell));
        self.core = core;
        self.sensors.set_clock(clock);
        Ok(())
    }

    #[cfg(test)]
    pub(crate) fn core(&self) -> &DriveCore<PATHS, STATES, INPUTS> {
        &self.core
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::analytic::{current_loop_response, C64};
    use crate::drivetrain::{continuous_model, Motion};
    use nalgebra::DMatrix;

    /// A deterministic, piecewise-constant test signal in [-1, 1).
    fn signal(step: usize, seed: u64) -> f64 {
        let mut z = (step as u64).wrapping_add(seed << 32).wrapping_mul(0x9E37_79B9_7F4A_7C15);
        z = (z ^ (z >> 29)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z ^= z >> 32;
        (z >> 11) as f64 / (1u64 << 52) as f64 - 1.0
    }

    /// The paper's doubled single-motor model of a cell: one motor with twice the inertia,
    /// friction and torque constant, one path with the two stiffnesses and dampings added.
    fn doubled_core(params: &AzimuthParams, elevation_deg: f64) -> DriveCore<1, 6, 3> {
        let cell = params.cell_of(elevation_deg);
        let m = params.cell_model(cell);
        let model = CellModel {
            gear_ratio: m.gear_ratio,
            load_inertia: m.load_inertia,
            load_viscous: m.load_viscous,
            motor_inertia: [2.0 * m.motor_inertia[0]],
            motor_viscous: [2.0 * m.motor_viscous[0]],
            torque_per_amp: [2.0 * m.torque_per_amp[0]],
            current_loop_rad_per_s: [m.current_loop_rad_per_s[0]],
            stiffness: [m.stiffness[0] + m.stiffness[1]],
            damping: [m.damping[0] + m.damping[1]],
            presliding_stiffness: [m.presliding_stiffness[0] + m.presliding_stiffness[1]],
            presliding_damping: [m.presliding_damping[0] + m.presliding_damping[1]],
        };
        let c = params.core_config();
        let motor_friction = c.motor_friction[0].elements[0];
        let doubled_friction = FrictionParams {
            coulomb_nm: 2.0 * motor_friction.coulomb_nm,
            static_nm: 2.0 * motor_friction.static_nm,
            ..motor_friction
        };
        let config = CoreConfig {
            motor_friction: [BodyFriction::single(doubled_friction)],
            load_friction: c.load_friction,
            backlash: [0.0],
            current_limit: [c.current_limit[0]],
            command_delay: [c.command_delay[0]],
            substep: c.substep,
            event_resolution: c.event_resolution,
            event_check_interval: c.event_check_interval,
            cache_capacity: c.cache_capacity,
            position_dependent_torques: false,
            substep_torques: false,
        };
        DriveCore::new(config, cell, model)
    }

    fn max_relative_difference(a: &[f64], b: &[f64]) -> f64 {
        let max = b.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
        let min = b.iter().cloned().fold(f64::INFINITY, f64::min);
        a.iter().zip(b).map(|(x, y)| (x - y).abs()).fold(0.0, f64::max) / (max - min)
    }

    fn compare_with_doubled_model(params: AzimuthParams) -> [f64; 4] {
        let elevation = 52.0;
        let mut plant = AzimuthPlant::new(params).unwrap();
        plant.set_initial_state(0.1).unwrap();
        let mut single = doubled_core(&params, elevation);
        single.set_at_rest(0.1 * params.gear_ratio);
        let mut two = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
        let mut one = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
        let none = |_: &SVector<f64, 6>, _: &CellModel<1>| ([0.0], 0.0);
        let (mut stuck_seen, mut sliding_seen, mut saturated_seen) = (false, false, false);
        // Bursts of drive (long enough to saturate) separated by coasting, in which friction
        // brings the axis to rest against a disturbance below the breakaway level.
        for k in 0..3000 {
            let current = if k % 500 < 40 { 20.0 * signal(k / 20, 5) } else { 0.0 };
            let disturbance = 1e3 * signal(k / 50, 6);
            let inputs = AzimuthInputs {
                current_command_a: [current; 2],
                disturbance_torque_nm: disturbance,
                elevation_deg: elevation,
            };
            plant.step(&inputs, 1e-3).unwrap();
            single.step([current], disturbance, 1e-3, &none);
            let o = plant.outputs();
            two.0.push(o.axis_position_deg.to_radians());
            two.1.push(o.motor_speed_rad_per_s[0]);
            two.2.push(o.pinion_torque_nm[0] + o.pinion_torque_nm[1]);
            two.3.push(o.motor_speed_rad_per_s[1]);
            stuck_seen |=
                plant.core().load_motion() == Motion::Stuck && plant.core().motor_motion()[0] == Motion::Stuck;
            sliding_seen |= plant.core().load_motion() != Motion::Stuck;
            saturated_seen |= o.motor_current_a[0].abs() > 0.99 * params.motors[0].current_limit_a;
            let x = single.state();
            one.0.push(single.load_angle() / params.gear_ratio);
            one.1.push(x[motor_speed_index(0)]);
            one.2.push(single.path_torque(0) * params.gear_ratio);
            one.3.push(x[motor_speed_index(0)]);
        }
        if params.bearing_friction.is_present() {
            assert!(stuck_seen && sliding_seen, "the run must exercise sticking and sliding");
        }
        if params.motors[0].current_limit_a.is_finite() {
            assert!(saturated_seen, "the run must exercise current saturation");
        }
        [
            max_relative_difference(&two.0, &one.0),
            max_relative_difference(&two.1, &one.1),
            max_relative_difference(&two.2, &one.2),
            max_relative_difference(&two.3, &one.3),
        ]
    }

    #[test]
    fn the_stiffness_varies_linearly_over_the_travel_and_the_dynamics_follow_it() {
        let p = AzimuthParams { stiffness_variation_over_elevation: 0.3, ..AzimuthParams::default() };
        let nominal = AzimuthParams::default();
        let ratio = |el: f64| p.path_stiffness_at(el)[0] / nominal.path_stiffness_nm_per_rad[0];
        assert!((ratio(15.0) - 0.85).abs() < 1e-12 && (ratio(88.0) - 1.15).abs() < 1e-12);
        assert!((ratio(51.5) - 1.0).abs() < 1e-12);
        // The anti-resonance moves with the square root of the stiffness.
        let f = |q: &AzimuthParams, el: f64| q.anti_resonance_hz(el);
        assert!((f(&p, 88.0) / f(&nominal, 88.0) - 1.15f64.sqrt()).abs() < 1e-12);
        // The drive's cell model takes the stiffness at the cell centre.
        let cell = p.cell_of(88.0);
        let model = p.cell_model(cell);
        let expected = p.path_stiffness_at(p.cell_centre_deg(cell))[0] / (p.gear_ratio * p.gear_ratio);
        assert_eq!(model.stiffness[0], expected);
        let bad = AzimuthParams { stiffness_variation_over_elevation: 1.5, ..AzimuthParams::default() };
        assert!(bad.validate().unwrap_err().to_string().contains("stiffness_variation_over_elevation"));
    }

    #[test]
    fn two_equal_motors_reduce_exactly_to_the_doubled_single_motor_model() {
        let differences = compare_with_doubled_model(AzimuthParams::linear());
        println!("linear: two motors vs doubled model, relative to range: {differences:?}");
        for d in differences {
            assert!(d < 1e-11, "two-motor and doubled models differ by {d:e} of the range");
        }
    }

    #[test]
    fn with_friction_and_saturation_but_no_backlash_the_two_motor_model_still_reduces_to_the_doubled_one() {
        let params = AzimuthParams { pinion_backlash_rad: [0.0; 2], ..AzimuthParams::default() };
        let differences = compare_with_doubled_model(params);
        println!("friction and saturation: two motors vs doubled model, relative to range: {differences:?}");
        for d in differences {
            assert!(d < 1e-9, "two-motor and doubled models differ by {d:e} of the range");
        }
    }

    /// `C (sI - A)^{-1} b` for the continuous model in the all-sliding, all-contact mode.
    fn state_space_response(model: &CellModel<2>, output: usize, inputs: &[usize], s: C64) -> C64 {
        let (a, b) = continuous_model(model, 0);
        let n = a.nrows();
        let mut m = DMatrix::<C64>::zeros(n, n);
        let mut rhs = DMatrix::<C64>::zeros(n, 1);
        for r in 0..n {
            for c in 0..n {
                m[(r, c)] = C64::new(-a[(r, c)], 0.0);
            }
            m[(r, r)] += s;
            rhs[(r, 0)] = inputs.iter().map(|&i| C64::new(b[(r, i)], 0.0)).sum();
        }
        m.lu().solve(&rhs).unwrap()[(output, 0)]
    }

    #[test]
    fn state_space_model_has_the_frequency_response_of_corrected_eq_1_with_added_path_stiffnesses() {
        let params = AzimuthParams::linear();
        for elevation in [15.0, 50.0, 88.0] {
            let cell = params.cell_of(elevation);
            let model = params.cell_model(cell);
            let two_mass = TwoMassParameters {
                load_inertia: model.load_inertia,
                ..TwoMassParameters::two_identical_motors(
                    model.motor_inertia[0],
                    model.motor_viscous[0],
                    model.stiffness[0],
                    model.damping[0],
                    model.load_inertia,
                )
            };
            let kt = 2.0 * model.torque_per_amp[0];
            let bandwidth = params.motors[0].current_loop_bandwidth_hz;
            for omega in [0.5, 20.0, 100.0, 130.0, 160.0, 400.0, 3000.0] {
                let s = C64::new(0.0, omega);
                let expected_speed = kt * current_loop_response(s, bandwidth) * two_mass.motor_speed_per_torque(s);
                let speed = state_space_response(&model, motor_speed_index(0), &[0, 1], s);
                assert!(
                    (speed / expected_speed - 1.0).norm() < 1e-9,
                    "el {elevation}, omega {omega}: {speed} vs {expected_speed}"
                );
                let expected_load = kt * current_loop_response(s, bandwidth) * two_mass.load_position_per_torque(s);
                let load = state_space_response(&model, LOAD_ANGLE, &[0, 1], s);
                assert!(
                    (load / expected_load - 1.0).norm() < 1e-9,
                    "el {elevation}, omega {omega}: {load} vs {expected_load}"
                );
            }
        }
    }

    #[test]
    fn default_design_meets_its_documented_targets() {
        let p = AzimuthParams::default();
        let f15 = p.anti_resonance_hz(15.0);
        assert!((20.0..=25.0).contains(&f15), "anti-resonance at 15 deg is {f15} Hz");
        let f_min = (0..=77).map(|k| p.anti_resonance_hz(15.0 + k as f64)).fold(f64::INFINITY, f64::min);
        assert!(f_min > 15.0, "a 10-15 Hz velocity loop needs the anti-resonance above 15 Hz, lowest is {f_min}");
        let motor_rpm = p.gear_ratio * 2f64.to_radians() * 60.0 / std::f64::consts::TAU;
        assert!(motor_rpm <= 3000.0 * 1.001, "2 deg/s needs {motor_rpm} rpm");
        assert!(p.axis_inertia_kg_m2(90.0) > p.axis_inertia_kg_m2(0.0), "a dish about its axis has more inertia");
        for el in [15.0, 50.0, 88.0] {
            let t = p.two_mass_at(el);
            let ratio = t.load_inertia / t.motor_inertia;
            assert!((0.3..=3.0).contains(&ratio), "reflected load to motor inertia {ratio} at {el} deg");
            let zeta = t.anti_resonance_damping_ratio();
            assert!((0.03..=0.08).contains(&zeta), "anti-resonance damping ratio {zeta} at {el} deg");
        }
    }

    #[test]
    fn parameters_too_fast_for_the_discretisation_are_refused_with_the_rate_named() {
        // The values the audit set through the FMU, which made every step return NaN (or, from
        // 1e50 N m/rad on, never return), and a damping so small beside backlash that the
        // spring's relaxation in the gap is as extreme.
        let d = AzimuthParams::default();
        let mut bandwidth = d;
        bandwidth.motors[1].current_loop_bandwidth_hz = 1e300;
        let cases = [
            (
                "stiffness",
                AzimuthParams { path_stiffness_nm_per_rad: [1e308, 7.3e9], ..d },
                "stiffness of path 1 / damping of path 1",
            ),
            (
                "damping",
                AzimuthParams { path_damping_nm_s_per_rad: [5.3e6, 1e308], ..d },
                "damping of path 2 / motor inertia",
            ),
            (
                "tiny damping",
                AzimuthParams { path_damping_nm_s_per_rad: [1e-100, 5.3e6], ..d },
                "relaxation in the backlash gap",
            ),
            ("bandwidth", bandwidth, "current-loop bandwidth of motor 2"),
            // Extreme only near 0 deg elevation, not in the 90 deg cell the plant starts in.
            (
                "load inertia at the horizon",
                AzimuthParams {
                    turning_head_inertia_kg_m2: 0.0,
                    elevation_structure_cross_inertia_kg_m2: 1e-9,
                    elevation_structure_boresight_inertia_kg_m2: 1e-3,
                    ..d
                },
                "load inertia",
            ),
        ];
        for (what, params, source) in cases {
            let error = AzimuthPlant::new(params).expect_err(what).to_string();
            assert!(error.contains(source) && error.contains("fastest rate"), "{what}: {error}");
        }
        // The defaults are seven decades below the bound.
        let (rate, _) = AzimuthPlant::new(d).unwrap().core().fastest_rate();
        assert!(rate < 2e3, "default fastest rate {rate}");
    }

    #[test]
    fn a_state_saved_over_a_kept_one_equals_a_fresh_save() {
        // The runtime keeps one state and saves over it before every step; the delay lines
        // change length as commands come and go, so the kept vectors must be rewritten whole.
        let mut params = AzimuthParams::default();
        params.motors[0].current_command_delay_s = 2.5e-3;
        let mut plant = AzimuthPlant::new(params).unwrap();
        let mut kept = plant.save_state();
        for k in 0..200 {
            let constant_run = if k % 7 < 3 { 0 } else { k };
            let inputs = AzimuthInputs {
                current_command_a: [signal(constant_run, 3), signal(k, 4)],
                disturbance_torque_nm: 1e4,
                elevation_deg: 45.0,
            };
            plant.step(&inputs, if k % 5 == 0 { 4e-3 } else { 1e-3 }).unwrap();
            plant.save_state_into(&mut kept);
            assert_eq!(kept, plant.save_state(), "step {k}");
        }
    }

    #[test]
    fn a_step_that_overflows_is_undone_and_reported_with_its_cause() {
        // A disturbance of 1e308 N m accelerates the axis until its angle overflows after some
        // 43 s. A command delay is on so that the delay lines must be restored too.
        let mut params = AzimuthParams::default();
        params.motors[0].current_command_delay_s = 2.5e-3;
        let mut plant = AzimuthPlant::new(params).unwrap();
        let mut failure = None;
        for k in 0..100_000 {
            let inputs = AzimuthInputs {
                current_command_a: [signal(k, 3), signal(k, 4)],
                disturbance_torque_nm: 1e308,
                elevation_deg: 45.0,
            };
            // Compared as the FMU state's bytes: bit for bit, -0.0 and NaN included.
            let before = postcard::to_allocvec(&plant.save_state()).unwrap();
            let outputs = plant.outputs();
            if let Err(error) = plant.step(&inputs, 1e-3) {
                failure = Some((k, error.to_string(), before, outputs));
                break;
            }
        }
        let (k, error, before, outputs) = failure.expect("the state never overflowed");
        assert!(k > 1000, "the overflow came after {k} steps, too early to be the disturbance's doing");
        assert!(error.contains("non-finite") && error.contains("load torque 1e308"), "{error}");
        let after = postcard::to_allocvec(&plant.save_state()).unwrap();
        assert!(after == before, "the failed step changed the saved state");
        assert_eq!(plant.outputs(), outputs, "the failed step changed the outputs");
        assert!(plant.outputs().axis_position_deg.is_finite());
    }

    #[test]
    fn bodies_start_sticking_where_there_is_friction() {
        let plant = AzimuthPlant::new(AzimuthParams::default()).unwrap();
        assert_eq!(plant.core().load_motion(), Motion::Stuck);
        assert_eq!(plant.core().motor_motion(), [Motion::Stuck; 2]);
        let linear = AzimuthPlant::new(AzimuthParams::linear()).unwrap();
        assert_eq!(linear.core().load_motion(), Motion::Forward);
    }
}
