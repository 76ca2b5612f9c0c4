//! The controllers against the real plant crate (`fmu_plant`) with its default friction,
//! backlash and encoder quantisation: the controller's drive knowledge matches the plant's
//! defaults, the analytic loops built from the plant's own two-mass model meet the design,
//! and the closed loop meets the step, slew and tracking requirements and shows the effect of
//! each feature the lead's system tests will switch off.

mod common;

use common::*;
use fmu_controller::linear::{bandwidth_hz, margins, AxisPlantResponse, C64};
use fmu_controller::params::{AzimuthDriveModel, ElevationDriveModel};
use fmu_controller::{AzimuthController, AzimuthControllerParams, ElevationController, ElevationControllerParams};
use fmu_plant::analytic::current_loop_response;
use fmu_plant::{AzimuthParams, AzimuthPlant, ElevationParams, ElevationPlant};

const ELEVATIONS: [f64; 3] = [15.0, 45.0, 88.0];

/// The azimuth plant at a fixed elevation.
struct Azimuth {
    plant: AzimuthPlant,
    elevation_deg: f64,
}

impl Azimuth {
    fn new(params: AzimuthParams, elevation_deg: f64, start_deg: f64) -> Self {
        let mut plant = AzimuthPlant::new(params).unwrap();
        plant.set_initial_state(start_deg.to_radians()).unwrap();
        Self { plant, elevation_deg }
    }
}

impl Plant for Azimuth {
    fn encoder_deg(&self) -> f64 {
        self.plant.outputs().encoder_position_deg
    }
    fn axis_deg(&self) -> f64 {
        self.plant.outputs().axis_position_deg
    }
    fn motor_speeds(&self) -> Vec<f64> {
        self.plant.outputs().motor_speed_rad_per_s.to_vec()
    }
    fn apply(&mut self, currents: &[f64], h: f64) {
        let inputs = fmu_plant::AzimuthInputs {
            current_command_a: [currents[0], currents[1]],
            disturbance_torque_nm: 0.0,
            elevation_deg: self.elevation_deg,
        };
        self.plant.step(&inputs, h).unwrap();
    }
}

struct Elevation {
    plant: ElevationPlant,
}

impl Elevation {
    fn new(params: ElevationParams, start_deg: f64) -> Self {
        let mut plant = ElevationPlant::new(params).unwrap();
        plant.set_initial_state(start_deg.to_radians()).unwrap();
        Self { plant }
    }
}

impl Plant for Elevation {
    fn encoder_deg(&self) -> f64 {
        self.plant.outputs().encoder_position_deg
    }
    fn axis_deg(&self) -> f64 {
        self.plant.outputs().axis_position_deg
    }
    fn motor_speeds(&self) -> Vec<f64> {
        vec![self.plant.outputs().motor_speed_rad_per_s]
    }
    fn apply(&mut self, currents: &[f64], h: f64) {
        let inputs = fmu_plant::ElevationInputs { current_command_a: currents[0], disturbance_torque_nm: 0.0 };
        self.plant.step(&inputs, h).unwrap();
    }
}

fn azimuth_with(edit: impl FnOnce(&mut AzimuthControllerParams)) -> AzimuthController {
    let mut p = AzimuthControllerParams::default();
    edit(&mut p);
    AzimuthController::new(p).unwrap()
}

fn elevation_with(edit: impl FnOnce(&mut ElevationControllerParams)) -> ElevationController {
    let mut p = ElevationControllerParams::default();
    edit(&mut p);
    ElevationController::new(p).unwrap()
}

#[test]
fn controller_drive_knowledge_matches_the_plant_defaults() {
    let az_plant = AzimuthParams::default();
    let az = AzimuthDriveModel::default();
    assert_eq!(az.gear_ratio, az_plant.gear_ratio);
    assert_eq!(az.motor_inertia_kg_m2, az_plant.motors[0].inertia_kg_m2);
    assert_eq!(az.torque_constant_nm_per_a, az_plant.motors[0].torque_constant_nm_per_a);
    assert_eq!(az.current_limit_a, az_plant.motors[0].current_limit_a);
    assert_eq!(az.axis_inertia_kg_m2, az_plant.axis_inertia_kg_m2(45.0));

    let el_plant = ElevationParams::default();
    let el = ElevationDriveModel::default();
    assert_eq!(el.motor_inertia_kg_m2, el_plant.motor.inertia_kg_m2);
    assert_eq!(el.dish_inertia_kg_m2, el_plant.dish_inertia_kg_m2);
    assert_eq!(el.torque_constant_nm_per_a, el_plant.motor.torque_constant_nm_per_a);
    assert_eq!(el.current_limit_a, el_plant.motor.current_limit_a);
    assert_eq!((el.travel_min_deg, el.travel_max_deg), (el_plant.travel_min_deg, el_plant.travel_max_deg));
    for deg in [15.0, 30.0, 45.0, 60.0, 88.0, 92.0] {
        let (ours, theirs) = (el.gear_ratio_at(deg), el_plant.ratio_at(deg));
        assert!((ours / theirs - 1.0).abs() < 1e-12, "ratio at {deg} deg: {ours} vs {theirs}");
    }
}

/// The plant crate's own linear two-mass model, with its current loop, as the controller's
/// linear models want it.
fn azimuth_response(el: f64, omega: f64) -> AxisPlantResponse {
    let p = AzimuthParams::default();
    let model = p.two_mass_at(el);
    let s = C64::new(0.0, omega);
    let current = current_loop_response(s, p.motors[0].current_loop_bandwidth_hz);
    AxisPlantResponse {
        motor_speed_per_torque: current * model.motor_speed_per_torque(s),
        axis_angle_per_torque: current * model.load_position_per_torque(s) / p.gear_ratio,
    }
}

fn elevation_response(el: f64, omega: f64) -> AxisPlantResponse {
    let p = ElevationParams::default();
    let model = p.two_mass_at(el);
    let s = C64::new(0.0, omega);
    let current = current_loop_response(s, p.motor.current_loop_bandwidth_hz);
    AxisPlantResponse {
        motor_speed_per_torque: current * model.motor_speed_per_torque(s),
        axis_angle_per_torque: current * model.load_position_per_torque(s) / p.ratio_at(el),
    }
}

#[test]
fn loops_designed_on_the_plant_crates_two_mass_model_meet_the_bandwidth_and_margin_targets() {
    let az = azimuth_with(|_| {});
    let elc = elevation_with(|_| {});
    for el in ELEVATIONS {
        let cases = [
            (
                "azimuth",
                az.velocity_loop_model(),
                az.position_loop_model(),
                azimuth_response as fn(f64, f64) -> AxisPlantResponse,
            ),
            ("elevation", elc.velocity_loop_model_at(el), elc.position_loop_model_at(el), elevation_response),
        ];
        for (axis, velocity, position, response) in cases {
            let p = |w: f64| response(el, w);
            let m = margins(|w| velocity.open_loop(w, p(w).motor_speed_per_torque), 0.05, 499.0, 20_000);
            let bw =
                bandwidth_hz(|w| velocity.closed_loop(w, p(w).motor_speed_per_torque), 0.05, 499.0, 20_000).unwrap();
            let position_bw = bandwidth_hz(|w| position.feedback_closed_loop(w, &p(w)), 0.005, 100.0, 5000).unwrap();
            println!(
                "{axis} at {el} deg: velocity bandwidth {bw:.2} Hz, PM {:.1} deg, GM {:.1} dB, modulus margin {:.3}; \
                 position bandwidth {position_bw:.3} Hz",
                m.phase_margin_deg, m.gain_margin_db, m.modulus_margin
            );
            assert!((10.0..=15.0).contains(&bw), "{axis} at {el}: {bw} Hz");
            assert!(m.phase_margin_deg >= 45.0 && m.gain_margin_db >= 10.0 && m.modulus_margin >= 0.5, "{m:?}");
            assert!((0.5..=1.0).contains(&position_bw), "{axis} at {el}: {position_bw} Hz");
        }
    }
}

/// Holds `start`, then steps to `start + step` at t = 0; returns records from the step on.
fn step_case<C: AxisController, P: Plant>(controller: C, plant: P, start: f64, step: f64, seconds: f64) -> Vec<Record>
where
    C::Outputs: Clone,
{
    let mut rig = Rig::new(controller, plant);
    rig.run(3.0, |_| Commands { position_deg: start, ..Commands::default() });
    let t0 = rig.time;
    let mut records = rig.run(seconds, |_| Commands { position_deg: start + step, ..Commands::default() });
    for r in &mut records {
        r.time -= t0;
    }
    records
}

#[test]
fn steps_and_slews_meet_requirements_2_to_4_on_the_plant() {
    let band = 15.0 * ARCSEC;
    for el in ELEVATIONS {
        // (step, limit on settling measured from the step, or from the end of the cruise).
        for (step, limit, from_braking) in [(0.5, 4.0, false), (-4.0, 10.0, false), (40.0, 15.0, true)] {
            let el_step = if step > 20.0 { 30.0 } else { step };
            let el_start = if step > 20.0 { 20.0 } else { el.min(80.0) };
            let seconds = if from_braking { 45.0 } else { 20.0 };
            let cases = [
                (
                    "azimuth",
                    step_case(
                        azimuth_with(|_| {}),
                        Azimuth::new(AzimuthParams::default(), el, 0.0),
                        0.0,
                        step,
                        seconds,
                    ),
                    0.0,
                    step,
                ),
                (
                    "elevation",
                    step_case(
                        elevation_with(|_| {}),
                        Elevation::new(ElevationParams::default(), el_start),
                        el_start,
                        el_step,
                        seconds,
                    ),
                    el_start,
                    el_step,
                ),
            ];
            for (axis, records, start, size) in cases {
                let from = if from_braking {
                    let max_speed =
                        records.iter().map(|r| r.status.reference_velocity_deg_per_s.abs()).fold(0.0, f64::max);
                    let k = records
                        .iter()
                        .rposition(|r| r.status.reference_velocity_deg_per_s.abs() >= 0.999 * max_speed)
                        .unwrap();
                    records[k].time
                } else {
                    0.0
                };
                let settle = settling_time(&records, from, band, 10.0).unwrap_or(f64::INFINITY);
                let over = overshoot(&records, start, start + size) / ARCSEC;
                let tail: Vec<f64> =
                    records.iter().rev().take(5000).map(|r| (r.command_deg - r.axis_deg) / ARCSEC).collect();
                println!(
                    "{axis} (elevation {el} deg) step {size} deg: settled {settle:.2} s{}, overshoot {over:.2} arcsec, \
                     final 5 s error RMS {:.3} arcsec",
                    if from_braking { " after braking began" } else { "" },
                    rms(&tail)
                );
                assert!(settle < limit, "{axis} at {el} deg, step {size}: {settle} s");
                assert!(over < 15.0, "{axis} at {el} deg, step {size}: overshoot {over} arcsec");
            }
        }
    }
}

#[test]
fn tracking_jitter_on_the_plant_is_far_below_15_arcsec_rms() {
    for rate in [0.004178, -0.04] {
        for el in ELEVATIONS {
            let start = el.min(80.0);
            let mut az = Rig::new(azimuth_with(|_| {}), Azimuth::new(AzimuthParams::default(), el, 0.0));
            let a =
                az.run(25.0, |t| Commands { position_deg: rate * t, velocity_deg_per_s: rate, ..Commands::default() });
            let mut ev = Rig::new(elevation_with(|_| {}), Elevation::new(ElevationParams::default(), start));
            let e = ev.run(25.0, |t| Commands {
                position_deg: start + rate * t,
                velocity_deg_per_s: rate,
                ..Commands::default()
            });
            for (axis, records) in [("azimuth", a), ("elevation", e)] {
                let window: Vec<f64> =
                    records.iter().filter(|r| r.time >= 15.0).map(|r| r.command_deg - r.axis_deg).collect();
                let jitter = rms(&window) / ARCSEC;
                println!("{axis} at {el} deg tracking {rate} deg/s: {jitter:.3} arcsec RMS");
                assert!(jitter < 3.0, "{axis} at {el} deg, {rate} deg/s: {jitter} arcsec RMS");
            }
        }
    }
}

/// Errors (arcsec) while tracking `centre + amplitude sin(2 pi t / period)`, after one period.
fn sine_track<C: AxisController, P: Plant>(
    controller: C,
    plant: P,
    centre: f64,
    amplitude: f64,
    period: f64,
) -> Vec<f64>
where
    C::Outputs: Clone,
{
    let w = std::f64::consts::TAU / period;
    let mut rig = Rig::new(controller, plant);
    let records = rig.run(3.0 * period, |t| Commands {
        position_deg: centre + amplitude * (w * t).sin(),
        velocity_deg_per_s: amplitude * w * (w * t).cos(),
        ..Commands::default()
    });
    records.iter().filter(|r| r.time > period).map(|r| (r.command_deg - r.axis_deg) / ARCSEC).collect()
}

fn peak(values: &[f64]) -> f64 {
    values.iter().fold(0.0, |m, v| m.max(v.abs()))
}

#[test]
fn switching_features_off_shows_their_effect_on_the_plant() {
    // Profiler off: a 4 deg step overshoots.
    let records = step_case(
        azimuth_with(|p| p.cascade.profiler.enabled = false),
        Azimuth::new(AzimuthParams::default(), 45.0, 0.0),
        0.0,
        4.0,
        20.0,
    );
    let over = overshoot(&records, 0.0, 4.0) / ARCSEC;
    println!("azimuth, profiler off: 4 deg step overshoots by {over:.0} arcsec");
    assert!(over > 60.0);

    // Torque bias off: the pinion backlash shows in the azimuth error at reversals.
    let track = |bias: bool| {
        sine_track(
            azimuth_with(|p| p.torque_bias.enabled = bias),
            Azimuth::new(AzimuthParams::default(), 45.0, 0.0),
            0.0,
            0.05,
            20.0,
        )
    };
    let (with, without) = (track(true), track(false));
    println!(
        "azimuth reversals: peak error {:.2} arcsec with torque bias, {:.2} without (RMS {:.3} vs {:.3})",
        peak(&with),
        peak(&without),
        rms(&with),
        rms(&without)
    );
    assert!(peak(&without) > 2.0 * peak(&with));

    // Friction feedforward off: larger elevation error at low speed.
    let track = |ff: bool| {
        sine_track(
            elevation_with(|p| p.friction_feedforward.enabled = ff),
            Elevation::new(ElevationParams::default(), 45.0),
            45.0,
            0.05,
            20.0,
        )
    };
    let (with, without) = (track(true), track(false));
    println!(
        "elevation at low speed: RMS error {:.3} arcsec with friction feedforward, {:.3} without (peak {:.2} vs {:.2})",
        rms(&with),
        rms(&without),
        peak(&with),
        peak(&without)
    );
    assert!(rms(&without) > 1.5 * rms(&with));
}

#[test]
fn simulated_velocity_loop_on_the_linear_plant_matches_the_analytic_bode_plot() {
    for frequency_hz in [2.0, 10.0, 25.0] {
        let w = std::f64::consts::TAU * frequency_hz;
        let c = azimuth_with(|p| {
            p.cascade.feedforward.acceleration_enabled = false;
            p.cascade.velocity_loop.velocity_mode_acceleration_limited = false;
        });
        let expected = c.velocity_loop_model().closed_loop(w, azimuth_response(15.0, w).motor_speed_per_torque);
        let measured = sine_response(c, Azimuth::new(AzimuthParams::linear(), 15.0, 0.0), frequency_hz, 9000.0);
        let ce = elevation_with(|p| {
            p.cascade.feedforward.acceleration_enabled = false;
            p.cascade.velocity_loop.velocity_mode_acceleration_limited = false;
            p.friction_feedforward.enabled = false;
        });
        // The linear plant freezes the jackscrew geometry at one angle; use 45 deg.
        let el = 45.0;
        let expected_el =
            ce.velocity_loop_model_at(el).closed_loop(w, elevation_response(el, w).motor_speed_per_torque);
        let ratio = ElevationParams::default().ratio_at(el);
        let linear = ElevationParams { frozen_geometry_elevation_deg: el, ..ElevationParams::linear() };
        let measured_el = sine_response(ce, Elevation::new(linear, el), frequency_hz, ratio);
        for (axis, m, e) in [("azimuth", measured, expected), ("elevation", measured_el, expected_el)] {
            println!(
                "{axis} {frequency_hz} Hz: simulated {:.4} / {:.2} deg, analytic {:.4} / {:.2} deg",
                m.norm(),
                m.arg().to_degrees(),
                e.norm(),
                e.arg().to_degrees()
            );
            assert!((m.norm() / e.norm() - 1.0).abs() < 0.03, "{axis} at {frequency_hz} Hz");
            assert!((m / e).arg().to_degrees().abs() < 3.0, "{axis} at {frequency_hz} Hz");
        }
    }
}

/// Velocity mode with a small sine; returns motor speed over motor speed reference at the
/// sine's frequency.
fn sine_response<C: AxisController, P: Plant>(controller: C, plant: P, frequency_hz: f64, gear_ratio: f64) -> C64
where
    C::Outputs: Clone,
{
    let amplitude_deg = 0.01;
    let mut rig = Rig::new(controller, plant);
    let period = 1.0 / frequency_hz;
    let span = (2.0f64 / period).ceil() * period;
    let command = move |t: f64| Commands {
        mode: fmu_controller::ControlMode::Velocity,
        velocity_mode_deg_per_s: amplitude_deg * (std::f64::consts::TAU * frequency_hz * t).sin(),
        ..Commands::default()
    };
    rig.run(span, command);
    let records = rig.run(span, command);
    let mut acc = C64::new(0.0, 0.0);
    for r in &records {
        let phase = std::f64::consts::TAU * frequency_hz * r.time;
        acc += r.motor_speed_mean * C64::new(phase.sin(), phase.cos());
    }
    acc * 2.0 / records.len() as f64 / (amplitude_deg.to_radians() * gear_ratio)
}
