//! The detection limits a validation reports for what it did not find
//! (`antenna_validate::selection::DetectionLimit`), checked against the search itself on the
//! synthetic rigid axis the re-estimation tests share: the limit read off the clean log must
//! separate the effects the same log would show from those it cannot.
//!
//! The limit is first order and the search draws its own noise, so the test stays clear of the
//! boundary by a factor of three on each side: an offset three times the clean log's limit
//! must be named, one a third of it must not.

use antenna_validate::candidates::Kind;
use antenna_validate::measured_log::parse_str;
use antenna_validate::output_error::RigidReferenceSimulator;
use antenna_validate::parameters::{names, ParameterSet};
use antenna_validate::selection::{DetectionLimit, LimitSetBy};
use antenna_validate::{validate_with, ValidateOptions, Validation};

mod common;

use common::FREQUENCIES;

fn validate(truth: &ParameterSet, start: &ParameterSet) -> Validation {
    let log = parse_str(&common::log_csv(truth, FREQUENCIES)).unwrap();
    let mut simulator = RigidReferenceSimulator::default();
    validate_with(&log, start, &ValidateOptions::default(), Some(&mut simulator)).unwrap()
}

fn limit(v: &Validation, kind: Kind) -> DetectionLimit {
    let limits = v.selection.detection_limits();
    limits.iter().find(|(k, _)| *k == kind).map(|(_, l)| l.clone()).unwrap_or_else(|| {
        panic!("no detection limit for {} (limits {limits:?}, found {:?})", kind.name(), v.selection.found)
    })
}

fn with_offset(offset: f64) -> ParameterSet {
    let mut truth = common::truth();
    truth.set(names::TORQUE_OFFSET, offset);
    truth
}

#[test]
fn the_offset_limit_of_a_clean_log_separates_the_offsets_the_search_names_from_those_it_cannot() {
    let start = common::truth();
    let clean = validate(&start, &start);
    assert!(clean.selection.found.is_empty(), "a claim on the clean log: {:?}", clean.selection.found);
    let offset = limit(&clean, Kind::Offset);
    println!("offset limit on the clean log: {offset:?}");
    assert_eq!((offset.parameter, offset.unit), (names::TORQUE_OFFSET, "N m"));
    // The slow unlogged disturbance colours the residual: the test, not the noise floor, sets it,
    // at some newton metres (the torque noise is 2 N m, the disturbance 20 N m).
    assert_eq!(offset.set_by, LimitSetBy::Significance);
    assert!(offset.size > 1.0 && offset.size < 100.0, "limit {} N m", offset.size);
    assert!(offset.effect_to_noise >= 1.0);

    let named = |v: &Validation| v.selection.found.iter().any(|f| f.kind == Kind::Offset);
    let above = validate(&with_offset(3.0 * offset.size), &start);
    assert!(
        named(&above),
        "an offset of 3 x the limit ({:.2} N m) was not named: {:?}",
        3.0 * offset.size,
        above.selection.found
    );
    let found = above.selection.corrected.value(names::TORQUE_OFFSET);
    assert!((found / (3.0 * offset.size) - 1.0).abs() < 0.3, "offset {found} against {}", 3.0 * offset.size);
    let below = validate(&with_offset(offset.size / 3.0), &start);
    assert!(!named(&below), "an offset of a third of the limit ({:.2} N m) was named", offset.size / 3.0);
    // The limit does not depend on what the log holds below it: the sub-limit log reports
    // nearly the same one (the candidate's standard error, not its estimate, sets it).
    let again = limit(&below, Kind::Offset);
    assert!((again.size / offset.size - 1.0).abs() < 0.2, "limit {} against {}", again.size, offset.size);
}
