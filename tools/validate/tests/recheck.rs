//! The re-check after a re-estimation (`selection::recheck`, run by `validate_with` when the
//! re-estimation of a family the start holds changed the model): every effect the search found
//! before is taken out in turn with the re-estimated value in place, the others refitted, and
//! confirmed again on the output error; what no longer confirms is withdrawn.
//!
//! On a synthetic rigid axis simulated by the crate's own rigid stand-in for the plant FMU, as
//! `tests/reestimate.rs`: the truth's friction is Coulomb 60 N m and viscous 80 N m s/rad, the
//! log is torque and motor encoder with white noise, and the axis carries a slow unlogged
//! disturbance torque that colours the equation error's residual, so that a change of a family
//! the start holds can be inside the equation error's uncertainty.
//!
//! - An effect that is really in the log survives: a torque offset of 50 N m, found by the
//!   search while the start's Coulomb guess (42 N m) is still in the model; after the guess is
//!   re-estimated (to 57 N m) the model with the offset has 0.123 of the output error of the
//!   model without it (better in 73 of 76 windows), and it is kept.
//! - An effect that stood in for the start's wrong value is withdrawn: from a start whose
//!   viscous coefficient is 66 instead of 80 N m s/rad, on a motion whose frequent reversals
//!   make the Coulomb column the better-tested one, the search names a Coulomb change (+16 N m,
//!   the truth's Coulomb is the start's) while the viscous change itself is not significant in
//!   the equation error. With the viscous coefficient at the value the data hold (the truth's:
//!   what a re-estimation that establishes it sets), the re-check withdraws the Coulomb change
//!   (the model with it has 1.88 times the output error of the model without it, better in 28
//!   of 74 windows).
//!   On this log the re-estimation itself does not establish the viscous change (the output
//!   error with it is 0.91 of the stand-in model's, p = 0.17 against its level 5e-3), so the
//!   state after a re-estimation is set up here by hand and `selection::recheck` asked
//!   directly, with the output error of the same rigid stand-in as its judge; a search of about
//!   450 drive, motion and start variants of this generator found no log on which the search
//!   names a stand-in and the re-estimation then establishes the true value.

use antenna_validate::candidates::{parameter_count, Kind};
use antenna_validate::equation_error::EquationData;
use antenna_validate::measured_log::parse_str;
use antenna_validate::output_error::{
    self, choose_window, OutputData, PlantSimulator, RigidReferenceSimulator, WindowPlan, WindowStart,
};
use antenna_validate::parameters::{names, FmuConfig, FmuDrive, FmuInput, ParameterSet};
use antenna_validate::selection::{self, Judge};
use antenna_validate::{validate_with, ValidateOptions, Validation};
use rand::SeedableRng;
use rand_distr::{Distribution, Normal};

const DT: f64 = 0.004;
const GEAR: f64 = 100.0;
const SAMPLES: usize = 3750;
/// The truth's friction, axis side: Coulomb (N m) and viscous (N m s/rad).
const COULOMB: f64 = 60.0;
const VISCOUS: f64 = 80.0;
/// Torque sensor noise (axis side, N m) and motor encoder noise (rad).
const TORQUE_NOISE: f64 = 2.0;
const POSITION_NOISE: f64 = 1e-6;
/// Amplitude (N m) of the slowest of the three sines of the unlogged disturbance torque.
const DISTURBANCE: f64 = 20.0;

fn truth(offset: f64) -> ParameterSet {
    let mut p = ParameterSet::new();
    p.set(names::GEAR_RATIO, GEAR);
    p.set(names::MOTOR_INERTIA, 2e-3);
    p.set(names::TORQUE_CONSTANT, 1.0);
    p.set(names::LOAD_INERTIA, 30.0);
    p.set(names::COULOMB, COULOMB);
    p.set(names::STATIC, COULOMB);
    p.set(names::VISCOUS, VISCOUS);
    p.set(names::TORQUE_OFFSET, offset);
    p
}

/// A 15 s log of `truth` driven by an axis torque of three sines of the given frequencies (Hz;
/// amplitudes 300, 150 and 80 N m), motor torque and motor encoder only.
fn log_csv(truth: &ParameterSet, frequencies: [f64; 3]) -> String {
    use std::f64::consts::TAU;
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
    let config = FmuConfig { drive: FmuDrive::Mirrored, input: FmuInput::Torque, sample_interval: DT };
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

fn kinds(v: &Validation) -> Vec<Kind> {
    v.selection.found.iter().map(|f| f.kind).collect()
}

#[test]
fn an_offset_really_in_the_log_is_kept_when_the_start_s_friction_is_re_estimated() {
    let log = parse_str(&log_csv(&truth(50.0), [0.31, 1.13, 2.71])).unwrap();
    let mut start = truth(0.0);
    start.set(names::COULOMB, 42.0);
    start.set(names::STATIC, 42.0);
    let mut simulator = RigidReferenceSimulator::default();
    let v = validate_with(&log, &start, &ValidateOptions::default(), Some(&mut simulator)).unwrap();
    // The search found the offset; the re-estimation then changed the start's Coulomb guess.
    assert!(v.selection.steps.iter().any(|s| !s.re_estimate && s.chosen == Some(Kind::Offset)));
    assert!(v.selection.steps.iter().any(|s| s.re_estimate && s.chosen == Some(Kind::Coulomb)));
    let output = v.output.as_ref().unwrap();
    let recheck = output.recheck.as_ref().expect("the offset was re-checked after the re-estimation");
    assert!(recheck.withdrawn.is_empty(), "withdrawn {:?}", recheck.withdrawn);
    assert_eq!(recheck.kept.iter().map(|k| k.0).collect::<Vec<_>>(), vec![Kind::Offset]);
    assert!(kinds(&v).contains(&Kind::Offset), "found {:?}", kinds(&v));
    let offset = v.selection.corrected.value(names::TORQUE_OFFSET);
    assert!((offset / 50.0 - 1.0).abs() < 0.1, "offset {offset} against the truth's 50");
    assert!(output.overall.confirmed, "{}", output.overall.reason);
}

/// The output error of the rigid stand-in as the judge, as `validate_with` judges effects:
/// signed-rank test and BIC gain of the model with the effect against the model without it.
struct Simulated<'a> {
    simulator: RigidReferenceSimulator,
    data: &'a EquationData,
    out: &'a OutputData,
    plan: &'a WindowPlan,
}

impl Judge for Simulated<'_> {
    fn confirm(&mut self, kind: Kind, without: &ParameterSet, with: &ParameterSet) -> Result<String, String> {
        let mut error = |p: &ParameterSet| {
            output_error::output_error(&mut self.simulator, p, self.data, self.out, self.plan)
                .map_err(|e| e.to_string())
        };
        let (before, after) = (error(without)?, error(with)?);
        let comparison = output_error::compare(&before, &after, parameter_count(kind, self.data.structure), 0.01);
        if comparison.confirmed {
            Ok(comparison.reason)
        } else {
            Err(comparison.reason)
        }
    }

    fn compares(&self) -> bool {
        true
    }
}

#[test]
fn an_effect_that_stood_in_for_the_start_s_wrong_value_is_withdrawn_once_the_value_is_re_estimated() {
    let log = parse_str(&log_csv(&truth(0.0), [0.31, 1.9, 3.3])).unwrap();
    let mut start = truth(0.0);
    start.set(names::VISCOUS, 66.0);
    let mut options = ValidateOptions::default();
    options.output.reestimate = false;
    options.output.presliding = false;
    let mut simulator = RigidReferenceSimulator::default();
    let v = validate_with(&log, &start, &options, Some(&mut simulator)).unwrap();
    // The search names a Coulomb change for the viscous coefficient's error, and the viscous
    // change itself is not significant in the equation error.
    assert_eq!(kinds(&v), vec![Kind::Coulomb], "found {:?}", v.selection.found);
    let first = &v.selection.steps[0];
    let viscous = first.scores.iter().find(|s| s.kind == Kind::Viscous).unwrap();
    assert!(!viscous.significant, "the viscous change was significant: p {:.2e}", viscous.p_value);
    let stand_in = v.selection.corrected.value(names::COULOMB) - COULOMB;
    assert!(stand_in > 5.0, "Coulomb change {stand_in} N m");

    // The model after a re-estimation of the start's viscous coefficient to the data's value.
    let mut selection = v.selection.clone();
    let mut corrected = selection.corrected.clone();
    corrected.set(names::VISCOUS, VISCOUS);
    let accepted = [Kind::Coulomb, Kind::Viscous];
    let weights = selection.after.channel_weights();
    let (after, found) = selection::final_fit(&v.data, &start, &corrected, &accepted, &weights);
    (selection.after, selection.found, selection.corrected) = (after, found, corrected);

    let out = OutputData::new(&log, &v.data, &start).unwrap();
    let plan = choose_window(&out, 0.9, 20);
    let mut judge = Simulated { simulator: RigidReferenceSimulator::default(), data: &v.data, out: &out, plan: &plan };
    let rechecked =
        selection::recheck(&v.data, &start, &mut selection, &[Kind::Coulomb], &options.selection, &mut judge);
    assert_eq!(rechecked.withdrawn.iter().map(|w| w.0).collect::<Vec<_>>(), vec![Kind::Coulomb]);
    assert!(rechecked.kept.is_empty(), "kept {:?}", rechecked.kept);
    // The re-estimated family stays, and the Coulomb level is the start's again.
    assert_eq!(selection.found.iter().map(|f| f.kind).collect::<Vec<_>>(), vec![Kind::Viscous]);
    let coulomb = selection.corrected.value(names::COULOMB);
    assert!((coulomb - COULOMB).abs() < 1e-9, "Coulomb {coulomb}");
    assert!(selection.removed.iter().any(|(k, _)| *k == Kind::Coulomb));
}
