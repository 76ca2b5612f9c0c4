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
use antenna_validate::output_error::{self, choose_window, OutputData, RigidReferenceSimulator, WindowPlan};
use antenna_validate::parameters::{names, ParameterSet};
use antenna_validate::selection::{self, Judge};
use antenna_validate::{validate_with, ValidateOptions, Validation};

mod common;

use common::{log_csv, COULOMB, FREQUENCIES, VISCOUS};

/// The shared truth with a torque offset (N m).
fn truth(offset: f64) -> ParameterSet {
    let mut p = common::truth();
    p.set(names::TORQUE_OFFSET, offset);
    p
}

fn kinds(v: &Validation) -> Vec<Kind> {
    v.selection.found.iter().map(|f| f.kind).collect()
}

#[test]
fn an_offset_really_in_the_log_is_kept_when_the_start_s_friction_is_re_estimated() {
    let log = parse_str(&log_csv(&truth(50.0), FREQUENCIES)).unwrap();
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
