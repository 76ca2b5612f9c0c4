//! Tests of `antenna_validate::output_error` against logs of the truth simulation (which depends on
//! the validation crate, so they live here).

use antenna_truth::{simulate, Effect, TruthConfig};
use antenna_validate::equation_error::{twist_centres, Structure};
use antenna_validate::output_error::*;
use antenna_validate::parameters::{names, ParameterSet};

/// RMS (rad) of the measured axis position less the load-side simulation with `params`,
/// over 1 s windows of a truth log.
fn load_side_error(config: &TruthConfig, params: &ParameterSet) -> f64 {
    let log = simulate(config).log;
    let start = config.plant.starting_parameters();
    let data = antenna_validate::equation_error::prepare(&log, &start, &Default::default()).unwrap();
    let out = OutputData::new(&log, &data, &start).unwrap();
    assert!(out.two_encoders && out.structure == Structure::TwoMass);
    let centres = twist_centres(&data, params);
    let length = (1.0 / out.dt) as usize;
    let (mut sum, mut count) = (0.0, 0);
    for i0 in (0..out.len() - length).step_by(length) {
        let simulated = simulate_load_side(&out, params, &centres, i0, length);
        for (j, y) in simulated.iter().enumerate() {
            sum += (out.load_pos[out.first_sample + i0 + j] - y).powi(2);
            count += 1;
        }
    }
    (sum / count as f64).sqrt()
}

#[test]
fn load_side_follows_a_two_mass_truth_to_the_encoder_noise_and_sees_a_stiffness_error() {
    let config = TruthConfig { duration: 12.0, ..TruthConfig::default() };
    let right = config.plant.starting_parameters();
    let noise = config.noise.twist_sigma(&config.plant);
    let floor = load_side_error(&config, &right);
    assert!(floor < 2.5 * noise, "load-side error {floor:e} rad against twist noise {noise:e} rad");
    let mut soft = right.clone();
    soft.set(names::STIFFNESS, 0.8 * right.value(names::STIFFNESS));
    let wrong = load_side_error(&config, &soft);
    assert!(wrong > 4.0 * floor, "a 20 % stiffness error gives {wrong:e} rad against {floor:e} rad");
}

#[test]
fn load_side_with_the_backlash_follows_a_truth_with_lost_motion() {
    // The truth's contact is smooth (rounded over a tenth of the gap), the model's a
    // sharp flank law: the right width must still explain most of what the gap adds.
    let width = 2.0e-6;
    let config = TruthConfig { duration: 12.0, effects: vec![Effect::Backlash(width)], ..TruthConfig::default() };
    let without = config.plant.starting_parameters();
    let mut with = without.clone();
    with.set(names::BACKLASH_WIDTH, width);
    let (before, after) = (load_side_error(&config, &without), load_side_error(&config, &with));
    assert!(after < 0.3 * before, "backlash in the model: {after:e} rad against {before:e} rad without");
}

#[test]
fn drive_pieces_are_cut_at_the_stribeck_growth_time_when_it_is_shorter_than_the_decay() {
    let params = TruthConfig::default().plant.starting_parameters();
    let dt = 2e-3;
    let gear = params.value(names::GEAR_RATIO);
    let motor = params.value(names::MOTOR_INERTIA) * gear * gear;
    let decay = 2.0 / (params.value(names::DAMPING) * (1.0 / motor + 1.0 / params.value(names::LOAD_INERTIA)));
    // The steepest point of the Gaussian Stribeck excess, by finite differences.
    let excess = |v: f64| {
        (params.value(names::STATIC) - params.value(names::COULOMB))
            * (-(v / params.value(names::STRIBECK_VELOCITY)).powi(2)).exp()
    };
    let vs = params.value(names::STRIBECK_VELOCITY);
    let steepest =
        (1..2000).map(|k| k as f64 * 1e-3 * vs).map(|v| (excess(v) - excess(v + 1e-9)) / 1e-9).fold(0.0, f64::max);
    let growth = motor / steepest;
    assert!(growth < decay, "the suite's plant has a Stribeck range faster than its drive decay");
    let (length, reason) = drive_window(&params, dt).unwrap();
    assert_eq!(length, (growth / dt).round() as usize + 1, "{reason}");
    assert!(reason.contains("Stribeck"), "{reason}");
    let mut without_stribeck = params.clone();
    without_stribeck.set(names::STATIC, params.value(names::COULOMB));
    let (length, reason) = drive_window(&without_stribeck, dt).unwrap();
    assert_eq!(length, (decay / dt).round() as usize + 1, "{reason}");
    let mut rigid = params.clone();
    rigid.set(names::STIFFNESS, 0.0);
    assert!(drive_window(&rigid, dt).is_none());
}

#[test]
fn drive_pieces_tile_each_window_without_gaps_or_tiny_remainders() {
    for (length, piece) in [(400, 150), (400, 100), (400, 400), (37, 10), (400, 1000)] {
        let plan = WindowPlan::new(length, 10 * length, 2e-3, String::new()).with_drive_length(piece, String::new());
        let pieces = plan.drive_pieces();
        let mut next = 0;
        for &(offset, len) in &pieces {
            assert_eq!(offset, next, "window {length}, piece {piece}: {pieces:?}");
            assert!(3 * len + 3 >= 2 * plan.drive_length && 2 * len <= 3 * plan.drive_length + 2, "{pieces:?}");
            next += len;
        }
        assert_eq!(next, length, "{pieces:?}");
    }
}

#[test]
fn signed_rank_p_values_match_exact_small_cases() {
    // n = 3, all positive: only 1 of 8 sign patterns reaches the top rank sum.
    let (w, p) = signed_rank_test(&[1.0, 2.0, 3.0]);
    assert_eq!(w, 6.0);
    assert!((p - 0.125).abs() < 1e-12);
    // All negative: every pattern has W+ >= 0.
    assert!((signed_rank_test(&[-1.0, -2.0, -3.0]).1 - 1.0).abs() < 1e-12);
    // n = 4, ranks 1..4, only rank 4 positive: W+ = 4; the p-value is the share of the 16
    // sign patterns whose positive ranks sum to at least 4, counted directly.
    let (w, p) = signed_rank_test(&[-1.0, -2.0, -3.0, 4.0]);
    let mut count = 0;
    for mask in 0..16u32 {
        let s: u32 = (0..4).filter(|b| mask & (1 << b) != 0).map(|b| b + 1).sum();
        if s >= 4 {
            count += 1;
        }
    }
    assert_eq!(w, 4.0);
    assert!((p - count as f64 / 16.0).abs() < 1e-12);
}

#[test]
fn signed_rank_test_is_near_uniform_for_symmetric_noise() {
    use rand::SeedableRng;
    use rand_distr::Distribution;
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(9);
    let normal = rand_distr::Normal::new(0.0, 1.0).unwrap();
    let trials = 2000;
    let mut rejections = 0;
    for _ in 0..trials {
        let d: Vec<f64> = (0..25).map(|_| normal.sample(&mut rng)).collect();
        if signed_rank_test(&d).1 < 0.05 {
            rejections += 1;
        }
    }
    let rate = rejections as f64 / trials as f64;
    // The exact test holds its level (at or just below 5 % for a discrete statistic).
    assert!(rate < 0.06 && rate > 0.03, "false rejection rate {rate}");
}

/// The rigid stand-in whose simulated motor speed turns NaN from the second sample of the
/// window that starts at `bad_start` (s) on.
struct NanSpeedAfter {
    inner: RigidReferenceSimulator,
    bad_start: f64,
    window_time: f64,
}

impl PlantSimulator for NanSpeedAfter {
    fn configure(
        &mut self,
        params: &ParameterSet,
        config: &antenna_validate::parameters::FmuConfig,
    ) -> Result<(), SimulatorError> {
        self.inner.configure(params, config)
    }

    fn simulate(
        &mut self,
        start: &WindowStart,
        commands: &[[f64; 2]],
        disturbance: &[f64],
        dt: f64,
    ) -> Result<SimulatedOutputs, SimulatorError> {
        let mut outputs = self.inner.simulate(start, commands, disturbance, dt)?;
        if self.window_time >= self.bad_start {
            outputs.motor_vel[1] = f64::NAN;
        }
        self.window_time += dt * commands.len() as f64;
        Ok(outputs)
    }
}

#[test]
fn a_nan_in_a_simulated_window_is_an_error_naming_the_channel_and_window() {
    let config = TruthConfig { duration: 12.0, ..TruthConfig::default() };
    let log = simulate(&config).log;
    let mut start = config.plant.starting_parameters();
    // The rigid stand-in: no compliance, so the total-torque route.
    start.set(names::STIFFNESS, 0.0);
    let data = antenna_validate::equation_error::prepare(&log, &start, &Default::default()).unwrap();
    let out = OutputData::new(&log, &data, &start).unwrap();
    let plan = WindowPlan::new((1.0 / out.dt) as usize, out.len(), out.dt, "1 s".into());
    let mut simulator = NanSpeedAfter { inner: RigidReferenceSimulator::default(), bad_start: 3.0, window_time: 0.0 };
    let error = output_error(&mut simulator, &start, &data, &out, &plan).unwrap_err();
    let text = error.to_string();
    assert!(matches!(error, SimulationError::NonFinite(_)), "{error:?}");
    assert!(text.starts_with("the output error of the motor speed is NaN in the window at"), "{text}");
}

#[test]
fn a_nan_from_the_simulator_on_the_starting_model_is_an_error_not_a_fallback_to_the_equation_error() {
    use antenna_validate::{validate_with, ValidateOptions, ValidationError};
    let config = TruthConfig { duration: 12.0, ..TruthConfig::default() };
    let log = simulate(&config).log;
    let mut start = config.plant.starting_parameters();
    start.set(names::STIFFNESS, 0.0);
    let mut simulator = NanSpeedAfter { inner: RigidReferenceSimulator::default(), bad_start: 0.0, window_time: 0.0 };
    let error = validate_with(&log, &start, &ValidateOptions::default(), Some(&mut simulator)).unwrap_err();
    assert!(matches!(error, ValidationError::Simulation(SimulationError::NonFinite(_))), "{error:?}");
    assert!(error.to_string().contains("is NaN in the window at"), "{error}");
}
