//! The re-estimation of a family the starting set already holds (`antenna_validate::reestimate`),
//! on a synthetic rigid axis simulated by the crate's own rigid stand-in for the plant FMU.
//!
//! The case is the mechanism seen on the KUKA records from a start with a friction guess. The
//! truth's Coulomb level is 60 N m, the start's guess 42 N m: a change seven times the torque
//! sensor's noise in the equations, but the axis also carries a slow unlogged disturbance
//! torque (20 N m, periods of 4-14 s) that colours the equation error's residual, as the real
//! records' unmodelled dynamics do, so that its robust test of the change from the guess finds
//! too few independent samples (chi-square 15 against about 19 at the search's level). The
//! family itself, the whole Coulomb friction, passes that test from zero by far (chi-square
//! 219), and the simulation, over 76 windows short against the disturbance, tells the guess
//! from the data (better in 45 of 76 windows, p = 1.3e-3 against its level 3.3e-3). The margin
//! is narrow by construction: a guess of 40 N m is found by the search itself, one of 44 N m is
//! not confirmed by the simulation either.

use antenna_validate::candidates::Kind;
use antenna_validate::measured_log::parse_str;
use antenna_validate::output_error::{PlantSimulator, RigidReferenceSimulator, WindowStart};
use antenna_validate::parameters::{names, FmuConfig, FmuDrive, FmuInput, ParameterSet};
use antenna_validate::{validate_with, ValidateOptions, Validation};
use rand::SeedableRng;
use rand_distr::{Distribution, Normal};

const DT: f64 = 0.004;
const GEAR: f64 = 100.0;
/// The truth's Coulomb level (axis side, N m) and the start's wrong guess of it.
const COULOMB: f64 = 60.0;
const GUESS: f64 = 42.0;
/// Torque sensor noise (axis side, N m).
const TORQUE_NOISE: f64 = 2.0;
const POSITION_NOISE: f64 = 1e-6;
/// Amplitude (N m) of the slowest of the three sines of the unlogged disturbance torque.
const DISTURBANCE: f64 = 20.0;

fn truth() -> ParameterSet {
    let mut p = ParameterSet::new();
    p.set(names::GEAR_RATIO, GEAR);
    p.set(names::MOTOR_INERTIA, 2e-3);
    p.set(names::TORQUE_CONSTANT, 1.0);
    p.set(names::LOAD_INERTIA, 30.0);
    p.set(names::COULOMB, COULOMB);
    p.set(names::STATIC, COULOMB);
    p.set(names::VISCOUS, 80.0);
    p
}

/// A 15 s log of the truth driven by a multisine torque that reverses the axis often, motor
/// torque and motor encoder only, with white sensor noise.
fn log_csv() -> String {
    let n = 3750;
    let axis_torque = |t: f64| {
        use std::f64::consts::TAU;
        300.0 * (TAU * 0.31 * t).sin() + 150.0 * (TAU * 1.13 * t + 1.0).sin() + 80.0 * (TAU * 2.71 * t + 2.0).sin()
    };
    let torque: Vec<f64> = (0..=n).map(|k| axis_torque(k as f64 * DT)).collect();
    // The simulator holds each command over its interval at the mean of its two samples, as
    // the output error drives the plant.
    let held: Vec<[f64; 2]> = torque
        .windows(2)
        .map(|w| {
            let motor = 0.5 * (w[0] + w[1]) / GEAR;
            [motor, motor]
        })
        .collect();
    let mut simulator = RigidReferenceSimulator::default();
    let config = FmuConfig { drive: FmuDrive::Mirrored, input: FmuInput::Torque, sample_interval: DT };
    simulator.configure(&truth(), &config).unwrap();
    let start = WindowStart {
        load_angle: 0.0,
        load_speed: 0.0,
        motor_angle: 0.0,
        motor_speed: 0.0,
        twist: 0.0,
        currents: held[0],
        history: Vec::new(),
    };
    // An unlogged slow disturbance torque on the axis (cable drag, wind), which colours the
    // equation error's residual as the real records' unmodelled dynamics do.
    let amplitude = DISTURBANCE;
    let disturbance: Vec<f64> = (0..n)
        .map(|k| {
            use std::f64::consts::TAU;
            let t = (k as f64 + 0.5) * DT;
            amplitude
                * ((TAU * 0.13 * t + 0.3).sin()
                    + 0.7 * (TAU * 0.07 * t + 2.1).sin()
                    + 0.5 * (TAU * 0.23 * t + 4.0).sin())
        })
        .collect();
    let motion = simulator.simulate(&start, &held, &disturbance, DT).unwrap();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(16);
    let torque_noise = Normal::new(0.0, TORQUE_NOISE / GEAR).unwrap();
    let position_noise = Normal::new(0.0, POSITION_NOISE).unwrap();
    let mut csv = String::from("time_s,motor_torque_Nm,motor_pos_rad\n");
    for (k, (tau, q)) in torque.iter().zip(&motion.motor_pos).enumerate() {
        csv.push_str(&format!(
            "{:.4},{:.6},{:.9}\n",
            k as f64 * DT,
            tau / GEAR + torque_noise.sample(&mut rng),
            q + position_noise.sample(&mut rng)
        ));
    }
    csv
}

fn validate_from(start: &ParameterSet) -> Validation {
    let log = parse_str(&log_csv()).unwrap();
    let mut simulator = RigidReferenceSimulator::default();
    let options = ValidateOptions::default();
    validate_with(&log, start, &options, Some(&mut simulator)).unwrap()
}

fn friction_found(v: &Validation) -> Vec<Kind> {
    v.selection.found.iter().map(|f| f.kind).filter(|k| matches!(k, Kind::Coulomb | Kind::Viscous)).collect()
}

#[test]
fn a_friction_guess_the_equation_error_cannot_reject_is_re_estimated_on_the_motion() {
    let mut start = truth();
    start.set(names::COULOMB, GUESS);
    start.set(names::STATIC, GUESS);
    let v = validate_from(&start);
    let found = friction_found(&v);
    assert_eq!(found, vec![Kind::Coulomb], "found {:?}", v.selection.found);
    let coulomb = v.selection.corrected.value(names::COULOMB);
    assert!((coulomb / COULOMB - 1.0).abs() < 0.1, "Coulomb {coulomb} against the truth's {COULOMB}");
    // The equation error's own test of the change from the guess did not pass: the step that
    // named it is the re-estimation's.
    assert!(v.selection.steps.iter().any(|s| s.re_estimate && s.chosen == Some(Kind::Coulomb)));
    let output = v.output.as_ref().unwrap();
    assert!(output.overall.confirmed, "{}", output.overall.reason);
}

#[test]
fn a_start_holding_the_true_friction_is_not_re_estimated() {
    let v = validate_from(&truth());
    assert!(v.selection.found.is_empty(), "found {:?}", v.selection.found);
    // The families were tested (the start holds them and the data carry them) and not changed.
    assert!(v.selection.steps.iter().any(|s| s.re_estimate && s.chosen.is_none()));
}
