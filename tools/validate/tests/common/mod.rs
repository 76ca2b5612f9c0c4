//! The synthetic rigid axis that the re-estimation tests share: a truth parameter set and a
//! 15 s log of it simulated by the crate's own rigid stand-in for the plant FMU, with white
//! sensor noise and a slow unlogged disturbance torque that colours the equation error's
//! residual, as the real records' unmodelled dynamics do.

use antenna_validate::output_error::{PlantSimulator, RigidReferenceSimulator, WindowStart};
use antenna_validate::parameters::{names, FmuConfig, FmuDrive, FmuInput, ParameterSet};
use rand::SeedableRng;
use rand_distr::{Distribution, Normal};
use std::f64::consts::TAU;

/// Log interval, s.
pub const DT: f64 = 0.004;
pub const GEAR: f64 = 100.0;
/// Samples of a log (15 s).
pub const SAMPLES: usize = 3750;
/// The truth's friction, axis side: Coulomb (N m) and viscous (N m s/rad).
pub const COULOMB: f64 = 60.0;
pub const VISCOUS: f64 = 80.0;
/// Torque sensor noise (axis side, N m) and motor encoder noise (rad).
pub const TORQUE_NOISE: f64 = 2.0;
pub const POSITION_NOISE: f64 = 1e-6;
/// Amplitude (N m) of the slowest of the three sines of the unlogged disturbance torque.
pub const DISTURBANCE: f64 = 20.0;
/// The axis torque's three frequencies (Hz) of the re-estimation test's log: slow reversals.
pub const FREQUENCIES: [f64; 3] = [0.31, 1.13, 2.71];

/// The truth: a rigid axis with Coulomb and viscous friction.
pub fn truth() -> ParameterSet {
    let mut p = ParameterSet::new();
    p.set(names::GEAR_RATIO, GEAR);
    p.set(names::MOTOR_INERTIA, 2e-3);
    p.set(names::TORQUE_CONSTANT, 1.0);
    p.set(names::LOAD_INERTIA, 30.0);
    p.set(names::COULOMB, COULOMB);
    p.set(names::STATIC, COULOMB);
    p.set(names::VISCOUS, VISCOUS);
    p
}

/// A 15 s log of `truth` driven by an axis torque of three sines of the given frequencies (Hz;
/// amplitudes 300, 150 and 80 N m) that reverses the axis often: motor torque and motor encoder
/// only, with white sensor noise.
pub fn log_csv(truth: &ParameterSet, frequencies: [f64; 3]) -> String {
    let [f1, f2, f3] = frequencies;
    let axis_torque =
        |t: f64| 300.0 * (TAU * f1 * t).sin() + 150.0 * (TAU * f2 * t + 1.0).sin() + 80.0 * (TAU * f3 * t + 2.0).sin();
    let torque: Vec<f64> = (0..=SAMPLES).map(|k| axis_torque(k as f64 * DT)).collect();
    // Held over each interval at the mean of its two samples, as the output error drives the plant.
    let held: Vec<[f64; 2]> = torque
        .windows(2)
        .map(|w| {
            let motor = 0.5 * (w[0] + w[1]) / GEAR;
            [motor, motor]
        })
        .collect();
    let mut simulator = RigidReferenceSimulator::default();
    let config =
        FmuConfig { drive: FmuDrive::Mirrored, input: FmuInput::Torque, sample_interval: DT, length_unit: 1.0 };
    simulator.configure(truth, &config).unwrap();
    let start = WindowStart {
        load_angle: 0.0,
        load_speed: 0.0,
        motor_angle: 0.0,
        motor_speed: 0.0,
        twist: 0.0,
        currents: held[0],
        history: Vec::new(),
    };
    // An unlogged slow disturbance torque on the axis (cable drag, wind).
    let disturbance: Vec<f64> = (0..SAMPLES)
        .map(|k| {
            let t = (k as f64 + 0.5) * DT;
            DISTURBANCE
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
