//! A start without friction (a "blind" start, as from a catalogue's inertia alone) on the
//! synthetic rigid axis of `common`, whose truth holds Coulomb and viscous friction and no
//! Stribeck hump. The Stribeck hump is the breakaway level's rise over the sliding level, so
//! the search may not offer it before a Coulomb level is in the model: from such a start a
//! hump over nothing would stand in for the Coulomb friction (the linear drive named
//! "Stribeck friction with zero Coulomb").

use antenna_validate::candidates::Kind;
use antenna_validate::measured_log::parse_str;
use antenna_validate::output_error::RigidReferenceSimulator;
use antenna_validate::parameters::names;
use antenna_validate::{validate_with, ValidateOptions};

mod common;

#[test]
fn a_start_without_friction_gets_coulomb_friction_and_no_hump_over_nothing() {
    let truth = common::truth();
    let mut start = truth.clone();
    for name in [names::COULOMB, names::STATIC, names::VISCOUS] {
        start.set(name, 0.0);
    }
    let log = parse_str(&common::log_csv(&truth, common::FREQUENCIES)).unwrap();
    let mut simulator = RigidReferenceSimulator::default();
    let v = validate_with(&log, &start, &ValidateOptions::default(), Some(&mut simulator)).unwrap();
    let found: Vec<Kind> = v.selection.found.iter().map(|f| f.kind).collect();
    assert!(found.contains(&Kind::Coulomb), "found {found:?}");
    assert!(!found.contains(&Kind::Stribeck), "found {found:?}");
    let coulomb = v.selection.corrected.value(names::COULOMB);
    assert!((coulomb / common::COULOMB - 1.0).abs() < 0.3, "Coulomb {coulomb} against {}", common::COULOMB);
    // The first step, with no Coulomb level in the model, does not offer the hump.
    let first = &v.selection.steps[0];
    let stribeck = first.scores.iter().find(|s| s.kind == Kind::Stribeck).expect("a Stribeck score in step 1");
    assert!(
        stribeck.not_applicable.as_deref().is_some_and(|r| r.contains("Coulomb first")),
        "step 1's Stribeck: {:?}",
        stribeck.not_applicable
    );
}
