//! The elevation axis: one motor driving the dish through a gearbox and a preloaded jackscrew.
//!
//! The jackscrew runs from a trunnion on the yoke to an attachment on the dish's backup
//! structure. As the dish turns about its pivot the actuator length `L(el)` changes, and with it
//! the lever arm `h(el) = dL/d(el)`, the transmission ratio seen at the motor
//! `N(el) = (2 pi G / lead) h(el)` and the axial stiffness `k(L)` of the screw (the nut moves
//! along a screw held axially at both ends, so the two screw segments act in parallel, in series
//! with the bearings, nut, housing and attachments). The dish is balanced about the pivot, so
//! its inertia about the axis is constant; reflected to the motor it is `J / N(el)^2`, which is
//! not. The stiffness and damping reflected to the motor are `k / n_s^2` and `c / n_s^2` with
//! `n_s = 2 pi G / lead` (motor radians per metre of nut travel), independent of the lever arm;
//! about the axis they are `k h^2` and `c h^2`.
//!
//! The load coordinate of the drive train is the actuator length in motor radians,
//! `s_L = n_s (L(el) - L(0))`, so that the twist `theta_M - s_L` (the nut's axial deflection
//! times `n_s`) and its rate are exact whatever the angle: the kinematics are never frozen.
//! Only the reflected load inertia `J / N^2`, the reflection of load torques and the stiffness
//! are frozen per grid cell. In these coordinates the load's equation gains the curvature term
//! `d^2 s_L/dt^2 = N dw/dt + N' w^2`; it is small (tens of N m equivalent at full slew speed)
//! and enters as a torque held over each piece of a step.

use fmu_runtime::state::StateError;

use crate::error::PlantError;

use crate::drivetrain::DriveState;
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
use crate::sensors::{SampleClock, SensorParams, Sensors, ARCSEC, ELEVATION_STREAMS};

const PATHS: usize = 1;
const STATES: usize = 2 + 4 * PATHS;
const INPUTS: usize = 2 * PATHS + 1;

/// Geometry, stiffness and friction of the elevation jackscrew.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct JackscrewParams {
    /// Distance from the elevation pivot to the actuator's attachment on the dish, m.
    pub dish_attachment_radius_m: f64,
    /// Distance from the elevation pivot to the actuator's trunnion on the yoke, m.
    pub yoke_attachment_radius_m: f64,
    /// Angle at the pivot between the two attachment radii at 0 deg elevation, deg. It grows
    /// one-for-one with elevation, and the actuator extends as it grows.
    pub attachment_angle_at_zero_elevation_deg: f64,
    /// Screw lead, m of nut travel per screw revolution.
    pub screw_lead_m: f64,
    /// Gearbox ratio between motor and screw, motor revolutions per screw revolution.
    pub gearbox_ratio: f64,
    /// Length of screw between its two axial bearings, m.
    pub screw_length_between_bearings_m: f64,
    /// Actuator length minus the nut's distance from the first bearing, m: the nut sits at
    /// `L(el) - nut_offset_m` along the screw.
    pub nut_offset_m: f64,
    /// Axial rigidity `E A` of the screw's root section, N.
    pub screw_axial_rigidity_n: f64,
    /// True if the screw is held axially at both ends (the two segments either side of the nut
    /// then carry the load in parallel); false for a screw held at the first bearing only.
    pub screw_fixed_at_both_ends: bool,
    /// Axial stiffness of everything in series with the screw (bearings, nut, housing,
    /// trunnion, attachments), N/m.
    pub series_stiffness_n_per_m: f64,
    /// Axial damping of the drive path, N s/m.
    pub axial_damping_n_s_per_m: f64,
    /// Axial backlash (total free play) of the nut, m. 0 for the preloaded nut.
    pub axial_backlash_m: f64,
    /// Coulomb and static friction of the preloaded nut and screw bearings, N m at the screw
    /// (preload drag and seals). Referred to the motor through the gearbox.
    pub screw_friction: FrictionParams,
}

impl JackscrewParams {
    /// Motor radians per metre of nut travel, `2 pi G / lead`.
    pub fn motor_rad_per_m(&self) -> f64 {
        std::f64::consts::TAU * self.gearbox_ratio / self.screw_lead_m
    }

    fn attachment_angle_rad(&self, elevation_rad: f64) -> f64 {
        self.attachment_angle_at_zero_elevation_deg.to_radians() + elevation_rad
    }

    /// Actuator length (trunnion to dish attachment) at an elevation, m.
    pub fn actuator_length_m(&self, elevation_rad: f64) -> f64 {
        let (rd, ry) = (self.dish_attachment_radius_m, self.yoke_attachment_radius_m);
        (rd * rd + ry * ry - 2.0 * rd * ry * self.attachment_angle_rad(elevation_rad).cos()).sqrt()
    }

    /// Lever arm `h = dL/d(el)`, m per rad: the perpendicular distance from the pivot to the
    /// actuator's line of action.
    pub fn lever_arm_m(&self, elevation_rad: f64) -> f64 {
        let (rd, ry) = (self.dish_attachment_radius_m, self.yoke_attachment_radius_m);
        rd * ry * self.attachment_angle_rad(elevation_rad).sin() / self.actuator_length_m(elevation_rad)
    }

    /// Position of the nut along the screw, measured from the first bearing, m.
    pub fn nut_position_m(&self, elevation_rad: f64) -> f64 {
        self.actuator_length_m(elevation_rad) - self.nut_offset_m
    }

    /// Axial stiffness of the whole drive path at an elevation, N/m.
    pub fn axial_stiffness_n_per_m(&self, elevation_rad: f64) -> f64 {
        let a = self.nut_position_m(elevation_rad);
        let ea = self.screw_axial_rigidity_n;
        let screw = if self.screw_fixed_at_both_ends {
            ea / a + ea / (self.screw_length_between_bearings_m - a)
        } else {
            ea / a
        };
        1.0 / (1.0 / screw + 1.0 / self.series_stiffness_n_per_m)
    }

    /// Transmission ratio at an elevation, motor rad per axis rad.
    pub fn ratio(&self, elevation_rad: f64) -> f64 {
        self.motor_rad_per_m() * self.lever_arm_m(elevation_rad)
    }

    fn validate(&self, travel_deg: (f64, f64), errors: &mut Vec<String>) {
        finite_positive("jackscrew.dish_attachment_radius_m", self.dish_attachment_radius_m, errors);
        finite_positive("jackscrew.yoke_attachment_radius_m", self.yoke_attachment_radius_m, errors);
        finite("jackscrew.attachment_angle_at_zero_elevation_deg", self.attachment_angle_at_zero_elevation_deg, errors);
        finite_positive("jackscrew.screw_lead_m", self.screw_lead_m, errors);
        finite_positive("jackscrew.gearbox_ratio", self.gearbox_ratio, errors);
        finite_positive("jackscrew.screw_length_between_bearings_m", self.screw_length_between_bearings_m, errors);
        finite("jackscrew.nut_offset_m", self.nut_offset_m, errors);
        finite_positive("jackscrew.screw_axial_rigidity_n", self.screw_axial_rigidity_n, errors);
        finite_positive("jackscrew.series_stiffness_n_per_m", self.series_stiffness_n_per_m, errors);
        finite_non_negative("jackscrew.axial_damping_n_s_per_m", self.axial_damping_n_s_per_m, errors);
        finite_non_negative("jackscrew.axial_backlash_m", self.axial_backlash_m, errors);
        if self.axial_backlash_m > 0.0 && self.axial_damping_n_s_per_m == 0.0 {
            errors.push(
                "jackscrew.axial_damping_n_s_per_m must be positive when jackscrew.axial_backlash_m is: \
                 the backlash model relaxes the path spring through its damper while in the gap"
                    .into(),
            );
        }
        self.screw_friction.validate("jackscrew.screw_friction", errors);
        if !errors.is_empty() {
            return;
        }
        // The geometry must be valid over the whole travel: the actuator must not pass through
        // the pivot (positive lever arm) and the nut must stay on the screw.
        let samples = 1000;
        for j in 0..=samples {
            let el_deg = travel_deg.0 + (travel_deg.1 - travel_deg.0) * j as f64 / samples as f64;
            let el = el_deg.to_radians();
            let angle = self.attachment_angle_rad(el).to_degrees();
            if !(angle > 0.0 && angle < 180.0) {
                errors.push(format!(
                    "jackscrew geometry: the attachment angle ({angle:.2} deg at {el_deg:.2} deg elevation) \
                     must stay between 0 and 180 deg over the travel, or the lever arm vanishes"
                ));
                return;
            }
            let a = self.nut_position_m(el);
            let end = if self.screw_fixed_at_both_ends { self.screw_length_between_bearings_m } else { f64::INFINITY };
            if !(a > 0.0 && a < end) {
                errors.push(format!(
                    "jackscrew geometry: the nut ({a:.3} m from the first bearing at {el_deg:.2} deg elevation) \
                     must stay between the bearings over the travel"
                ));
                return;
            }
        }
    }
}

/// Physical parameters of the elevation axis. Axis-side values are about the elevation axis.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ElevationParams {
    /// The elevation motor with its gearbox input stage, current loop and own friction.
    pub motor: MotorParams,
    /// Jackscrew geometry, stiffness, backlash and friction.
    pub jackscrew: JackscrewParams,
    /// Inertia of the elevation structure about the elevation axis, kg m^2. Constant: the dish
    /// is balanced about the pivot.
    pub dish_inertia_kg_m2: f64,
    /// Coulomb and static friction of the elevation pivot bearings, N m about the axis.
    pub pivot_friction: FrictionParams,
    /// Viscous friction of the pivot bearings, N m s/rad about the axis (0 in the paper's model).
    pub pivot_viscous_friction_nm_s_per_rad: f64,
    /// Gravity unbalance moment `m g r`, N m. The torque about the axis (positive raises the
    /// dish) is `-m g r cos(el + phase)`: a positive moment with zero phase is a nose-heavy dish,
    /// pulled down most at the horizon. 0 (the default) is balanced.
    pub unbalance_moment_nm: f64,
    /// Phase of the unbalance torque, deg.
    pub unbalance_phase_deg: f64,
    /// Constant torque on the load, N m about the axis. 0 (the default) is off.
    pub torque_offset_nm: f64,
    /// Position-periodic torque on the load. Off by default.
    pub periodic_torque: PeriodicTorqueParams,
    /// Lower end of the travel range, deg. Geometry is validated over the travel, and the
    /// angle-dependent parameters are held at their end values outside it (there are no end
    /// stops in the model).
    pub travel_min_deg: f64,
    /// Upper end of the travel range, deg.
    pub travel_max_deg: f64,
    /// Freeze the jackscrew geometry (ratio, stiffness, reflected inertia, kinematics) at
    /// `frozen_geometry_elevation_deg`. The axis is then linear time-invariant: exactly the
    /// paper's Eq. 1 with that angle's parameters, whatever the motion. Default false.
    pub geometry_frozen: bool,
    /// Elevation at which the geometry is frozen when `geometry_frozen` is set, deg.
    pub frozen_geometry_elevation_deg: f64,
    /// Resolution of the axis encoder, bits per turn; 0 means unquantised.
    pub encoder_bits: u32,
    /// Encoder errors and speed-signal noise (ideal by default).
    pub sensors: SensorParams<1>,
    /// Numerical scheme settings.
    pub numerics: NumericsParams,
}

impl Default for ElevationParams {
    /// MeerKAT-like values; `docs/plant-model.md` gives the reasoning for each.
    fn default() -> Self {
        Self {
            motor: MotorParams {
                inertia_kg_m2: 0.002,
                viscous_friction_nm_s_per_rad: 5.0e-4,
                friction: FrictionParams::coulomb_and_static(0.15, 0.2),
                torque_constant_nm_per_a: 0.8,
                torque_constant_scale: 1.0,
                current_limit_a: 15.0,
                current_loop_bandwidth_hz: 100.0,
                current_command_delay_s: 0.0,
                cogging: CoggingParams::NONE,
                presliding_stiffness_nm_per_rad: 0.0,
                presliding_damping_nm_s_per_rad: 0.0,
            },
            jackscrew: JackscrewParams {
                dish_attachment_radius_m: 2.0,
                yoke_attachment_radius_m: 3.6,
                attachment_angle_at_zero_elevation_deg: 20.0,
                screw_lead_m: 0.02,
                gearbox_ratio: 28.0,
                screw_length_between_bearings_m: 3.5,
                nut_offset_m: 1.57,
                screw_axial_rigidity_n: 1.65e9,
                screw_fixed_at_both_ends: true,
                series_stiffness_n_per_m: 5.0e9,
                axial_damping_n_s_per_m: 1.4e6,
                axial_backlash_m: 0.0,
                screw_friction: FrictionParams::coulomb_and_static(8.0, 10.0),
            },
            dish_inertia_kg_m2: 3.5e5,
            pivot_friction: FrictionParams::coulomb_and_static(500.0, 650.0),
            pivot_viscous_friction_nm_s_per_rad: 0.0,
            unbalance_moment_nm: 0.0,
            unbalance_phase_deg: 0.0,
            torque_offset_nm: 0.0,
            periodic_torque: PeriodicTorqueParams::NONE,
            travel_min_deg: 15.0,
            travel_max_deg: 92.0,
            geometry_frozen: false,
            frozen_geometry_elevation_deg: 15.0,
            encoder_bits: 25,
            sensors: SensorParams::default(),
            numerics: NumericsParams::default(),
        }
    }
}

impl ElevationParams {
    /// The paper's linear Eq. 1 configuration: viscous motor friction `B_M` only, no Coulomb or
    /// static friction, no backlash, no saturation, no quantisation, no extra torques, and the
    /// geometry frozen at 15 deg (the angle of the paper's Figs. 8 and 9; set
    /// `frozen_geometry_elevation_deg` for another, or clear `geometry_frozen` to keep the
    /// angle dependence with the linear drive).
    pub fn linear() -> Self {
        let d = Self::default();
        Self {
            motor: d.motor.linearised(),
            jackscrew: JackscrewParams { axial_backlash_m: 0.0, screw_friction: FrictionParams::NONE, ..d.jackscrew },
            pivot_friction: FrictionParams::NONE,
            pivot_viscous_friction_nm_s_per_rad: 0.0,
            unbalance_moment_nm: 0.0,
            torque_offset_nm: 0.0,
            periodic_torque: PeriodicTorqueParams::NONE,
            geometry_frozen: true,
            frozen_geometry_elevation_deg: 15.0,
            encoder_bits: 0,
            sensors: SensorParams::default(),
            ..d
        }
    }

    /// Checks every field; the message names each offending field and its constraint.
    pub fn validate(&self) -> Result<(), PlantError> {
        let mut errors = Vec::new();
        self.motor.validate("motor", &mut errors);
        finite_positive("dish_inertia_kg_m2", self.dish_inertia_kg_m2, &mut errors);
        self.pivot_friction.validate("pivot_friction", &mut errors);
        finite_non_negative(
            "pivot_viscous_friction_nm_s_per_rad",
            self.pivot_viscous_friction_nm_s_per_rad,
            &mut errors,
        );
        finite("unbalance_moment_nm", self.unbalance_moment_nm, &mut errors);
        finite("unbalance_phase_deg", self.unbalance_phase_deg, &mut errors);
        finite("torque_offset_nm", self.torque_offset_nm, &mut errors);
        self.periodic_torque.validate("periodic_torque", &mut errors);
        if self.encoder_bits > 48 {
            errors.push(format!("encoder_bits ({}) must be at most 48", self.encoder_bits));
        }
        self.sensors.validate(&mut errors);
        self.numerics.validate(&mut errors);
        let travel_ok = self.travel_min_deg.is_finite()
            && self.travel_max_deg.is_finite()
            && self.travel_min_deg < self.travel_max_deg;
        if !self.frozen_geometry_elevation_deg.is_finite() {
            errors
                .push(format!("frozen_geometry_elevation_deg ({}) must be finite", self.frozen_geometry_elevation_deg));
        }
        if travel_ok {
            self.jackscrew.validate((self.travel_min_deg, self.travel_max_deg), &mut errors);
        } else {
            errors.push(format!(
                "travel_min_deg ({}) must be finite and below travel_max_deg ({})",
                self.travel_min_deg, self.travel_max_deg
            ));
        }
        into_result("elevation", errors)
    }

    fn clamp_to_travel_rad(&self, elevation_deg: f64) -> f64 {
        elevation_deg.clamp(self.travel_min_deg, self.travel_max_deg).to_radians()
    }

    /// Transmission ratio at an elevation (held at its end value outside the travel), motor
    /// rad per axis rad.
    pub fn ratio_at(&self, elevation_deg: f64) -> f64 {
        self.jackscrew.ratio(self.clamp_to_travel_rad(elevation_deg))
    }

    /// Stiffness of the drive about the elevation axis, `k(L) h^2`, N m/rad.
    pub fn axis_stiffness_at(&self, elevation_deg: f64) -> f64 {
        let el = self.clamp_to_travel_rad(elevation_deg);
        let h = self.jackscrew.lever_arm_m(el);
        self.jackscrew.axial_stiffness_n_per_m(el) * h * h
    }

    /// The paper's reflected two-mass parameters at an elevation (exact, not grid-frozen).
    pub fn two_mass_at(&self, elevation_deg: f64) -> TwoMassParameters {
        let el = self.clamp_to_travel_rad(elevation_deg);
        let ns = self.jackscrew.motor_rad_per_m();
        let n = self.jackscrew.ratio(el);
        TwoMassParameters {
            motor_inertia: self.motor.inertia_kg_m2,
            motor_friction: self.motor.viscous_friction_nm_s_per_rad,
            shaft_stiffness: self.jackscrew.axial_stiffness_n_per_m(el) / (ns * ns),
            cross_coupled_damping: self.jackscrew.axial_damping_n_s_per_m / (ns * ns),
            load_inertia: self.dish_inertia_kg_m2 / (n * n),
        }
    }

    /// Undamped anti-resonance `sqrt(K_s/J_L)` at an elevation, Hz.
    pub fn anti_resonance_hz(&self, elevation_deg: f64) -> f64 {
        self.two_mass_at(elevation_deg).anti_resonance_hz()
    }

    /// Grid cell of an elevation. Angles beyond the travel share the end cells: their
    /// parameters are the end values anyway, so no discretisations are wasted on them. A
    /// frozen geometry has the single cell 0.
    fn cell_of(&self, elevation_deg: f64) -> i64 {
        if self.geometry_frozen {
            return 0;
        }
        let clamped = elevation_deg.clamp(self.travel_min_deg, self.travel_max_deg);
        crate::floor::floor(clamped / self.numerics.parameter_grid_cell_deg) as i64
    }

    /// The elevation whose parameters a cell uses.
    fn cell_centre_deg(&self, cell: i64) -> f64 {
        if self.geometry_frozen {
            self.frozen_geometry_elevation_deg
        } else {
            (cell as f64 + 0.5) * self.numerics.parameter_grid_cell_deg
        }
    }

    fn cell_model(&self, cell: i64) -> CellModel<PATHS> {
        let centre = self.cell_centre_deg(cell);
        let two_mass = self.two_mass_at(centre);
        let n = self.ratio_at(centre);
        CellModel {
            gear_ratio: n,
            load_inertia: two_mass.load_inertia,
            load_viscous: self.pivot_viscous_friction_nm_s_per_rad / (n * n),
            motor_inertia: [self.motor.inertia_kg_m2],
            motor_viscous: [self.motor.viscous_friction_nm_s_per_rad],
            torque_per_amp: [self.motor.effective_torque_constant()],
            current_loop_rad_per_s: [std::f64::consts::TAU * self.motor.current_loop_bandwidth_hz],
            stiffness: [two_mass.shaft_stiffness],
            damping: [two_mass.cross_coupled_damping],
            presliding_stiffness: [0.0],
            presliding_damping: [0.0],
        }
    }

    fn core_config(&self) -> CoreConfig<PATHS> {
        let screw_at_motor = self.jackscrew.screw_friction.referred_through(self.jackscrew.gearbox_ratio);
        CoreConfig {
            motor_friction: [BodyFriction { elements: [self.motor.friction, screw_at_motor] }],
            load_friction: BodyFriction::single(self.pivot_friction),
            backlash: [self.jackscrew.axial_backlash_m * self.jackscrew.motor_rad_per_m()],
            current_limit: [self.motor.current_limit_a],
            command_delay: [self.motor.current_command_delay_s],
            substep: self.numerics.nonlinear_substep_s,
            event_resolution: self.numerics.event_time_resolution_s,
            event_check_interval: self.numerics.event_check_interval_s,
            cache_capacity: self.numerics.cache_capacity,
            // The curvature term of a varying ratio is evaluated at every piece; it varies with
            // the speed, slowly, so it needs no sub-steps of its own.
            position_dependent_torques: !self.geometry_frozen || self.has_fast_position_dependent_torques(),
            substep_torques: self.has_fast_position_dependent_torques(),
        }
    }

    fn has_fast_position_dependent_torques(&self) -> bool {
        self.motor.cogging.amplitude_nm != 0.0
            || self.periodic_torque.amplitude_nm != 0.0
            || self.unbalance_moment_nm != 0.0
    }

    /// Gravity torque about the axis at an elevation, N m (positive raises the dish).
    pub fn unbalance_torque_nm(&self, elevation_rad: f64) -> f64 {
        -self.unbalance_moment_nm * (elevation_rad + self.unbalance_phase_deg.to_radians()).cos()
    }
}

/// The elevation kinematics in terms of the drive train's load coordinate, the actuator
/// length from its 0 deg value in motor radians, `s_L = n_s (L(el) - L(0))`; or, with a frozen
/// geometry, `s_L = N el`. Beyond the travel, where the model has no end stops and the real
/// geometry may not even exist, it continues linearly with the end ratio, consistent with the
/// parameters being held at their end values there. The constants are computed once, so that
/// a step needs one square root for the ratio and one arccosine for the angle.
#[derive(Debug, Clone, Copy)]
struct Kinematics {
    frozen_ratio: Option<f64>,
    motor_rad_per_m: f64,
    length_at_zero: f64,
    /// `r_d r_y` and `r_d^2 + r_y^2`.
    radii_product: f64,
    radii_squares: f64,
    angle_offset: f64,
    low: TravelEnd,
    high: TravelEnd,
}

#[derive(Debug, Clone, Copy)]
struct TravelEnd {
    angle: f64,
    position: f64,
    ratio: f64,
}

impl Kinematics {
    fn new(params: &ElevationParams) -> Self {
        let j = &params.jackscrew;
        let exact_position = |el: f64| j.motor_rad_per_m() * (j.actuator_length_m(el) - j.actuator_length_m(0.0));
        let end = |deg: f64| {
            let angle = deg.to_radians();
            TravelEnd { angle, position: exact_position(angle), ratio: j.ratio(angle) }
        };
        Self {
            frozen_ratio: params.geometry_frozen.then(|| params.ratio_at(params.frozen_geometry_elevation_deg)),
            motor_rad_per_m: j.motor_rad_per_m(),
            length_at_zero: j.actuator_length_m(0.0),
            radii_product: j.dish_attachment_radius_m * j.yoke_attachment_radius_m,
            radii_squares: j.dish_attachment_radius_m.powi(2) + j.yoke_attachment_radius_m.powi(2),
            angle_offset: j.attachment_angle_at_zero_elevation_deg.to_radians(),
            low: end(params.travel_min_deg),
            high: end(params.travel_max_deg),
        }
    }

    /// The load coordinate of an elevation, motor rad.
    fn position_of(&self, elevation_rad: f64) -> f64 {
        if let Some(ratio) = self.frozen_ratio {
            return ratio * elevation_rad;
        }
        if elevation_rad < self.low.angle {
            return self.low.position + self.low.ratio * (elevation_rad - self.low.angle);
        }
        if elevation_rad > self.high.angle {
            return self.high.position + self.high.ratio * (elevation_rad - self.high.angle);
        }
        let cosine = (elevation_rad + self.angle_offset).cos();
        let length = (self.radii_squares - 2.0 * self.radii_product * cosine).sqrt();
        self.motor_rad_per_m * (length - self.length_at_zero)
    }

    /// Cosine of the attachment angle for a load coordinate within the travel.
    fn attachment_cosine(&self, position: f64) -> (f64, f64) {
        let length = self.length_at_zero + position / self.motor_rad_per_m;
        let cosine = ((self.radii_squares - length * length) / (2.0 * self.radii_product)).clamp(-1.0, 1.0);
        (cosine, length)
    }

    /// The elevation of a load coordinate, rad.
    fn angle_of(&self, position: f64) -> f64 {
        if let Some(ratio) = self.frozen_ratio {
            return position / ratio;
        }
        if position < self.low.position {
            return self.low.angle + (position - self.low.position) / self.low.ratio;
        }
        if position > self.high.position {
            return self.high.angle + (position - self.high.position) / self.high.ratio;
        }
        self.attachment_cosine(position).0.acos() - self.angle_offset
    }

    /// The ratio `N = n_s h` and its slope `dN/d(el) = n_s (r_d r_y cos(alpha) - h^2) / L` at a
    /// load coordinate; the slope is zero where the kinematics are linear.
    fn ratio_and_slope(&self, position: f64) -> (f64, f64) {
        if let Some(ratio) = self.frozen_ratio {
            return (ratio, 0.0);
        }
        if position < self.low.position {
            return (self.low.ratio, 0.0);
        }
        if position > self.high.position {
            return (self.high.ratio, 0.0);
        }
        let (cosine, length) = self.attachment_cosine(position);
        let sine = (1.0 - cosine * cosine).sqrt();
        let lever_arm = self.radii_product * sine / length;
        let slope = (self.radii_product * cosine - lever_arm * lever_arm) / length;
        (self.motor_rad_per_m * lever_arm, self.motor_rad_per_m * slope)
    }

    /// Actuator length at a load coordinate (continuing linearly beyond the travel), m.
    fn length_of(&self, position: f64) -> f64 {
        self.length_at_zero + position / self.motor_rad_per_m
    }
}

/// Inputs of the elevation plant, held constant over a step.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ElevationInputs {
    /// Motor current command, A. Positive current extends the jackscrew and raises the dish.
    pub current_command_a: f64,
    /// Disturbance torque on the dish about the elevation axis (wind), N m; positive raises it.
    pub disturbance_torque_nm: f64,
}

/// What a telescope engineer reads from the elevation axis.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ElevationOutputs {
    /// Axis encoder reading, deg: the true angle with the encoder's errors, counted to whole
    /// encoder counts (rounded down by default).
    pub encoder_position_deg: f64,
    /// Encoder reading minus true angle, arcsec.
    pub encoder_error_arcsec: f64,
    /// True elevation angle, deg.
    pub axis_position_deg: f64,
    /// Axis (dish) speed, deg/s.
    pub axis_speed_deg_per_s: f64,
    /// Motor shaft speed signal, rad/s: the true speed plus the speed-signal noise (none by
    /// default).
    pub motor_speed_rad_per_s: f64,
    /// Motor current (output of the current loop), A.
    pub motor_current_a: f64,
    /// Electromagnetic motor torque `K_phi i`, N m.
    pub motor_torque_nm: f64,
    /// Torque the jackscrew delivers to the dish (motor-side path torque times the ratio at
    /// the true angle, i.e. screw force times lever arm), N m about the axis.
    pub drive_torque_nm: f64,
    /// Axial force in the jackscrew, N (positive pushes the dish up).
    pub screw_force_n: f64,
    /// Transmission ratio at the true angle (the frozen one if the geometry is frozen), motor
    /// rad per axis rad.
    pub transmission_ratio: f64,
    /// Actuator length (trunnion to dish attachment), m; beyond the travel it continues
    /// linearly, like the kinematics.
    pub actuator_length_m: f64,
}

/// The elevation drive train. See the module documentation.
#[derive(Debug, Clone)]
pub struct ElevationPlant {
    params: ElevationParams,
    kinematics: Kinematics,
    core: DriveCore<PATHS, STATES, INPUTS>,
    /// Derived from the state after every change (not part of it): the elevation and the
    /// ratio at it, which the next step and the outputs both need.
    angle_rad: f64,
    ratio: f64,
    sensors: Sensors<PATHS>,
}

impl ElevationPlant {
    /// Elevation at which a new plant starts, at rest: the MeerKAT stow position.
    pub const STOW_ELEVATION_DEG: f64 = 90.0;

    /// Validates the parameters and builds the plant at rest at the stow elevation.
    pub fn new(params: ElevationParams) -> Result<Self, PlantError> {
        params.validate()?;
        let cell = params.cell_of(Self::STOW_ELEVATION_DEG);
        let core = DriveCore::new(params.core_config(), cell, params.cell_model(cell));
        // The ratio, and with it the reflected stiffness and inertia, varies over the travel by
        // some 20 %, not monotonically: the ends and the middle stand for the whole travel,
        // given the bound's seven decades of headroom over the defaults.
        let (low, high) = (params.travel_min_deg, params.travel_max_deg);
        core.check_rates("elevation", [low, 0.5 * (low + high), high].map(|el| params.cell_model(params.cell_of(el))))?;
        let sensors = Sensors::new(params.sensors, params.encoder_bits, ELEVATION_STREAMS);
        let mut plant =
            Self { params, kinematics: Kinematics::new(&params), core, angle_rad: 0.0, ratio: 1.0, sensors };
        plant.set_initial_state(Self::STOW_ELEVATION_DEG.to_radians())?;
        Ok(plant)
    }

    pub fn params(&self) -> &ElevationParams {
        &self.params
    }

    /// Puts the axis at rest at `axis_angle_rad`: untwisted drive, nut centred in any backlash,
    /// zero current, sticking bodies where there is friction, time zero.
    pub fn set_initial_state(&mut self, axis_angle_rad: f64) -> Result<(), PlantError> {
        if !axis_angle_rad.is_finite() {
            return Err(PlantError::InitialAngleNotFinite { axis: "elevation", angle: axis_angle_rad });
        }
        let cell = self.params.cell_of(axis_angle_rad.to_degrees());
        self.core.set_cell(cell, self.params.cell_model(cell));
        self.core.set_at_rest(self.kinematics.position_of(axis_angle_rad));
        self.update_derived();
        self.sensors.set_clock(SampleClock::default());
        Ok(())
    }

    fn update_derived(&mut self) {
        let position = self.core.load_angle();
        self.angle_rad = self.kinematics.angle_of(position);
        self.ratio = self.kinematics.ratio_and_slope(position).0;
    }

    /// Advances by `h` seconds with the inputs held constant over `[t, t + h)`. The parameter
    /// cell follows the angle at the start of the step. On an error the state is unchanged.
    pub fn step(&mut self, inputs: &ElevationInputs, h: f64) -> Result<(), PlantError> {
        if !(h.is_finite() && h > 0.0) {
            return Err(PlantError::StepNotPositive { h });
        }
        if !(inputs.current_command_a.is_finite() && inputs.disturbance_torque_nm.is_finite()) {
            return Err(PlantError::InputsNotFinite { axis: "elevation", inputs: Box::new(*inputs) });
        }
        let checkpoint = self.core.checkpoint();
        let cell = self.params.cell_of(self.angle_rad.to_degrees());
        if cell != self.core.cell() {
            // The state's coordinates do not depend on the cell: only the frozen parameters change.
            self.core.set_cell(cell, self.params.cell_model(cell));
        }
        let params = &self.params;
        let kinematics = &self.kinematics;
        let fast_torques = params.has_fast_position_dependent_torques();
        let position_torques = |x: &SVector<f64, STATES>, model: &CellModel<PATHS>| {
            // Curvature of the load coordinate, d^2 s_L/dt^2 = N dw/dt + N' w^2, as the axis
            // torque that gives the reflected load that acceleration: J N' w^2 / N_c.
            let (ratio, slope) = kinematics.ratio_and_slope(x[LOAD_ANGLE]);
            let speed = x[LOAD_SPEED] / ratio;
            let curvature = params.dish_inertia_kg_m2 * slope * speed * speed / model.gear_ratio;
            if !fast_torques {
                return ([0.0], curvature);
            }
            let angle = kinematics.angle_of(x[LOAD_ANGLE]);
            // The motor angle is the load coordinate plus the twist: zero at 0 deg elevation.
            let motor = [params.motor.cogging.torque_nm(x[LOAD_ANGLE] + x[twist_index(0)])];
            let load = params.unbalance_torque_nm(angle) + params.periodic_torque.torque_nm(angle) + curvature;
            (motor, load)
        };
        let load_torque = inputs.disturbance_torque_nm + params.torque_offset_nm;
        self.core.step([inputs.current_command_a], load_torque, h, &position_torques);
        self.update_derived();
        if !(self.core.is_finite() && self.angle_rad.is_finite() && self.ratio.is_finite()) {
            let cause = self.core.likely_cause_of_non_finite_state(&[inputs.current_command_a], load_torque);
            let params = &self.params;
            self.core.rollback(checkpoint, |cell| params.cell_model(cell));
            self.update_derived();
            return Err(PlantError::NonFiniteStep { axis: "elevation", time: self.core.time(), h, cause });
        }
        self.sensors.advance(h);
        Ok(())
    }

    /// Time since the initial state, s.
    pub fn time_s(&self) -> f64 {
        self.core.time()
    }

    /// The outputs. Geometric quantities (ratio, drive torque, actuator length) are evaluated
    /// exactly at the true angle, not at the grid cell's centre, so they vary smoothly.
    pub fn outputs(&self) -> ElevationOutputs {
        let x = self.core.state();
        let model = self.core.model();
        let (angle, ratio) = (self.angle_rad, self.ratio);
        let screw_force = self.core.path_torque(0) * self.params.jackscrew.motor_rad_per_m();
        let encoder = self.sensors.encoder_reading_rad(angle);
        ElevationOutputs {
            encoder_position_deg: encoder.to_degrees(),
            encoder_error_arcsec: (encoder - angle) / ARCSEC,
            axis_position_deg: angle.to_degrees(),
            axis_speed_deg_per_s: (x[LOAD_SPEED] / ratio).to_degrees(),
            motor_speed_rad_per_s: self.sensors.motor_speed_signal(0, x[motor_speed_index(0)]),
            motor_current_a: x[current_index(0)],
            motor_torque_nm: model.torque_per_amp[0] * x[current_index(0)],
            drive_torque_nm: self.core.path_torque(0) * ratio,
            screw_force_n: screw_force,
            transmission_ratio: ratio,
            actuator_length_m: self.kinematics.length_of(self.core.load_angle()),
        }
    }

    /// The reflected two-mass parameters the simulation is using now (frozen at the centre of
    /// the current elevation cell).
    pub fn two_mass_in_use(&self) -> TwoMassParameters {
        let m = self.core.model();
        TwoMassParameters {
            motor_inertia: m.motor_inertia[0],
            motor_friction: m.motor_viscous[0],
            shaft_stiffness: m.stiffness[0],
            cross_coupled_damping: m.damping[0],
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
        self.update_derived();
        self.sensors.set_clock(clock);
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const RPM: f64 = std::f64::consts::TAU / 60.0;

    fn travel(params: &ElevationParams) -> impl Iterator<Item = f64> + '_ {
        (0..=770)
            .map(move |j| params.travel_min_deg + (params.travel_max_deg - params.travel_min_deg) * j as f64 / 770.0)
    }

    #[test]
    fn load_coordinate_and_elevation_are_inverse_over_the_travel() {
        let p = ElevationParams::default();
        let k = Kinematics::new(&p);
        for el_deg in travel(&p) {
            let el = el_deg.to_radians();
            let back = k.angle_of(k.position_of(el));
            assert!((back - el).abs() < 1e-13, "{el_deg} deg comes back as {} deg", back.to_degrees());
        }
    }

    #[test]
    fn lever_arm_ratio_and_ratio_slope_are_derivatives_of_the_geometry() {
        let p = ElevationParams::default();
        let k = Kinematics::new(&p);
        let j = &p.jackscrew;
        let d = 1e-6;
        for el_deg in [15.5, 37.0, 60.0, 91.5] {
            let el = f64::to_radians(el_deg);
            let dl = (j.actuator_length_m(el + d) - j.actuator_length_m(el - d)) / (2.0 * d);
            assert!((dl / j.lever_arm_m(el) - 1.0).abs() < 1e-8, "lever arm at {el_deg} deg");
            let ds = (k.position_of(el + d) - k.position_of(el - d)) / (2.0 * d);
            let (ratio, slope) = k.ratio_and_slope(k.position_of(el));
            assert!((ds / ratio - 1.0).abs() < 1e-8, "ratio at {el_deg} deg");
            assert!((ratio / j.ratio(el) - 1.0).abs() < 1e-12, "ratio from the load coordinate at {el_deg} deg");
            let dn = (j.ratio(el + d) - j.ratio(el - d)) / (2.0 * d);
            assert!((dn - slope).abs() < 1e-5 * j.ratio(el), "ratio slope at {el_deg} deg");
        }
    }

    #[test]
    fn default_design_meets_its_documented_targets() {
        let p = ElevationParams::default();
        let stiffness: Vec<f64> = travel(&p).map(|el| p.axis_stiffness_at(el)).collect();
        let (k_min, k_max) = stiffness.iter().fold((f64::INFINITY, 0.0f64), |(a, b), &k| (a.min(k), b.max(k)));
        let spread = (k_max - k_min) / k_max;
        assert!((0.15..=0.25).contains(&spread), "axis stiffness spread {spread} is not about 20 %");
        let f15 = p.anti_resonance_hz(15.0);
        assert!((18.0..=25.0).contains(&f15), "anti-resonance at 15 deg is {f15} Hz");
        let f_min = travel(&p).map(|el| p.anti_resonance_hz(el)).fold(f64::INFINITY, f64::min);
        assert!(f_min > 15.0, "a 10-15 Hz velocity loop needs the anti-resonance above 15 Hz, lowest is {f_min}");
        let worst_ratio = travel(&p).map(|el| p.ratio_at(el)).fold(0.0, f64::max);
        let motor_speed_rpm = worst_ratio * 1f64.to_radians() / RPM;
        assert!(motor_speed_rpm <= 3000.0 * 1.001, "1 deg/s needs {motor_speed_rpm} rpm at the worst lever arm");
        for el in travel(&p) {
            let t = p.two_mass_at(el);
            let ratio = t.load_inertia / t.motor_inertia;
            assert!((0.3..=3.0).contains(&ratio), "reflected load to motor inertia {ratio} at {el} deg");
        }
    }

    #[test]
    fn beyond_the_travel_the_kinematics_continue_linearly_and_stay_finite() {
        let p = ElevationParams::default();
        let k = Kinematics::new(&p);
        for el_deg in [-60.0, 0.0, 14.9, 92.1, 150.0, 400.0] {
            let el = f64::to_radians(el_deg);
            let position = k.position_of(el);
            assert!(position.is_finite() && k.ratio_and_slope(position).0 > 0.0);
            let back = k.angle_of(position);
            assert!((back - el).abs() < 1e-12, "{el_deg} deg comes back as {} deg", back.to_degrees());
        }
        // An open-loop current drives the dish far past its travel without producing NaN.
        let mut plant = ElevationPlant::new(p).unwrap();
        plant.set_initial_state(80f64.to_radians()).unwrap();
        for _ in 0..20_000 {
            plant.step(&ElevationInputs { current_command_a: 5.0, disturbance_torque_nm: 0.0 }, 1e-3).unwrap();
        }
        let out = plant.outputs();
        assert!(
            out.axis_position_deg > 100.0 && out.motor_speed_rad_per_s.is_finite() && out.screw_force_n.is_finite()
        );
    }

    #[test]
    fn parameters_too_fast_for_the_discretisation_are_refused_and_an_overflowing_step_is_undone() {
        let d = ElevationParams::default();
        let mut stiff = d;
        stiff.jackscrew.series_stiffness_n_per_m = 1e300;
        stiff.jackscrew.screw_axial_rigidity_n = 1e300;
        let error = ElevationPlant::new(stiff).expect_err("a stiffness of 1e300 N/m").to_string();
        assert!(error.contains("fastest rate") && error.contains("stiffness"), "{error}");
        let mut fast = d;
        fast.motor.current_loop_bandwidth_hz = 1e300;
        let error = ElevationPlant::new(fast).expect_err("a bandwidth of 1e300 Hz").to_string();
        assert!(error.contains("current-loop bandwidth"), "{error}");

        // A disturbance of 1e308 N m until the state overflows: that step is undone.
        let mut plant = ElevationPlant::new(d).unwrap();
        let inputs = ElevationInputs { current_command_a: 1.0, disturbance_torque_nm: 1e308 };
        let mut failure = None;
        for k in 0..100_000 {
            // Compared as the FMU state's bytes: bit for bit, -0.0 and NaN included.
            let before = postcard::to_allocvec(&plant.save_state()).unwrap();
            let outputs = plant.outputs();
            if let Err(error) = plant.step(&inputs, 1e-3) {
                failure = Some((k, error.to_string(), before, outputs));
                break;
            }
        }
        let (k, error, before, outputs) = failure.expect("the state never overflowed");
        assert!(k > 100, "the overflow came after {k} steps, too early to be the disturbance's doing");
        assert!(error.contains("non-finite") && error.contains("load torque 1e308"), "{error}");
        let after = postcard::to_allocvec(&plant.save_state()).unwrap();
        assert!(after == before, "the failed step changed the saved state");
        assert_eq!(plant.outputs(), outputs, "the failed step changed the outputs");
    }

    #[test]
    fn a_frozen_geometry_uses_one_cell_and_the_frozen_parameters() {
        let p = ElevationParams::linear();
        let plant = ElevationPlant::new(p).unwrap();
        assert_eq!(plant.two_mass_in_use(), p.two_mass_at(p.frozen_geometry_elevation_deg));
        assert_eq!(plant.outputs().transmission_ratio, p.ratio_at(p.frozen_geometry_elevation_deg));
    }
}
