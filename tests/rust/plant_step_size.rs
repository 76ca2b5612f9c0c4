//! How much the packaged plant FMUs depend on the communication step with all their nonlinear
//! effects on (friction with sticking, backlash, current saturation, quantised encoders, the
//! elevation's angle-dependent geometry): the same inputs, changing every millisecond, are fed
//! with 1 ms and with 0.1 ms communication steps and the outputs are compared at every
//! millisecond. The figures are printed for docs/plant-fmu-tests.md; the bounds are those
//! docs/plant-model.md (section 8.4) states for the plant.
//!
//! Two further azimuth scenarios, a 3 A sine with 0.5 A noise, separate what the numerics
//! cause from what the physics does: without torque bias the backlash chattering is
//! ill-conditioned (1e-9 A more on one motor moves the axis by arcseconds, and finer numerics
//! do not converge), so its step-size dependence is a symptom of that sensitivity; with a bias
//! the sine overpowers, the motion converges as the numerics are refined, and the remaining
//! dependence is that of the default event check interval and resolution.
//!
//! Run with `cargo test --release -p antenna-tests --test integration -- plant_step_size:: --nocapture`.

use antenna_tests::{error_relative_to_range, open, reals, set_reals, test_signal};
use fmu_import::{Fmu, Instance};

/// Bounds of docs/plant-model.md, section 8.4, for currents and torques as a fraction of their
/// range.
const CURRENT_BOUND: f64 = 2e-3;
const TORQUE_BOUND: f64 = 5e-3;

/// An input's value at a millisecond index.
type Signal = Box<dyn Fn(usize) -> f64>;

struct Scenario {
    identifier: &'static str,
    inputs: Vec<(&'static str, Signal)>,
    position: &'static str,
    speeds: Vec<&'static str>,
    currents: Vec<&'static str>,
    torques: Vec<&'static str>,
    milliseconds: usize,
}

fn square(ms: usize, half_period_ms: usize) -> f64 {
    if (ms / half_period_ms) & 1 == 0 {
        1.0
    } else {
        -1.0
    }
}

fn azimuth() -> Scenario {
    // Torque-biased drives (motor 1 +1 A, motor 2 -1 A) with a common sine that reverses the
    // axis every second, a little noise, a 3 kN m disturbance that flips every 2.5 s, and an
    // elevation input that sweeps through parameter-grid cells.
    let common =
        |ms: usize| 1.5 * (std::f64::consts::TAU * 0.5 * ms as f64 * 1e-3).sin() + 0.2 * test_signal(ms as u64, 11);
    Scenario {
        identifier: "AzimuthPlant",
        inputs: vec![
            ("motor1.current_command", Box::new(move |ms| common(ms) + 1.0)),
            ("motor2.current_command", Box::new(move |ms| common(ms) - 1.0)),
            ("load.disturbance_torque", Box::new(|ms| 3e3 * square(ms, 2500))),
            ("elevation", Box::new(|ms| 45.0 + 10.0 * (std::f64::consts::TAU * 0.05 * ms as f64 * 1e-3).sin())),
        ],
        position: "axis.position",
        speeds: vec!["motor1.speed", "motor2.speed"],
        currents: vec!["motor1.current", "motor2.current"],
        torques: vec!["pinion1.torque", "pinion2.torque"],
        milliseconds: 10_000,
    }
}

fn elevation() -> Scenario {
    // A sine that reverses the dish every second on top of an offset that makes it creep up
    // through the angle-dependent geometry, a little noise, and a 2 kN m disturbance.
    Scenario {
        identifier: "ElevationPlant",
        inputs: vec![
            (
                "motor.current_command",
                Box::new(|ms| {
                    0.15 + 1.5 * (std::f64::consts::TAU * 0.5 * ms as f64 * 1e-3).sin()
                        + 0.1 * test_signal(ms as u64, 12)
                }),
            ),
            ("load.disturbance_torque", Box::new(|ms| 2e3 * square(ms, 2500))),
        ],
        position: "axis.position",
        speeds: vec!["motor.speed"],
        currents: vec!["motor.current"],
        torques: vec!["drive.torque"],
        milliseconds: 10_000,
    }
}

struct Record {
    /// Per millisecond: position (deg), speeds, currents, torques, in the scenario's order.
    samples: Vec<Vec<f64>>,
    /// Motor-speed reversals seen at the millisecond samples.
    reversals: usize,
    /// Model events the FMU logged under logEvents (pinion flank changes in azimuth).
    logged_events: usize,
}

fn run(fmu: &Fmu, scenario: &Scenario, substeps: usize, event_resolution_s: f64) -> Record {
    run_with(fmu, scenario, substeps, event_resolution_s, DEFAULT_EVENT_CHECK_INTERVAL)
}

/// The plants' default `numerics.event_check_interval`, s.
const DEFAULT_EVENT_CHECK_INTERVAL: f64 = 1e-3;

/// A run with `substeps` communication steps per millisecond and the given event resolution
/// and event check interval.
fn run_with(
    fmu: &Fmu,
    scenario: &Scenario,
    substeps: usize,
    event_resolution_s: f64,
    event_check_interval_s: f64,
) -> Record {
    let mut instance: Instance = fmu.instantiate("step-size", false).unwrap();
    instance.set_debug_logging(true, &["logEvents"]).unwrap();
    let numerics = fmu.description.vrs(&["numerics.event_time_resolution", "numerics.event_check_interval"]).unwrap();
    instance.initialize(0.0, &[(numerics[0], event_resolution_s), (numerics[1], event_check_interval_s)]).unwrap();
    let names: Vec<&str> = std::iter::once(scenario.position)
        .chain(scenario.speeds.iter().copied())
        .chain(scenario.currents.iter().copied())
        .chain(scenario.torques.iter().copied())
        .collect();
    let h = 1e-3 / substeps as f64;
    let mut t = 0.0;
    let mut samples: Vec<Vec<f64>> = Vec::with_capacity(scenario.milliseconds);
    let mut reversals = 0;
    let mut last_sign = vec![0.0f64; scenario.speeds.len()];
    for ms in 0..scenario.milliseconds {
        let values: Vec<(&str, f64)> = scenario.inputs.iter().map(|(name, f)| (*name, f(ms))).collect();
        set_reals(fmu, &mut instance, &values);
        for _ in 0..substeps {
            instance.do_step(t, h).unwrap();
            t += h;
        }
        let v = reals(fmu, &mut instance, &names).unwrap();
        // A reversal usually passes through a spell of sticking (speed exactly 0), so the sign
        // is compared with the last non-zero one.
        for (k, sign) in last_sign.iter_mut().enumerate() {
            let speed = v[1 + k];
            if speed != 0.0 {
                if *sign != 0.0 && speed.signum() != *sign {
                    reversals += 1;
                }
                *sign = speed.signum();
            }
        }
        samples.push(v);
    }
    let logged_events = instance.log_records().iter().filter(|r| r.category == "logEvents").count();
    Record { samples, reversals, logged_events }
}

/// The differences between a 1 ms and a 0.1 ms run of a scenario.
struct Dependence {
    position_arcsec: f64,
    position_fraction: f64,
    position_range_deg: f64,
    speed: f64,
    current: f64,
    torque: f64,
    reversals: (usize, usize),
    logged_events: (usize, usize),
}

fn dependence(fmu: &Fmu, scenario: &Scenario, event_resolution_s: f64) -> Dependence {
    let coarse = run(fmu, scenario, 1, event_resolution_s);
    let fine = run(fmu, scenario, 10, event_resolution_s);
    let column = |r: &Record, k: usize| -> Vec<f64> { r.samples.iter().map(|s| s[k]).collect() };
    let group = |first: usize, count: usize| {
        (first..first + count)
            .map(|k| error_relative_to_range(&column(&coarse, k), &column(&fine, k)))
            .fold(0.0, f64::max)
    };
    let (position_coarse, position_fine) = (column(&coarse, 0), column(&fine, 0));
    let n_speeds = scenario.speeds.len();
    let n_currents = scenario.currents.len();
    Dependence {
        position_arcsec: position_coarse
            .iter()
            .zip(&position_fine)
            .map(|(a, b)| (a - b).abs() * 3600.0)
            .fold(0.0, f64::max),
        position_fraction: error_relative_to_range(&position_coarse, &position_fine),
        position_range_deg: position_fine.iter().copied().fold(f64::NEG_INFINITY, f64::max)
            - position_fine.iter().copied().fold(f64::INFINITY, f64::min),
        speed: group(1, n_speeds),
        current: group(1 + n_speeds, n_currents),
        torque: group(1 + n_speeds + n_currents, scenario.torques.len()),
        reversals: (coarse.reversals, fine.reversals),
        logged_events: (coarse.logged_events, fine.logged_events),
    }
}

/// A quarter of a count of the plants' 25-bit encoders, arcsec: a step-size dependence below
/// it cannot show in any measured position.
const QUARTER_ENCODER_COUNT_ARCSEC: f64 = 0.25 * 1_296_000.0 / (1u64 << 25) as f64;

#[test]
fn nonlinear_fmu_results_depend_on_the_communication_step_by_less_than_a_quarter_encoder_count() {
    for scenario in [azimuth(), elevation()] {
        let fmu = open(scenario.identifier);
        let started = std::time::Instant::now();
        let d = dependence(&fmu, &scenario, 1e-6);
        let wall = started.elapsed().as_secs_f64();
        // The same with the events localised 100 times more finely, to show where the
        // dependence comes from (event timing, or something that does not shrink with it).
        let finer = dependence(&fmu, &scenario, 1e-8);
        println!(
            "{}.fmu, nonlinear, 1 ms vs 0.1 ms steps over {} s: position {:.2e} arcsec ({:.1e} of its {:.3} deg range), motor speed {:.1e}, current {:.1e}, torque {:.1e} of range; motor-speed reversals {:?}, logged events {:?}; with 1e-8 s event resolution: position {:.2e} arcsec, torque {:.1e}; wall {:.2} s",
            scenario.identifier,
            scenario.milliseconds as f64 * 1e-3,
            d.position_arcsec,
            d.position_fraction,
            d.position_range_deg,
            d.speed,
            d.current,
            d.torque,
            d.reversals,
            d.logged_events,
            finer.position_arcsec,
            finer.torque,
            wall
        );
        // The scenario must exercise the nonlinear effects, or the comparison says nothing.
        assert!(
            d.reversals.0 >= 8,
            "{}: only {} reversals: the scenario does not exercise friction",
            scenario.identifier,
            d.reversals.0
        );
        assert_eq!(
            d.reversals.0, d.reversals.1,
            "{}: the 1 ms and 0.1 ms runs reverse a different number of times",
            scenario.identifier
        );
        assert!(
            d.position_arcsec < QUARTER_ENCODER_COUNT_ARCSEC,
            "{}: position differs by {:e} arcsec, more than a quarter encoder count ({QUARTER_ENCODER_COUNT_ARCSEC:e} arcsec)",
            scenario.identifier,
            d.position_arcsec
        );
        assert!(
            d.current < CURRENT_BOUND,
            "{}: currents differ by {:e} of their range",
            scenario.identifier,
            d.current
        );
        assert!(d.torque < TORQUE_BOUND, "{}: torques differ by {:e} of their range", scenario.identifier, d.torque);
    }
}

/// The audit's open-loop azimuth scenario: defaults, both motors given the same (unbiased) or
/// a +/-1 A biased command, a 1 Hz sine of 3 A plus 0.5 A of noise that changes every
/// millisecond, no disturbance, 2 s. `delta` is added to motor 1's command, to measure how
/// sensitive the motion is to the input.
fn chattering(bias_a: f64, delta_a: f64, seed: u64) -> Scenario {
    let common =
        move |ms: usize| 3.0 * (std::f64::consts::TAU * ms as f64 * 1e-3).sin() + 0.5 * test_signal(ms as u64, seed);
    Scenario {
        identifier: "AzimuthPlant",
        inputs: vec![
            ("motor1.current_command", Box::new(move |ms| common(ms) + bias_a + delta_a)),
            ("motor2.current_command", Box::new(move |ms| common(ms) - bias_a)),
            ("load.disturbance_torque", Box::new(|_| 0.0)),
            ("elevation", Box::new(|_| 45.0)),
        ],
        position: "axis.position",
        speeds: vec!["motor1.speed", "motor2.speed"],
        currents: vec!["motor1.current", "motor2.current"],
        torques: vec!["pinion1.torque", "pinion2.torque"],
        milliseconds: 2000,
    }
}

/// Largest position difference (arcsec) and largest pinion-torque difference (fraction of the
/// reference's range) between two records of [`chattering`].
fn difference(record: &Record, reference: &Record) -> (f64, f64) {
    let column = |r: &Record, k: usize| -> Vec<f64> { r.samples.iter().map(|s| s[k]).collect() };
    let position =
        column(record, 0).iter().zip(column(reference, 0)).map(|(a, b)| (a - b).abs() * 3600.0).fold(0.0, f64::max);
    let torque = [5, 6].map(|k| error_relative_to_range(&column(record, k), &column(reference, k)));
    (position, torque[0].max(torque[1]))
}

/// The four runs each chattering statement rests on: default numerics at 1 ms; the reference
/// (0.1 ms pieces, events to 1e-8 s); a finer one (10 us pieces, 1e-9 s); the reference with
/// 1e-9 A more on motor 1.
struct Chattering {
    default_1ms: (f64, f64),
    finer: (f64, f64),
    perturbed: (f64, f64),
}

fn chattering_runs(fmu: &Fmu, bias_a: f64, seed: u64) -> Chattering {
    let reference = run_with(fmu, &chattering(bias_a, 0.0, seed), 10, 1e-8, 1e-4);
    let default_1ms = run(fmu, &chattering(bias_a, 0.0, seed), 1, 1e-6);
    let finer = run_with(fmu, &chattering(bias_a, 0.0, seed), 100, 1e-9, 1e-5);
    let perturbed = run_with(fmu, &chattering(bias_a, 1e-9, seed), 10, 1e-8, 1e-4);
    // The communication step itself does not matter: 1 ms steps cut into the same 0.1 ms
    // pieces as the reference give exactly the reference.
    let same_pieces = run_with(fmu, &chattering(bias_a, 0.0, seed), 1, 1e-8, 1e-4);
    assert!(
        same_pieces.samples == reference.samples,
        "bias {bias_a}, seed {seed}: 1 ms steps in 0.1 ms pieces differ from 0.1 ms steps"
    );
    Chattering {
        default_1ms: difference(&default_1ms, &reference),
        finer: difference(&finer, &reference),
        perturbed: difference(&perturbed, &reference),
    }
}

#[test]
fn unbiased_backlash_chattering_is_so_sensitive_that_its_step_size_dependence_does_not_shrink() {
    // Without torque bias both pinions cross the backlash at every reversal together, and the
    // lightly damped contact (damping ratio 0.04) makes the motion depend on the input to
    // rounding level: the differences below are those of an ill-conditioned problem, not a
    // discretisation error that finer numerics would remove (docs/plant-model.md 8.4).
    let fmu = open("AzimuthPlant");
    for seed in [21, 25] {
        let c = chattering_runs(&fmu, 0.0, seed);
        println!(
            "AzimuthPlant unbiased chattering, seed {seed}, against 0.1 ms pieces with 1e-8 s events: default 1 ms {:.2} arcsec, {:.2} of pinion-torque range; 10 us pieces with 1e-9 s events {:.2} arcsec, {:.2}; 1e-9 A more on motor 1 {:.2} arcsec, {:.2}",
            c.default_1ms.0, c.default_1ms.1, c.finer.0, c.finer.1, c.perturbed.0, c.perturbed.1
        );
        // Measured over six noise seeds: 1.4-3.6 arcsec and 0.24-0.51 (the audit, with its
        // own noise, 6.0 arcsec and 0.52-0.59). The bound is the documented statement.
        assert!(c.default_1ms.0 < 10.0 && c.default_1ms.1 < 0.8, "seed {seed}: {:?}", c.default_1ms);
        // Ill-conditioned: a 1e-9 A change of one input moves the axis by arcseconds
        // (measured 3-10), and refining the numerics tenfold does not converge (2.0-3.4).
        assert!(
            c.perturbed.0 > 0.5,
            "seed {seed}: 1e-9 A moved the axis by only {:?}: the chattering is no longer ill-conditioned",
            c.perturbed
        );
        assert!(c.finer.0 > 0.3, "seed {seed}: the finer numerics agree with the reference to {:?}: the chattering is no longer ill-conditioned", c.finer);
    }
}

#[test]
fn an_overpowered_bias_converges_with_finer_numerics_but_the_default_ones_miss_short_stick_slip() {
    // The same signal on a +/-1 A torque bias: the 3 A sine overpowers the bias, so the pinions
    // still cross the backlash, but one after the other. This motion is well-conditioned and
    // converges; the default numerics (events checked every 1 ms, located to 1 us) miss motor
    // stick-slip that comes and goes within a millisecond and mistime impacts.
    let fmu = open("AzimuthPlant");
    for seed in [24, 26] {
        let c = chattering_runs(&fmu, 1.0, seed);
        println!(
            "AzimuthPlant bias overpowered, seed {seed}, against 0.1 ms pieces with 1e-8 s events: default 1 ms {:.2} arcsec, {:.2} of pinion-torque range; 10 us pieces with 1e-9 s events {:.1e} arcsec, {:.1e}; 1e-9 A more on motor 1 {:.1e} arcsec, {:.1e}",
            c.default_1ms.0, c.default_1ms.1, c.finer.0, c.finer.1, c.perturbed.0, c.perturbed.1
        );
        // Measured over six seeds: 0.012-6.1 arcsec, up to 0.74 of the torque range.
        assert!(c.default_1ms.0 < 10.0 && c.default_1ms.1 < 0.9, "seed {seed}: {:?}", c.default_1ms);
        // Converges: measured 0.004-0.016 arcsec and at most 0.022 of the torque range.
        assert!(c.finer.0 < 0.05 && c.finer.1 < 0.05, "seed {seed}: finer numerics differ by {:?}", c.finer);
        // Well-conditioned: measured at most 1.0e-3 arcsec.
        assert!(c.perturbed.0 < 0.01, "seed {seed}: 1e-9 A moved the axis by {:?}", c.perturbed);
    }
}
