//! The effect search on logs of the second, separately written generator (`second.rs`: LuGre
//! bristles, a second-order current loop, a multisine-excited cascade of its own): the search
//! must not be shaped by the first generator's choices. Equation error only, 30 s logs.

use antenna_truth::second::{generate, start_params, SecondEffect, SecondOptions};
use antenna_validate::candidates::Kind;
use antenna_validate::equation_error::{prepare, EquationOptions};
use antenna_validate::measured_log::parse_str;
use antenna_validate::parameters::{names, ParameterSet};
use antenna_validate::selection::{select, Selection, SelectionOptions};

fn search(effect: SecondEffect, seed: u64) -> Selection {
    let options = SecondOptions { effect, seed, duration: 30.0, ..SecondOptions::default() };
    let log = parse_str(&generate(&options)).unwrap();
    let start = ParameterSet::parse(&start_params()).unwrap();
    let data = prepare(&log, &start, &EquationOptions::default()).unwrap();
    select(&data, &start, &SelectionOptions::default())
}

fn kinds(selection: &Selection) -> Vec<Kind> {
    selection.found.iter().map(|f| f.kind).collect()
}

#[test]
fn a_clean_log_of_the_second_generator_gets_no_claim() {
    let selection = search(SecondEffect::Clean, 3);
    assert!(selection.found.is_empty(), "claimed {:?}", kinds(&selection));
}

#[test]
fn the_second_generators_coulomb_change_is_named_within_ten_percent() {
    let selection = search(SecondEffect::Coulomb, 4);
    assert_eq!(kinds(&selection), vec![Kind::Coulomb]);
    let coulomb = selection.corrected.value(names::COULOMB);
    assert!((coulomb - 3300.0).abs() < 30.0, "Coulomb {coulomb} against 3300 N m (a change of 300)");
}

#[test]
fn the_second_generators_load_inertia_change_is_named_within_ten_percent() {
    let selection = search(SecondEffect::Inertia, 5);
    assert_eq!(kinds(&selection), vec![Kind::Inertia]);
    let inertia = selection.corrected.value(names::LOAD_INERTIA);
    assert!((inertia / 8.7e4 - 1.0).abs() < 0.1, "load inertia {inertia} against 8.7e4 kg m^2");
}
