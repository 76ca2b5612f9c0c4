//! The structure's lowest mode under the servo, predicted by a linear frequency-domain model of
//! one axis: what the coupled antenna measures (the mode's peak in the beam error moving down and
//! flattening when the axis is free to move), computed from the parameters alone.
//!
//! The mechanics are three bodies about the axis, reflected to the motor side as in the
//! paper's two-mass model (`fmu_plant::analytic`): the motor (both motors for azimuth), the
//! drive's stiffness and damping, the rigid load (the plant's load inertia less the inertia the
//! mode carries, as the antenna master leaves it out), and the mode's body on the mode's spring
//! and damper (clamped-base frequency `w`, damping `zeta`, modal stiffness `K`, inertia `K / w^2`).
//! The mode's equation is the `Structure` FMU's (`fmu_structure::dynamics`): with `q` its
//! coordinate relative to the load, `p` the axis's participation and `T` the wind's torque about
//! the axis,
//!
//! ```text
//! J_m q'' + c q' + K q = p T - p J_m a_L          (J_m = K / w^2, c = 2 zeta K / w)
//! load:  J_r a_L = drive torque + T - p (p T - K q - c q')
//! ```
//!
//! the second line being the structure's `drive_torque` (the loads' torque less what
//! accelerates the mode's body). No friction enters: the model is the axis free to move, which
//! an axis sliding while it tracks is, and one stuck in static friction is not.
//!
//! The servo is the controller's cascade as `fmu_controller::linear` models it (velocity PI on
//! the filtered motor speed, delay and hold, the position PI on the encoder's load angle) with
//! the plant's current loop; the command is constant, so the wind's torque is the only input.
//! The beam's pointing is the load angle (times `cos(el)` for azimuth, on the sky) plus the
//! mode's offset `b q`, as the master's report judges it. The same mode on a fixed base (the
//! axis clamped) is `b p / (J_m s^2 + c s + K)`.
//!
//! What it leaves out: friction, backlash (closed by the azimuth motors' torque bias), the
//! sensors' quantisation and noise, aliasing above the controller's Nyquist frequency and the
//! co-simulation's coupling through the communication step (docs/structure-model.md, "Both
//! ways": within 0.1 point of damping at 1 ms).

use std::f64::consts::TAU;

use antenna_plot::{Figure, Panel};
use fmu_controller::linear::{margins, AxisPlantResponse, Margins, PositionLoopModel, C64};
use fmu_controller::{AzimuthController, AzimuthControllerParams, ElevationController, ElevationControllerParams};
use fmu_plant::analytic::{current_loop_response, TwoMassParameters};
use fmu_plant::{AzimuthParams, ElevationParams};
use fmu_structure::modes::{parse_modes, Mode, DEFAULT_MODES, DEFAULT_MODES_FILE};
use nalgebra::Matrix3;

use super::Axis;

/// One axis with its structural mode and its servo, linearised.
#[derive(Debug, Clone)]
pub struct AxisWithMode {
    pub axis: Axis,
    pub elevation_deg: f64,
    /// The drive as the plant models it, reflected to the motor side, with the whole load
    /// inertia (the mode's included).
    pub drive: TwoMassParameters,
    /// Motor rad per axis rad.
    pub gear_ratio: f64,
    /// Bandwidth of the plant's current loop, Hz.
    pub current_loop_bandwidth_hz: f64,
    /// The mode that belongs to the axis.
    pub mode: Mode,
    /// The cascade around the drive.
    pub servo: PositionLoopModel,
}

/// The stability margins of the two loops of one axis.
#[derive(Debug, Clone, PartialEq)]
pub struct LoopMargins {
    pub velocity: Margins,
    pub position: Margins,
}

impl LoopMargins {
    /// The six figures a margins table shows, in its order: the velocity loop's phase margin
    /// (deg), gain margin (dB) and modulus margin, then the position loop's.
    pub fn figures(&self) -> [f64; 6] {
        let (v, p) = (&self.velocity, &self.position);
        [v.phase_margin_deg, v.gain_margin_db, v.modulus_margin, p.phase_margin_deg, p.gain_margin_db, p.modulus_margin]
    }
}

/// Responses of the three bodies at one frequency, to the motor torque and to the wind's torque.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MechanicalResponse {
    /// Motor angle, load angle (both reflected to the motor side, rad) and the mode's coordinate
    /// (axis rad times the gear ratio), per N m of motor torque.
    pub per_motor_torque: [C64; 3],
    /// The same per N m of the wind's torque about the axis.
    pub per_wind_torque: [C64; 3],
}

/// A resonance of a frequency response: where its magnitude peaks, how wide the peak is, and
/// the pole nearest to it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Resonance {
    /// Frequency of the largest magnitude, Hz.
    pub peak_hz: f64,
    /// The largest magnitude.
    pub peak_magnitude: f64,
    /// Damping from the half-power points, `(f2 - f1) / (2 f_peak)`; `None` when the magnitude
    /// does not fall to `1/sqrt(2)` of the peak on both sides within the search band.
    pub half_power_damping: Option<f64>,
    /// The pole nearest the peak, rad/s, continued from the imaginary axis (below).
    pub pole: C64,
}

impl Resonance {
    /// The pole's natural frequency, Hz.
    pub fn pole_frequency_hz(&self) -> f64 {
        self.pole.norm() / TAU
    }

    /// The pole's damping ratio.
    pub fn pole_damping(&self) -> f64 {
        -self.pole.re / self.pole.norm()
    }
}

impl AxisWithMode {
    /// The shipped antenna at `elevation_deg`: the plants', controllers' and structure's default
    /// parameters, as the realistic configuration sets them. The plants evaluate their
    /// elevation-dependent parameters at the centre of the parameter-grid cell, and so does this.
    pub fn shipped(axis: Axis, elevation_deg: f64) -> Self {
        let modes = parse_modes(DEFAULT_MODES, DEFAULT_MODES_FILE).expect("the shipped modes file parses");
        let participation_index = match axis {
            Axis::Azimuth => 0,
            Axis::Elevation => 1,
        };
        let mode = modes
            .into_iter()
            .find(|m| m.participation[participation_index] != 0.0)
            .expect("the shipped modes file has a mode for each axis");
        match axis {
            Axis::Azimuth => {
                let plant = AzimuthParams::default();
                let frozen = plant.frozen_elevation_deg(elevation_deg);
                let controller =
                    AzimuthController::new(AzimuthControllerParams::default()).expect("the default gains are valid");
                AxisWithMode {
                    axis,
                    elevation_deg,
                    drive: plant.two_mass_at(frozen),
                    gear_ratio: plant.gear_ratio,
                    current_loop_bandwidth_hz: plant.motors[0].current_loop_bandwidth_hz,
                    mode,
                    servo: controller.position_loop_model(),
                }
            }
            Axis::Elevation => {
                let plant = ElevationParams::default();
                let controller = ElevationController::new(ElevationControllerParams::default())
                    .expect("the default gains are valid");
                AxisWithMode {
                    axis,
                    elevation_deg,
                    drive: plant.two_mass_at(elevation_deg),
                    gear_ratio: plant.ratio_at(elevation_deg),
                    current_loop_bandwidth_hz: plant.motor.current_loop_bandwidth_hz,
                    mode,
                    servo: controller.position_loop_model_at(elevation_deg),
                }
            }
        }
    }

    /// The axis's participation in its mode, `p`.
    fn participation(&self) -> f64 {
        match self.axis {
            Axis::Azimuth => self.mode.participation[0],
            Axis::Elevation => self.mode.participation[1],
        }
    }

    /// The mode's beam participation on the sky in the axis's own beam direction, `b`: a
    /// rotation about the azimuth axis projected with cos(el), as the Structure FMU does.
    fn beam_participation(&self) -> f64 {
        let on_sky = self.mode.beam_on_sky(self.elevation_deg.to_radians().cos());
        match self.axis {
            Axis::Azimuth => on_sky[0],
            Axis::Elevation => on_sky[1],
        }
    }

    /// How much of a load angle reaches the sky: `cos(el)` for azimuth, 1 for elevation.
    fn sky_scale(&self) -> f64 {
        match self.axis {
            Axis::Azimuth => self.elevation_deg.to_radians().cos(),
            Axis::Elevation => 1.0,
        }
    }

    /// The three bodies at `s`: the dynamic stiffness matrix of (motor angle, load angle, mode
    /// coordinate), all reflected to the motor side, solved for the two torques.
    pub fn mechanics(&self, s: C64) -> MechanicalResponse {
        let d = &self.drive;
        let n = self.gear_ratio;
        let n2 = n * n;
        let p = self.participation();
        let w = self.mode.omega();
        // The mode reflected to the motor side: its inertia, damping and stiffness over N^2.
        let modal_inertia = self.mode.inertia() / n2;
        let modal_stiffness = self.mode.stiffness / n2;
        let modal_damping = 2.0 * self.mode.damping_ratio * self.mode.stiffness / w / n2;
        // The plant keeps the load inertia less what the mode carries (p^2 K / w^2).
        let remaining_inertia = d.load_inertia - p * p * modal_inertia;
        let shaft = d.shaft_stiffness + d.cross_coupled_damping * s;
        let spring = modal_stiffness + modal_damping * s;
        let zero = C64::new(0.0, 0.0);
        #[rustfmt::skip]
        let stiffness = Matrix3::new(
            d.motor_inertia * s * s + d.motor_friction * s + shaft, -shaft, zero,
            -shaft, remaining_inertia * s * s + shaft, -p * spring,
            zero, p * modal_inertia * s * s, modal_inertia * s * s + spring,
        );
        let inverse = stiffness.try_inverse().expect("the three bodies' dynamic stiffness is regular off its poles");
        // The wind's torque T about the axis is T / N on the motor side; the load takes T
        // less p (p T) (what goes into the mode's body through its participation), the mode's
        // body p T.
        let wind = nalgebra::Vector3::new(zero, C64::new((1.0 - p * p) / n, 0.0), C64::new(p / n, 0.0));
        let per_wind = inverse * wind;
        MechanicalResponse {
            per_motor_torque: [inverse[(0, 0)], inverse[(1, 0)], inverse[(2, 0)]],
            per_wind_torque: [per_wind[0], per_wind[1], per_wind[2]],
        }
    }

    /// The plant as the cascade sees it with the mode inside the loops: the measured motor speed
    /// and the encoder's axis angle per N m of motor torque, through the current loop and the
    /// three bodies (the mode coupled both ways).
    pub fn plant_response(&self, omega: f64) -> AxisPlantResponse {
        let s = C64::new(0.0, omega);
        let m = self.mechanics(s);
        let current = current_loop_response(s, self.current_loop_bandwidth_hz);
        AxisPlantResponse {
            motor_speed_per_torque: current * s * m.per_motor_torque[0],
            axis_angle_per_torque: current * m.per_motor_torque[1] / self.gear_ratio,
        }
    }

    /// The velocity and position loops' margins with the mode inside them, over the same
    /// frequency grids as the margins of the two-mass plant (docs/controller.md).
    pub fn loop_margins(&self) -> LoopMargins {
        let velocity = &self.servo.velocity;
        LoopMargins {
            velocity: margins(
                |w| velocity.open_loop(w, self.plant_response(w).motor_speed_per_torque),
                0.05,
                499.0,
                20_000,
            ),
            position: margins(|w| self.servo.open_loop(w, &self.plant_response(w)), 0.005, 100.0, 20_000),
        }
    }

    /// The same axis with another mode: modal stiffness `stiffness` (N m/rad) and the mode's
    /// body carrying `inertia_share` of the axis's load inertia, which sets its clamped-base
    /// frequency `sqrt(K / (share J_load)) / 2 pi` (the parameters `structure.stiffness` and
    /// `structure.*_mode_inertia_share` of docs/parameters.csv).
    pub fn with_mode(&self, stiffness: f64, inertia_share: f64) -> Self {
        let load_inertia_at_axis = self.drive.load_inertia * self.gear_ratio * self.gear_ratio;
        let p = match self.axis {
            Axis::Azimuth => self.mode.participation[0],
            Axis::Elevation => self.mode.participation[1],
        };
        let modal_inertia = inertia_share * load_inertia_at_axis / (p * p);
        let mut mode = self.mode.clone();
        mode.stiffness = stiffness;
        mode.frequency_hz = (stiffness / modal_inertia).sqrt() / TAU;
        Self { mode, ..self.clone() }
    }

    /// The share of the axis's load inertia that the mode's body carries, `p^2 K / w^2 / J_load`.
    pub fn inertia_share(&self) -> f64 {
        let p = match self.axis {
            Axis::Azimuth => self.mode.participation[0],
            Axis::Elevation => self.mode.participation[1],
        };
        p * p * self.mode.inertia() / (self.drive.load_inertia * self.gear_ratio * self.gear_ratio)
    }

    /// The beam's pointing on the sky (rad) per N m of the wind's torque about the axis, with
    /// the servo holding a constant command and the axis free to move (no friction). The
    /// pointing error is its negative.
    pub fn beam_per_wind_torque_free(&self, omega: f64) -> C64 {
        let s = C64::new(0.0, omega);
        let n = self.gear_ratio;
        let m = self.mechanics(s);
        let current = current_loop_response(s, self.current_loop_bandwidth_hz);
        let v = &self.servo.velocity;
        // The cascade's torque command for a constant position command:
        // u = D C_v (N K_p (0 - theta_L) - F omega_M), theta_L the encoder's load angle.
        let cascade = v.actuation(omega) * v.controller(omega);
        let position = self.servo.gear_ratio * self.servo.controller(omega);
        let filter = v.filter(omega);
        let command_path = |response: &[C64; 3]| cascade * (position * response[1] / n + filter * s * response[0]);
        let loop_gain = command_path(&m.per_motor_torque) * current;
        let torque_command = -command_path(&m.per_wind_torque) / (1.0 + loop_gain);
        let motor_torque = current * torque_command;
        let load = (m.per_wind_torque[1] + m.per_motor_torque[1] * motor_torque) / n;
        let mode = (m.per_wind_torque[2] + m.per_motor_torque[2] * motor_torque) / n;
        self.sky_scale() * load + self.beam_participation() * mode
    }

    /// The same with the axis clamped: the mode on a fixed base, `b p / (J_m s^2 + c s + K)`.
    pub fn beam_per_wind_torque_clamped(&self, omega: f64) -> C64 {
        let s = C64::new(0.0, omega);
        let w = self.mode.omega();
        let k = self.mode.stiffness;
        let dynamic = self.mode.inertia() * s * s + 2.0 * self.mode.damping_ratio * k / w * s + k;
        self.beam_participation() * self.participation() / dynamic
    }

    /// The resonance of the free axis between `low_hz` and `high_hz`.
    pub fn free_resonance(&self, low_hz: f64, high_hz: f64) -> Resonance {
        resonance(|w| self.beam_per_wind_torque_free(w), low_hz, high_hz)
    }

    /// The resonance of the clamped axis between `low_hz` and `high_hz`.
    pub fn clamped_resonance(&self, low_hz: f64, high_hz: f64) -> Resonance {
        resonance(|w| self.beam_per_wind_torque_clamped(w), low_hz, high_hz)
    }
}

/// Arcseconds per radian.
const ARCSEC_PER_RAD: f64 = 180.0 / std::f64::consts::PI * 3600.0;

/// A simulated frequency response: bin frequencies (Hz) and values (rad per N m).
pub type SimulatedResponse<'a> = (&'a [f64], &'a [C64]);

/// One panel per axis: the magnitude of the beam's pointing per wind torque (arcsec per kN m)
/// from `low_hz` to `high_hz`, the free axis's model, the clamped mode's, and where given a
/// simulated estimate as markers.
pub fn figure(title: &str, axes: &[(&AxisWithMode, Option<SimulatedResponse>)], low_hz: f64, high_hz: f64) -> Figure {
    let points = 600;
    let grid: Vec<f64> = (0..=points).map(|k| low_hz * (high_hz / low_hz).powf(k as f64 / points as f64)).collect();
    let scale = ARCSEC_PER_RAD * 1e3;
    let mut figure = Figure::new(1000, 400 * axes.len() as u32).title(title);
    for (model, simulated) in axes {
        let free: Vec<f64> = grid.iter().map(|f| scale * model.beam_per_wind_torque_free(TAU * f).norm()).collect();
        let clamped: Vec<f64> =
            grid.iter().map(|f| scale * model.beam_per_wind_torque_clamped(TAU * f).norm()).collect();
        let mut panel = Panel::new(&format!("{} at {} deg", model.axis.name(), model.elevation_deg))
            .x_label("Frequency (Hz)")
            .y_label("|beam pointing / wind torque| (arcsec per kN m)")
            .log_y();
        if let Some((frequency_hz, response)) = simulated {
            let keep: Vec<usize> =
                (0..frequency_hz.len()).filter(|&k| (low_hz..=high_hz).contains(&frequency_hz[k])).collect();
            let f: Vec<f64> = keep.iter().map(|&k| frequency_hz[k]).collect();
            let h: Vec<f64> = keep.iter().map(|&k| scale * response[k].norm()).collect();
            panel = panel.markers("coupled antenna, friction zeroed (H1)", &f, &h);
        }
        panel = panel.line("linear model, axis free (servo closed, no friction)", &grid, &free).dashed(
            "the mode on a fixed base (axis clamped)",
            &grid,
            &clamped,
        );
        figure = figure.panel(panel);
    }
    figure
}

/// The resonance of `response` (a function of omega, rad/s) between `low_hz` and `high_hz`:
/// the peak on a fine grid refined by golden-section search, its half-power points, and the
/// pole nearest to it.
///
/// The pole is found from the response on the imaginary axis alone: `g = 1 / H` is analytic
/// and vanishes at the pole, so its Taylor series about `j w_peak` (derivatives along the axis,
/// `dg/ds = -j dg/dw`) to second order, set to zero, gives the pole's offset. It is exact for a
/// single second-order resonance (the clamped mode) and close for a peak that stands out of the
/// rest of the response.
pub fn resonance(response: impl Fn(f64) -> C64, low_hz: f64, high_hz: f64) -> Resonance {
    let magnitude = |f: f64| response(TAU * f).norm();
    let points = 4000;
    let grid: Vec<f64> = (0..=points).map(|k| low_hz + (high_hz - low_hz) * k as f64 / points as f64).collect();
    let (best, _) = grid
        .iter()
        .enumerate()
        .max_by(|a, b| magnitude(*a.1).total_cmp(&magnitude(*b.1)))
        .expect("the grid is not empty");
    let (mut a, mut b) = (grid[best.saturating_sub(1)], grid[(best + 1).min(points)]);
    // Golden-section search for the maximum within the grid's neighbouring points.
    let ratio = (5f64.sqrt() - 1.0) / 2.0;
    for _ in 0..80 {
        let (c, d) = (b - ratio * (b - a), a + ratio * (b - a));
        if magnitude(c) > magnitude(d) {
            b = d;
        } else {
            a = c;
        }
    }
    let peak_hz = 0.5 * (a + b);
    let peak_magnitude = magnitude(peak_hz);
    let level = peak_magnitude / 2f64.sqrt();
    let below = grid[..=best].iter().rev().find(|f| magnitude(**f) < level).copied();
    let above = grid[best..].iter().find(|f| magnitude(**f) < level).copied();
    let crossing = |mut inside: f64, mut outside: f64| {
        for _ in 0..60 {
            let middle = 0.5 * (inside + outside);
            if magnitude(middle) >= level {
                inside = middle;
            } else {
                outside = middle;
            }
        }
        0.5 * (inside + outside)
    };
    let half_power_damping = match (below, above) {
        (Some(lo), Some(hi)) => Some((crossing(peak_hz, hi) - crossing(peak_hz, lo)) / (2.0 * peak_hz)),
        _ => None,
    };
    let omega = TAU * peak_hz;
    let h = 1e-4 * omega;
    let g = |w: f64| 1.0 / response(w);
    let (g0, g_plus, g_minus) = (g(omega), g(omega + h), g(omega - h));
    let j = C64::new(0.0, 1.0);
    // Along s = j w: dg/ds = (dg/dw) / j and d2g/ds2 = (d2g/dw2) / j^2.
    let first = (g_plus - g_minus) / (2.0 * h) / j;
    let second = -(g_plus - 2.0 * g0 + g_minus) / (h * h);
    // g0 + first d + second d^2 / 2 = 0, the root nearer the axis.
    let root = (first * first - 2.0 * second * g0).sqrt();
    let candidates = [(-first + root) / second, (-first - root) / second];
    let offset = if candidates[0].norm() < candidates[1].norm() { candidates[0] } else { candidates[1] };
    Resonance { peak_hz, peak_magnitude, half_power_damping, pole: j * omega + offset }
}

/// Bode and Nichols charts of the velocity and position loops' open-loop responses for each
/// `(name, axis)` case: what a servo engineer reads the margins from. The Nichols chart marks
/// the critical point (-180 deg, 0 dB); the distance of each curve from it is the margin.
pub fn open_loop_figures(title: &str, cases: &[(String, AxisWithMode)]) -> (Figure, Figure) {
    let frequency_hz: Vec<f64> = (0..=800).map(|k| 0.1 * 10f64.powf(3.3 * k as f64 / 800.0)).collect();
    let mut responses: Vec<(String, Vec<C64>)> = Vec::new();
    for (name, axis) in cases {
        let velocity = &axis.servo.velocity;
        let at = |f: &f64| TAU * f;
        responses.push((
            format!("{name}: velocity loop"),
            frequency_hz
                .iter()
                .map(|f| velocity.open_loop(at(f), axis.plant_response(at(f)).motor_speed_per_torque))
                .collect(),
        ));
        responses.push((
            format!("{name}: position loop"),
            frequency_hz.iter().map(|f| axis.servo.open_loop(at(f), &axis.plant_response(at(f)))).collect(),
        ));
    }
    let curves: Vec<(&str, &[f64], &[C64])> =
        responses.iter().map(|(name, h)| (name.as_str(), frequency_hz.as_slice(), h.as_slice())).collect();
    let bode = antenna_plot::bode(&format!("{title}: open loops (Bode)"), &curves);
    let mut nichols = Panel::new(&format!("{title}: open loops (Nichols)"))
        .x_label("open-loop phase (deg)")
        .y_label("open-loop gain (dB)")
        .x_range(-540.0, 0.0)
        .y_range(-40.0, 60.0);
    for (name, h) in &responses {
        let wrapped: Vec<f64> = h.iter().map(|v| v.arg().to_degrees()).collect();
        // Unwrapped from the low-frequency end, shifted by whole turns into (-360, 0] there.
        let mut phase = antenna_dsp::unwrap_phase_deg(&wrapped);
        let shift = 360.0 * ((phase[0] + 360.0) / 360.0).floor();
        phase.iter_mut().for_each(|p| *p -= shift);
        let gain: Vec<f64> = h.iter().map(|v| 20.0 * v.norm().log10()).collect();
        nichols = nichols.line(name, &phase, &gain);
    }
    let nichols = nichols.vertical_line("-180 deg", -180.0).horizontal_line("0 dB", 0.0).markers(
        "critical point",
        &[-180.0],
        &[0.0],
    );
    (bode, Figure::new(1000, 800).panel(nichols))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The clamped mode is a single second-order resonance: its pole, from the response on the
    /// axis alone, is the mode's `-zeta w +- j w sqrt(1 - zeta^2)`, and its peak is at `w
    /// sqrt(1 - 2 zeta^2)`.
    #[test]
    fn the_clamped_mode_has_the_modes_own_frequency_and_damping() {
        let model = AxisWithMode::shipped(Axis::Azimuth, 45.0);
        let r = model.clamped_resonance(3.0, 9.0);
        let (f, zeta) = (model.mode.frequency_hz, model.mode.damping_ratio);
        assert!((r.pole_frequency_hz() / f - 1.0).abs() < 1e-6, "{r:?}");
        assert!((r.pole_damping() / zeta - 1.0).abs() < 1e-4, "{r:?}");
        assert!((r.peak_hz / (f * (1.0 - 2.0 * zeta * zeta).sqrt()) - 1.0).abs() < 1e-7, "{r:?}");
        let half_power = r.half_power_damping.expect("a 1.5 % peak has half-power points");
        assert!((half_power / zeta - 1.0).abs() < 0.01, "{half_power} against {zeta}");
    }

    /// Below the servo's bandwidth the servo holds the load still, so the wind's static
    /// deflection of the beam is the mode's compliance `b p / K` whether the axis is free or
    /// clamped; and the model's mechanics without a servo reduce to the rigid body at low
    /// frequency (the whole load inertia, the mode's included).
    #[test]
    fn at_low_frequency_the_free_axis_deflects_the_beam_as_the_clamped_one() {
        for axis in Axis::BOTH {
            let model = AxisWithMode::shipped(axis, 45.0);
            let omega = TAU * 1e-3;
            let free = model.beam_per_wind_torque_free(omega);
            let clamped = model.beam_per_wind_torque_clamped(omega);
            assert!((free / clamped - 1.0).norm() < 1e-3, "{axis:?}: {free} against {clamped}");
            let s = C64::new(0.0, TAU * 0.01);
            let m = model.mechanics(s);
            let d = &model.drive;
            let rigid = 1.0 / ((d.motor_inertia + d.load_inertia) * s * s + d.motor_friction * s);
            assert!((m.per_motor_torque[1] / rigid - 1.0).norm() < 1e-3, "{axis:?}");
        }
    }
}
