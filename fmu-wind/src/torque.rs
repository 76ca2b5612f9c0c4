//! Wind torques about the azimuth and elevation axes (axis side, N m), from the wind speed and
//! the torque coefficient surfaces, each split into a mean and a gust part.
//!
//! * [`TorqueForm::Quadratic`] (default): `T = tau k v |v|` with `v = v_m + v_t` and
//!   `k = 0.5 rho A D`. Mean part: `tau k v_m^2` (Eq. 3); gust part: the rest,
//!   `tau k (v |v| - v_m^2)`. The gust part is not zero-mean: its `v_t^2` term averages
//!   `6 kappa` times the mean part (about 9 % for the paper's `z0`), which is the exact
//!   consequence of the quadratic law.
//! * [`TorqueForm::Linearised`]: the paper's form, mean `tau k v_m^2` plus `k_t dv0` with
//!   `k_t = 2 tau k sqrt(6 kappa) v_m^2` and `dv0 = v_t / (sqrt(6 kappa) v_m)` the normalised
//!   gust ([`gust_torque_gain`], [`normalised_gust`]). Their product is `2 tau k v_m v_t`
//!   whatever `kappa` is. The paper also divides `k_t` by the gear ratio `N` because it refers
//!   the torque to the motor; these torques are on the axis side, so there is no `N`.
//!
//! The coefficients follow the pointing: yaw = wind direction - antenna azimuth, see
//! [`crate::coefficients`] for the sign conventions.
//!
//! The same law gives the forces on the dish ([`DishForces`]): drag along the flow, and the
//! cross-flow force split into lift (vertical) and side force (horizontal, across the wind),
//! `F = C 0.5 rho A v |v|`, with the angular laws of [`ForceCoefficients`]. The gust that
//! enters them is the load gust: the point gust through the aerodynamic admittance
//! ([`crate::admittance`]), or the point gust itself in the coherent configuration. The
//! horizontal forces are also resolved in the antenna's frame, whose horizontal axes turn with
//! azimuth: axial `drag cos(yaw) + side sin(yaw)` (positive from the dish's face towards its
//! back) and lateral `-drag sin(yaw) + side cos(yaw)` (positive towards increasing azimuth),
//! which is what a structural mode's participation weighs.
//!
//! The feed support (MeerKAT's single feed-support arm, the 3.8 m sub-reflector and the feed
//! indexer at its end) adds its own drag ([`FeedDrag`]): a horizontal force along the flow,
//! `0.5 rho (C_D A)_feed v |v|`, applied at its centre of pressure, which sits ahead of the
//! elevation axis along the boresight and off it across the aperture. Its moments about the two
//! axes are added to the dish's torques; without a feed drag area (the paper's model) they are
//! not computed at all, so the paper's torques keep their bits.

use crate::coefficients::CoefficientTable;
use crate::error::WindError;
use std::f64::consts::PI;

/// Which torque law to use.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum TorqueForm {
    /// `tau k v |v|` with the total wind speed: exact in the gust.
    #[default]
    Quadratic,
    /// The seed paper's linearisation about `v_m`.
    Linearised,
}

/// The torques at one instant, N m on the axis side; positive drives positive azimuth
/// (clockwise seen from above) or higher elevation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WindTorques {
    pub azimuth_mean: f64,
    pub azimuth_gust: f64,
    pub elevation_mean: f64,
    pub elevation_gust: f64,
    /// The coefficients used, for logging.
    pub tau_az: f64,
    pub tau_el: f64,
    /// Wind direction minus azimuth, wrapped to (-180, 180] degrees.
    pub yaw_deg: f64,
}

impl WindTorques {
    pub fn azimuth(&self) -> f64 {
        self.azimuth_mean + self.azimuth_gust
    }

    pub fn elevation(&self) -> f64 {
        self.elevation_mean + self.elevation_gust
    }
}

/// Force coefficients of the dish, an **estimate** (no table with force columns is shipped):
///
/// * drag along the flow, `C_D = C_D0 |cos alpha|`,
/// * lift, the vertical component of the force across the flow, `C_L = -C_L0 sin(2 el) cos(psi)`,
/// * side force, its horizontal component, `C_S = C_L0 cos^2(el) sin(2 psi)`, positive to the
///   left of the flow looking downwind (90 degrees anticlockwise from the downwind direction,
///   seen from above),
///
/// with `cos alpha = cos(el) cos(psi)` the cosine of the angle between the boresight and the
/// direction the wind comes from (the angle of [`crate::coefficients`]'s reference model). The
/// lift law is the vertical part of a cross-flow force `C_L0 sin(2 alpha)` in the plane of wind
/// and boresight: that force points along `-(b - cos(alpha) s) / sin(alpha)` (`b` the boresight,
/// `s` the horizontal unit vector towards where the wind comes from), the cross-flow part of a
/// force normal to the aperture that pushes the face away from the wind, and its vertical
/// component is `sin(el) / sin(alpha)` of it, so `-C_L0 sin(2 alpha) sin(el) / sin(alpha) =
/// -2 C_L0 cos(alpha) sin(el)`. Front wind on a raised dish pushes it down (negative lift), wind
/// from behind lifts it. The horizontal component across the wind is `cos(el) sin(psi) /
/// sin(alpha)` of it, `C_L0 2 cos(alpha) cos(el) sin(psi) = C_L0 cos^2(el) sin(2 psi)`: one
/// law, so lift and side force cannot disagree (a yawed dish at zero elevation is a raised dish
/// turned on its side). `C_D0 = 1.3` (range 1.1-1.6: "approximately 1.2-1.4 for a solid
/// parabolic dish", weak vendor sources; JPL Publication 78-16 was not read) and `C_L0 = 0.3`
/// (0.1-0.6, order of the published lift curves, not verified); docs/wind-model.md.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ForceCoefficients {
    /// `C_D0`, the drag coefficient with the wind along the boresight (either face).
    pub drag_face_on: f64,
    /// `C_L0`, the largest cross-flow (lift) coefficient, reached at 45 degrees.
    pub lift_max: f64,
}

impl Default for ForceCoefficients {
    fn default() -> Self {
        Self { drag_face_on: DRAG_COEFFICIENT_FACE_ON, lift_max: LIFT_COEFFICIENT_MAX }
    }
}

/// Default `C_D0` (estimate, range 1.1-1.6).
pub const DRAG_COEFFICIENT_FACE_ON: f64 = 1.3;
/// Default `C_L0` (estimate, range 0.1-0.6).
pub const LIFT_COEFFICIENT_MAX: f64 = 0.3;

impl ForceCoefficients {
    /// `(C_D, C_L)` at yaw `psi` and elevation `el`, degrees.
    pub fn at(&self, yaw_deg: f64, elevation_deg: f64) -> (f64, f64) {
        let (c_drag, c_lift, _) = self.at_yaw(0.0, libm::cos(yaw_deg.to_radians()), elevation_deg);
        (c_drag, c_lift)
    }

    /// `C_S` at yaw `psi` and elevation `el`, degrees.
    pub fn side_at(&self, yaw_deg: f64, elevation_deg: f64) -> f64 {
        let (sin_psi, cos_psi) = libm::sincos(yaw_deg.to_radians());
        self.at_yaw(sin_psi, cos_psi, elevation_deg).2
    }

    /// `(C_D, C_L, C_S)` from the yaw's sine and cosine and the elevation, degrees (the forces
    /// take both from one fdlibm `sincos`, which gives the same bits as its `cos`, tested).
    fn at_yaw(&self, sin_psi: f64, cos_psi: f64, elevation_deg: f64) -> (f64, f64, f64) {
        // Evaluated at every step: one fdlibm `sincos` for the elevation (sin 2 el = 2 sin el
        // cos el) instead of four calls into the system library.
        let (sin_el, cos_el) = libm::sincos(elevation_deg.to_radians());
        let cos_alpha = cos_el * cos_psi;
        (
            self.drag_face_on * cos_alpha.abs(),
            -self.lift_max * (2.0 * sin_el * cos_el) * cos_psi,
            self.lift_max * (cos_el * cos_el) * (2.0 * sin_psi * cos_psi),
        )
    }
}

/// The forces on the dish at one instant, N: drag positive downwind, lift positive up, side
/// force positive to the left of the flow looking downwind.
///
/// Drag and side force lie in the horizontal plane along and across the wind, whose direction
/// in the antenna's frame turns with the yaw; their sum's components in that frame are
/// [`DishForces::axial`] and [`DishForces::lateral`]. With the lift they make a right-handed
/// frame: axial (horizontal, backwards from the face), lateral (horizontal, towards increasing
/// azimuth), up.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DishForces {
    pub drag_mean: f64,
    pub drag_gust: f64,
    pub lift_mean: f64,
    pub lift_gust: f64,
    pub side_mean: f64,
    pub side_gust: f64,
    pub c_drag: f64,
    pub c_lift: f64,
    pub c_side: f64,
    /// `cos(yaw)`: the axial component per unit drag.
    pub axial_per_drag: f64,
    /// `-sin(yaw)`: the lateral component per unit drag.
    pub lateral_per_drag: f64,
}

impl DishForces {
    pub fn drag(&self) -> f64 {
        self.drag_mean + self.drag_gust
    }

    pub fn lift(&self) -> f64 {
        self.lift_mean + self.lift_gust
    }

    pub fn side(&self) -> f64 {
        self.side_mean + self.side_gust
    }

    /// The horizontal force along the horizontal projection of the boresight, positive pushing
    /// the dish backwards (from its reflector face towards its back): `drag cos(yaw) + side
    /// sin(yaw)`. A wind blowing into the face (yaw 0) gives `+drag`, a wind from behind (yaw
    /// 180) `-drag`.
    pub fn axial(&self) -> f64 {
        Self::along(self.drag(), self.side(), self.axial_per_drag, self.lateral_per_drag)
    }

    /// Mean part of [`DishForces::axial`].
    pub fn axial_mean(&self) -> f64 {
        Self::along(self.drag_mean, self.side_mean, self.axial_per_drag, self.lateral_per_drag)
    }

    /// The horizontal force across the boresight (cross-elevation), positive pushing the dish
    /// towards increasing azimuth (clockwise seen from above): `-drag sin(yaw) + side cos(yaw)`.
    /// A wind coming from the left of the boresight (yaw -90, seen from behind the dish) pushes
    /// it to the right, towards increasing azimuth.
    pub fn lateral(&self) -> f64 {
        Self::across(self.drag(), self.side(), self.axial_per_drag, self.lateral_per_drag)
    }

    /// Mean part of [`DishForces::lateral`].
    pub fn lateral_mean(&self) -> f64 {
        Self::across(self.drag_mean, self.side_mean, self.axial_per_drag, self.lateral_per_drag)
    }

    /// `drag cos(yaw) + side sin(yaw)`, with `cos(yaw)` and `-sin(yaw)` given.
    fn along(drag: f64, side: f64, cos_yaw: f64, minus_sin_yaw: f64) -> f64 {
        drag * cos_yaw - side * minus_sin_yaw
    }

    /// `-drag sin(yaw) + side cos(yaw)`, with `cos(yaw)` and `-sin(yaw)` given.
    fn across(drag: f64, side: f64, cos_yaw: f64, minus_sin_yaw: f64) -> f64 {
        drag * minus_sin_yaw + side * cos_yaw
    }
}

/// The drag of the feed support (arm, sub-reflector, indexer) as a drag area at a centre of
/// pressure fixed to the dish: an **estimate** (docs/wind-model.md, "Feed-support drag").
///
/// The centre of pressure is `boresight_distance` ahead of the elevation axis along the
/// boresight and `offset` from it in the plane of boresight and zenith, positive towards the
/// zenith when the dish points at the horizon (MeerKAT's feed-down optics put the sub-reflector
/// below the boresight: a negative offset). In the antenna's frame (x the boresight's
/// horizontal projection, z up) it lies at `x = L cos(el) - h sin(el)`, `z = L sin(el) + h
/// cos(el)`; a drag `F` along the flow, which comes from yaw `psi`, gives about the elevation
/// axis `F z cos(psi)` (positive raises the dish: wind into the face pushes the raised feed
/// back) and about the azimuth axis `-F x sin(psi)` (the feed ahead of the axis is pushed
/// downwind, turning the boresight away from the wind).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct FeedDrag {
    /// `(C_D A)_feed`, m^2; 0 leaves the feed out.
    pub drag_area: f64,
    /// `L`, the centre of pressure's distance ahead of the elevation axis along the boresight, m.
    pub boresight_distance: f64,
    /// `h`, its distance from the boresight through the elevation axis, m (negative: feed-down).
    pub offset: f64,
}

impl FeedDrag {
    /// The lever arms `(x, z)` of the centre of pressure at elevation `el`, deg: horizontal
    /// (along the boresight's projection) and vertical, m.
    pub fn arms(&self, elevation_deg: f64) -> (f64, f64) {
        let (sin_el, cos_el) = libm::sincos(elevation_deg.to_radians());
        (
            self.boresight_distance * cos_el - self.offset * sin_el,
            self.boresight_distance * sin_el + self.offset * cos_el,
        )
    }

    /// The torques `(azimuth, elevation)` per newton of feed drag at yaw `psi` and elevation
    /// `el`, deg: N m per N.
    pub fn torque_per_drag(&self, yaw_deg: f64, elevation_deg: f64) -> (f64, f64) {
        let (x, z) = self.arms(elevation_deg);
        let (sin_psi, cos_psi) = libm::sincos(yaw_deg.to_radians());
        (-x * sin_psi, z * cos_psi)
    }
}

/// The wind torque model of one antenna.
#[derive(Debug, Clone, PartialEq)]
pub struct WindTorqueModel {
    pub coefficients: CoefficientTable,
    /// Air density, kg/m^3 (see [`crate::site::AIR_DENSITY`]).
    pub air_density: f64,
    /// Dish diameter `D`, m; the reference area is the aperture circle `pi D^2 / 4`.
    pub dish_diameter: f64,
    pub form: TorqueForm,
    pub forces: ForceCoefficients,
    /// The feed support's drag, whose moments add to the dish's torques.
    pub feed: FeedDrag,
}

impl WindTorqueModel {
    /// Checks that density and diameter are positive and finite.
    pub fn new(
        coefficients: CoefficientTable,
        air_density: f64,
        dish_diameter: f64,
        form: TorqueForm,
    ) -> Result<Self, WindError> {
        if !(air_density.is_finite() && air_density > 0.0) {
            return Err(WindError::AirDensity { density: air_density });
        }
        if !(dish_diameter.is_finite() && dish_diameter > 0.0) {
            return Err(WindError::DishDiameter { diameter: dish_diameter });
        }
        Ok(Self {
            coefficients,
            air_density,
            dish_diameter,
            form,
            forces: ForceCoefficients::default(),
            feed: FeedDrag::default(),
        })
    }

    /// The same model with these force coefficients (finite, checked).
    pub fn with_forces(mut self, forces: ForceCoefficients) -> Result<Self, WindError> {
        if !(forces.drag_face_on.is_finite() && forces.lift_max.is_finite()) {
            return Err(WindError::ForceCoefficients { drag_face_on: forces.drag_face_on, lift_max: forces.lift_max });
        }
        self.forces = forces;
        Ok(self)
    }

    /// The same model with this feed-support drag (finite, drag area not negative, checked).
    pub fn with_feed(mut self, feed: FeedDrag) -> Result<Self, WindError> {
        let finite = feed.drag_area.is_finite() && feed.boresight_distance.is_finite() && feed.offset.is_finite();
        if !(finite && feed.drag_area >= 0.0) {
            return Err(WindError::FeedDrag {
                drag_area: feed.drag_area,
                boresight_distance: feed.boresight_distance,
                offset: feed.offset,
            });
        }
        self.feed = feed;
        Ok(self)
    }

    /// `(mean, gust)` parts of `v |v|` (quadratic) or its linearisation, (m/s)^2.
    fn speed_squared(&self, v_mean: f64, v_gust: f64) -> (f64, f64) {
        let mean = v_mean * v_mean;
        let gust = match self.form {
            TorqueForm::Quadratic => {
                let v = v_mean + v_gust;
                v * v.abs() - mean
            }
            TorqueForm::Linearised => 2.0 * v_mean * v_gust,
        };
        (mean, gust)
    }

    /// Drag, lift and side force on the dish for the same arguments as [`WindTorqueModel::torques`]:
    /// `F = C 0.5 rho A v |v|` (or its linearisation), split like the torques.
    pub fn forces(
        &self,
        v_mean: f64,
        v_gust: f64,
        wind_direction_deg: f64,
        azimuth_deg: f64,
        elevation_deg: f64,
    ) -> DishForces {
        let yaw = yaw_deg(wind_direction_deg, azimuth_deg);
        // fdlibm's sincos, as the coefficients use: the same bits on every platform.
        let (sin_yaw, cos_yaw) = libm::sincos(yaw.to_radians());
        let (c_drag, c_lift, c_side) = self.forces.at_yaw(sin_yaw, cos_yaw, elevation_deg);
        let k = 0.5 * self.air_density * self.reference_area();
        let (mean, gust) = self.speed_squared(v_mean, v_gust);
        DishForces {
            drag_mean: c_drag * k * mean,
            drag_gust: c_drag * k * gust,
            lift_mean: c_lift * k * mean,
            lift_gust: c_lift * k * gust,
            side_mean: c_side * k * mean,
            side_gust: c_side * k * gust,
            c_drag,
            c_lift,
            c_side,
            axial_per_drag: cos_yaw,
            lateral_per_drag: -sin_yaw,
        }
    }

    /// The reference area `A = pi D^2 / 4`, m^2.
    pub fn reference_area(&self) -> f64 {
        PI * self.dish_diameter * self.dish_diameter / 4.0
    }

    /// `k = 0.5 rho A D`, N m per (m/s)^2: the torque per unit coefficient and unit speed squared.
    pub fn torque_scale(&self) -> f64 {
        0.5 * self.air_density * self.reference_area() * self.dish_diameter
    }

    /// Torques for mean speed `v_mean`, gust `v_gust` (m/s), wind direction (where the wind comes
    /// from, degrees from north, clockwise) and antenna pointing (degrees).
    pub fn torques(
        &self,
        v_mean: f64,
        v_gust: f64,
        wind_direction_deg: f64,
        azimuth_deg: f64,
        elevation_deg: f64,
    ) -> WindTorques {
        let yaw = yaw_deg(wind_direction_deg, azimuth_deg);
        let (tau_az, tau_el) = self.coefficients.coefficients(yaw, elevation_deg);
        let k = self.torque_scale();
        let mean = k * v_mean * v_mean;
        let gust = match self.form {
            TorqueForm::Quadratic => {
                let v = v_mean + v_gust;
                k * (v * v.abs() - v_mean * v_mean)
            }
            TorqueForm::Linearised => 2.0 * k * v_mean * v_gust,
        };
        let mut torques = WindTorques {
            azimuth_mean: tau_az * mean,
            azimuth_gust: tau_az * gust,
            elevation_mean: tau_el * mean,
            elevation_gust: tau_el * gust,
            tau_az,
            tau_el,
            yaw_deg: yaw,
        };
        if self.feed.drag_area > 0.0 {
            // The feed's drag per (m/s)^2 times the same mean and gust parts of v |v| as the
            // dish's: the feed sees the dish's load gust (its own admittance, nearer 1 for a
            // smaller body, is not modelled).
            let k_feed = 0.5 * self.air_density * self.feed.drag_area;
            let (v2_mean, v2_gust) = self.speed_squared(v_mean, v_gust);
            let (drag_mean, drag_gust) = (k_feed * v2_mean, k_feed * v2_gust);
            let (per_drag_az, per_drag_el) = self.feed.torque_per_drag(yaw, elevation_deg);
            torques.azimuth_mean += per_drag_az * drag_mean;
            torques.azimuth_gust += per_drag_az * drag_gust;
            torques.elevation_mean += per_drag_el * drag_mean;
            torques.elevation_gust += per_drag_el * drag_gust;
        }
        torques
    }
}

/// Wind direction minus azimuth, wrapped to (-180, 180] degrees.
pub fn yaw_deg(wind_direction_deg: f64, azimuth_deg: f64) -> f64 {
    let y = crate::coefficients::wrap_360(wind_direction_deg - azimuth_deg);
    if y > 180.0 {
        y - 360.0
    } else {
        y
    }
}

/// The paper's gust torque gain on the axis side, `k_t = 2 tau k sqrt(6 kappa) v_m^2`, N m.
pub fn gust_torque_gain(tau: f64, torque_scale: f64, kappa: f64, v_mean: f64) -> f64 {
    2.0 * tau * torque_scale * (6.0 * kappa).sqrt() * v_mean * v_mean
}

/// The paper's normalised gust `dv0 = v_t / (sqrt(6 kappa) v_m)`: unit variance for a
/// Davenport-normalised gust.
pub fn normalised_gust(v_gust: f64, kappa: f64, v_mean: f64) -> f64 {
    v_gust / ((6.0 * kappa).sqrt() * v_mean)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::coefficients::reference_model;
    use crate::davenport::Davenport;

    fn model(form: TorqueForm) -> WindTorqueModel {
        WindTorqueModel::new(CoefficientTable::default_table(), 1.075, 13.5, form).unwrap()
    }

    #[test]
    fn mean_torques_match_hand_computed_eq3_values() {
        // Eq. 3 by hand: k = 0.5 * 1.075 * (pi 13.5^2 / 4) * 13.5 = 1038.6 N m / (m/s)^2.
        let area = PI * 13.5 * 13.5 / 4.0;
        let k = 0.5 * 1.075 * area * 13.5;
        assert!((k - 1038.6).abs() < 0.1, "k = {k}");
        let m = model(TorqueForm::Quadratic);
        // (wind direction, azimuth, elevation): the coefficient comes from the grid node at
        // yaw = wind - azimuth, where the table holds the reference model exactly (5 decimals).
        for (wind, az, el, v) in
            [(130.0, 0.0, 0.0, 10.0), (40.0, 100.0, 30.0, 9.8), (200.0, 20.0, 45.0, 2.9), (350.0, 5.0, 15.0, 25.0)]
        {
            let (tau_az, tau_el) = reference_model(yaw_deg(wind, az), el);
            let t = m.torques(v, 0.0, wind, az, el);
            assert!((t.azimuth_mean - tau_az * k * v * v).abs() < 1e-5 * k * v * v, "az at ({wind}, {az}, {el})");
            assert!((t.elevation_mean - tau_el * k * v * v).abs() < 1e-5 * k * v * v, "el at ({wind}, {az}, {el})");
            assert_eq!(t.azimuth_gust, 0.0);
        }
        // One number written out: yaw 130 deg at the horizon, 10 m/s.
        let t = m.torques(10.0, 0.0, 130.0, 0.0, 0.0);
        let tau = -0.05 * 130f64.to_radians().sin() + 0.07 * 260f64.to_radians().sin();
        assert!((tau + 0.10724).abs() < 1e-5);
        assert!((t.azimuth_mean - tau * 1038.6 * 100.0).abs() < 15.0, "{}", t.azimuth_mean);
    }

    #[test]
    fn back_quartering_wind_turns_the_dish_to_point_downwind() {
        // Wind from 130 deg clockwise of the pointing: the weather-vane torque turns the dish
        // away from the wind (yaw towards 180), i.e. towards lower azimuth.
        let t = model(TorqueForm::Quadratic).torques(10.0, 0.0, 130.0, 0.0, 10.0);
        assert!(t.azimuth_mean < 0.0);
        let mirrored = model(TorqueForm::Quadratic).torques(10.0, 0.0, -130.0, 0.0, 10.0);
        assert!((mirrored.azimuth_mean + t.azimuth_mean).abs() < 1e-9 * t.azimuth_mean.abs());
    }

    #[test]
    fn front_wind_at_low_elevation_pushes_the_dish_down_and_zenith_wind_tips_it_downwind() {
        // Hand calculation with the reference model, psi = 0, el = 15 deg:
        // C = m1 + 2 m2 cos(15) = -0.05 + 0.1352 = 0.0852, tau_el = -C sin(15) = -0.0221 < 0:
        // the dish's own moment (centre of pressure towards the upwind, lower rim) turns it to
        // face the wind squarely, i.e. lowers it.
        let m = model(TorqueForm::Quadratic);
        let low = m.torques(10.0, 0.0, 0.0, 0.0, 15.0);
        let c = -0.05 + 2.0 * 0.07 * 15f64.to_radians().cos();
        assert!((low.tau_el + c * 15f64.to_radians().sin()).abs() < 1e-5);
        assert!(low.elevation_mean < 0.0);
        // At zenith the front wind acts on the dish ahead of (above) the elevation axis and
        // tips the boresight downwind, beyond 90 deg: positive, tau_el = -m1 = 0.05.
        let zenith = m.torques(10.0, 0.0, 0.0, 0.0, 90.0);
        assert!((zenith.tau_el - 0.05).abs() < 1e-5);
        assert!(zenith.azimuth_mean.abs() < 1e-9);
    }

    #[test]
    fn quadratic_gust_part_carries_the_six_kappa_mean_increase() {
        // E[(v_m + v_t)^2 - v_m^2] = sigma^2 = 6 kappa v_m^2 for a zero-mean gust: check on a
        // symmetric two-point gust +-sigma, for which the average is exact.
        let d = Davenport::new(9.5, 10.0, 0.4).unwrap();
        let m = model(TorqueForm::Quadratic);
        let plus = m.torques(9.5, d.sigma(), 130.0, 0.0, 20.0);
        let minus = m.torques(9.5, -d.sigma(), 130.0, 0.0, 20.0);
        let mean_gust = 0.5 * (plus.azimuth_gust + minus.azimuth_gust);
        assert!((mean_gust / plus.azimuth_mean - 6.0 * d.kappa()).abs() < 1e-12);
        assert!((6.0 * d.kappa() - 0.0926).abs() < 1e-3, "about 9 %");
    }

    #[test]
    fn linearised_gust_torque_is_the_papers_kt_times_dv0_without_the_gear_ratio() {
        let m = model(TorqueForm::Linearised);
        let d = Davenport::new(3.0, 10.0, 0.4).unwrap();
        let v_t = 0.7;
        let t = m.torques(3.0, v_t, 45.0, 10.0, 30.0);
        let kt = gust_torque_gain(t.tau_az, m.torque_scale(), d.kappa(), 3.0);
        let dv0 = normalised_gust(v_t, d.kappa(), 3.0);
        assert!((t.azimuth_gust - kt * dv0).abs() < 1e-9 * t.azimuth_gust.abs());
        assert!((t.azimuth_gust - 2.0 * t.tau_az * m.torque_scale() * 3.0 * v_t).abs() < 1e-9 * t.azimuth_gust.abs());
    }

    #[test]
    fn reversed_flow_reverses_the_quadratic_torque() {
        let m = model(TorqueForm::Quadratic);
        let t = m.torques(0.5, -1.5, 130.0, 0.0, 0.0);
        assert!(t.azimuth() * t.azimuth_mean < 0.0, "v = -1 m/s pushes the other way");
        // v = 0.5 - 1.5 = -1 m/s: T = tau k v|v| = -tau k.
        assert!((t.azimuth() + t.tau_az * m.torque_scale()).abs() < 1e-9);
    }

    #[test]
    fn steady_drag_face_on_is_q_a_cd_and_lift_follows_its_signs() {
        // q A C_D by hand at 9.8 m/s: 0.5 * 1.075 * 9.8^2 * (pi 13.5^2 / 4) * 1.3 = 9,605.8 N.
        let m = model(TorqueForm::Quadratic);
        let f = m.forces(9.8, 0.0, 40.0, 40.0, 0.0);
        let q_a = 0.5 * 1.075 * 9.8 * 9.8 * PI * 13.5 * 13.5 / 4.0;
        assert!((f.drag() - 1.3 * q_a).abs() < 1e-9 * q_a, "{}", f.drag());
        assert!((f.drag() - 9605.8).abs() < 0.1);
        assert_eq!(f.lift(), 0.0, "no lift face-on at the horizon");
        // Front wind on a dish raised to 45 deg: C_D = 1.3 cos 45, pushed down by C_L0.
        let raised = m.forces(9.8, 0.0, 40.0, 40.0, 45.0);
        assert!((raised.c_drag - 1.3 * 45f64.to_radians().cos()).abs() < 1e-12);
        assert!((raised.c_lift + 0.3).abs() < 1e-12 && raised.lift() < 0.0);
        // Wind from behind lifts it; wind from the side has neither drag nor lift.
        assert!(m.forces(9.8, 0.0, 220.0, 40.0, 45.0).lift() > 0.0);
        let side = m.forces(9.8, 0.0, 130.0, 40.0, 30.0);
        assert!(side.drag().abs() < 1e-9 * q_a && side.lift().abs() < 1e-9 * q_a);
        // Zenith: edge-on, no drag, no lift.
        assert!(m.forces(9.8, 0.0, 0.0, 0.0, 90.0).drag().abs() < 1e-9 * q_a);
    }

    #[test]
    fn feed_drag_adds_its_hand_computed_moments_about_both_axes() {
        // 8 m^2 at 7 m ahead of the elevation axis and 3 m below the boresight, 9.8 m/s:
        // drag 0.5 * 1.075 * 9.8^2 * 8 = 413.0 N. At 45 deg the arms are x = 7 cos 45 + 3 sin 45
        // = 7.071 m and z = 7 sin 45 - 3 cos 45 = 2.828 m.
        let feed = FeedDrag { drag_area: 8.0, boresight_distance: 7.0, offset: -3.0 };
        let bare = model(TorqueForm::Quadratic);
        let with = bare.clone().with_feed(feed).unwrap();
        let drag: f64 = 0.5 * 1.075 * 9.8 * 9.8 * 8.0;
        assert!((drag - 413.0).abs() < 0.1);
        let (x, z) = feed.arms(45.0);
        assert!((x - 10.0 / 2f64.sqrt()).abs() < 1e-12 && (z - 4.0 / 2f64.sqrt()).abs() < 1e-12, "{x} {z}");
        // Wind into the face (yaw 0) pushes the raised feed back: the dish tips up, no yaw.
        let (a, b) = (with.torques(9.8, 0.0, 40.0, 40.0, 45.0), bare.torques(9.8, 0.0, 40.0, 40.0, 45.0));
        assert!((a.elevation() - b.elevation() - drag * z).abs() < 1e-9 * drag);
        assert!((a.azimuth() - b.azimuth()).abs() < 1e-9 * drag);
        // Wind from the right (yaw +90) pushes the feed to the left: azimuth decreases by F x.
        let (a, b) = (with.torques(9.8, 0.0, 130.0, 40.0, 45.0), bare.torques(9.8, 0.0, 130.0, 40.0, 45.0));
        assert!((a.azimuth() - b.azimuth() + drag * x).abs() < 1e-9 * drag, "{}", a.azimuth() - b.azimuth());
        assert!((a.elevation() - b.elevation()).abs() < 1e-9 * drag);
        // At the horizon the feed hangs 3 m below the axis: wind into the face tips the dish down.
        let (a, b) = (with.torques(9.8, 0.0, 40.0, 40.0, 0.0), bare.torques(9.8, 0.0, 40.0, 40.0, 0.0));
        assert!((a.elevation() - b.elevation() + 3.0 * drag).abs() < 1e-9 * drag);
        // The gust part takes the same law; without a drag area nothing changes, to the bit.
        let (a, b) = (with.torques(9.8, 1.7, 70.0, 40.0, 30.0), bare.torques(9.8, 1.7, 70.0, 40.0, 30.0));
        let (per_az, _) = feed.torque_per_drag(30.0, 30.0);
        let v = 9.8 + 1.7;
        let gust_drag = 0.5 * 1.075 * 8.0 * (v * v - 9.8 * 9.8);
        assert!((a.azimuth_gust - b.azimuth_gust - per_az * gust_drag).abs() < 1e-9 * drag);
        let none = bare.clone().with_feed(FeedDrag { drag_area: 0.0, ..feed }).unwrap();
        assert_eq!(none.torques(9.8, 1.7, 70.0, 40.0, 30.0), b);
        assert!(bare.with_feed(FeedDrag { drag_area: -1.0, ..feed }).is_err());
    }

    #[test]
    fn forces_take_the_gust_like_the_torques() {
        for form in [TorqueForm::Quadratic, TorqueForm::Linearised] {
            let m = model(form);
            let (t, f) = (m.torques(9.8, 1.7, 10.0, 0.0, 30.0), m.forces(9.8, 1.7, 10.0, 0.0, 30.0));
            // The gust-to-mean ratio is the same for every load: one dynamic pressure.
            let ratio = t.azimuth_gust / t.azimuth_mean;
            assert!((f.drag_gust / f.drag_mean - ratio).abs() < 1e-12);
            assert!((f.lift_gust / f.lift_mean - ratio).abs() < 1e-12);
        }
    }

    #[test]
    fn drag_and_side_force_resolve_into_axial_and_lateral_by_the_yaw() {
        // The wind comes from 30 deg clockwise of the pointing (yaw +30, from the right seen
        // from behind the dish): it pushes the dish backwards and to the left (towards lower
        // azimuth), and the two components add up to drag and side force as a vector.
        let m = model(TorqueForm::Quadratic);
        let f = m.forces(9.8, 1.3, 70.0, 40.0, 20.0);
        let (s, c) = (30f64.to_radians().sin(), 30f64.to_radians().cos());
        let tolerance = 1e-12 * f.drag();
        assert!(f.side() != 0.0);
        assert!((f.axial() - (f.drag() * c + f.side() * s)).abs() < tolerance && f.axial() > 0.0);
        assert!((f.lateral() - (-f.drag() * s + f.side() * c)).abs() < tolerance && f.lateral() < 0.0);
        assert!((f.axial_mean() - (f.drag_mean * c + f.side_mean * s)).abs() < 1e-12 * f.drag_mean);
        assert!((f.lateral_mean() - (-f.drag_mean * s + f.side_mean * c)).abs() < 1e-12 * f.drag_mean);
        assert!((f.axial().hypot(f.lateral()) - f.drag().hypot(f.side())).abs() < tolerance);
        // Along the wind the drag, across it the side force.
        assert!((f.axial() * c - f.lateral() * s - f.drag()).abs() < tolerance);
        assert!((f.axial() * s + f.lateral() * c - f.side()).abs() < tolerance);
        // The mirrored wind (yaw -30) pushes to the right; a wind from behind pushes forwards.
        assert!(m.forces(9.8, 0.0, 10.0, 40.0, 20.0).lateral() > 0.0);
        assert!(m.forces(9.8, 0.0, 220.0, 40.0, 20.0).axial() < 0.0);
    }

    #[test]
    fn lift_and_side_force_are_the_vertical_and_horizontal_parts_of_one_cross_flow_force() {
        // The cross-flow force C_L0 sin(2 alpha), alpha the angle between the boresight and
        // where the wind comes from, lies in the plane of wind and boresight, across the wind:
        // its two parts add up to it, and it is perpendicular to the wind. A yawed dish at zero
        // elevation is a raised dish in front wind turned on its side.
        let forces = ForceCoefficients::default();
        for (yaw, el) in [(30.0, 20.0), (-60.0, 45.0), (135.0, 10.0), (90.0, 30.0), (0.0, 60.0), (-170.0, 5.0)] {
            let (c_drag, c_lift) = forces.at(yaw, el);
            let c_side = forces.side_at(yaw, el);
            let (psi, e) = (f64::to_radians(yaw), f64::to_radians(el));
            let alpha = (e.cos() * psi.cos()).acos();
            let cross = forces.lift_max * (2.0 * alpha).sin();
            assert!((c_lift.hypot(c_side) - cross.abs()).abs() < 1e-12, "yaw {yaw} el {el}");
            assert!((c_drag - forces.drag_face_on * alpha.cos().abs()).abs() < 1e-12);
        }
        let (_, lift_raised) = forces.at(0.0, 30.0);
        assert!((forces.side_at(-30.0, 0.0) - lift_raised).abs() < 1e-12, "the same force turned by 90 deg");
        // Front, rear and edge-on winds have no side force.
        for yaw in [0.0, 180.0, 90.0, -90.0] {
            assert!(forces.side_at(yaw, 30.0).abs() < 1e-12, "yaw {yaw}");
        }
    }

    #[test]
    fn fdlibm_sincos_gives_the_cosine_of_cos_bit_for_bit() {
        // The force coefficients take the yaw's cosine from the `sincos` that the resolved
        // forces need: their values must not change with it. Every yaw the model sees lies in
        // [-180, 180] deg; a dense sweep, the quadrant edges and a few far arguments.
        let mut angles: Vec<f64> = (-720_000..=720_000).map(|k| (k as f64 * 2.5e-4).to_radians()).collect();
        angles.extend([0.0, -0.0, std::f64::consts::FRAC_PI_4, std::f64::consts::PI, 1e6, -3e9, 1e-300]);
        for x in angles {
            assert_eq!(libm::sincos(x).1.to_bits(), libm::cos(x).to_bits(), "cos({x:e})");
        }
    }

    #[test]
    fn yaw_wraps_to_plus_minus_180() {
        assert_eq!(yaw_deg(10.0, 350.0), 20.0);
        assert_eq!(yaw_deg(350.0, 10.0), -20.0);
        assert_eq!(yaw_deg(0.0, 180.0), 180.0);
    }

    #[test]
    fn invalid_density_or_diameter_is_an_error() {
        assert!(WindTorqueModel::new(CoefficientTable::default_table(), 0.0, 13.5, TorqueForm::Quadratic).is_err());
        assert!(WindTorqueModel::new(CoefficientTable::default_table(), 1.0, f64::NAN, TorqueForm::Quadratic).is_err());
    }
}
