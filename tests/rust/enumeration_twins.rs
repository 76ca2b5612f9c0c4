//! Masters that ignore FMI 2.0 enumerations (libcosim and ecos skip them with a warning) must not
//! silently change the antenna: every enumeration a master may set has an Integer twin,
//! `<name>_number`, and setting the twin to an item's number runs the unit exactly as setting the
//! enumeration to that item does.

use antenna_tests::{output_bits, packaged_fmus};
use fmu_import::{Fmu, ImportError};

/// The unit with `name` set to `value` before initialisation, stepped 0.2 s at 1 ms from its
/// default inputs: every output's bits at the end, or the error that stopped it.
fn outputs_with(fmu: &Fmu, name: &str, value: i32) -> Result<Vec<u64>, ImportError> {
    let mut instance = fmu.instantiate("twin", false)?;
    instance.setup_experiment(0.0, None)?;
    instance.set_integer(&[fmu.description.vr(name)?], &[value])?;
    instance.enter_initialization_mode()?;
    instance.exit_initialization_mode()?;
    for k in 0..200 {
        instance.do_step(f64::from(k) * 1e-3, 1e-3)?;
    }
    Ok(output_bits(fmu, &mut instance))
}

#[test]
fn every_settable_enumeration_has_an_integer_twin_that_runs_the_unit_as_the_enumeration_does() {
    let mut failures = Vec::new();
    let mut items_that_changed_the_outputs = 0;
    for path in packaged_fmus() {
        let fmu = Fmu::open(&path).unwrap_or_else(|e| panic!("cannot open {}: {e}", path.display()));
        let model = fmu.description.model_name.clone();
        let enumerations: Vec<String> = fmu
            .description
            .variables
            .iter()
            .filter(|v| v.type_name == "Enumeration" && (v.causality == "parameter" || v.causality == "input"))
            .map(|v| v.name.clone())
            .collect();
        for name in enumerations {
            let twin = format!("{name}_number");
            if !fmu.description.variable(&twin).is_ok_and(|t| t.type_name == "Integer") {
                failures.push(format!("{model}: {name} has no Integer twin {twin}"));
                continue;
            }
            let mut distinct = std::collections::BTreeSet::new();
            for item in 1..=4 {
                match (outputs_with(&fmu, &name, item), outputs_with(&fmu, &twin, item)) {
                    (Ok(by_enumeration), Ok(by_twin)) => {
                        if by_enumeration != by_twin {
                            failures.push(format!("{model}: {name} = {item} and {twin} = {item} run differently"));
                        }
                        distinct.insert(by_enumeration);
                    }
                    // An item the unit refuses (out of range, or not with the default parameters)
                    // must be refused through either variable.
                    (Err(_), Err(_)) => {}
                    (by_enumeration, by_twin) => failures.push(format!(
                        "{model}: {name} = {item} gives {:?}, {twin} = {item} gives {:?}",
                        by_enumeration.err().map(|e| e.to_string()),
                        by_twin.err().map(|e| e.to_string())
                    )),
                }
            }
            items_that_changed_the_outputs += distinct.len().saturating_sub(1);
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
    // Not vacuous: the items do change what the units compute (the wind's spectrum `off`, the
    // torque law, the encoders' rounding).
    assert!(items_that_changed_the_outputs >= 3, "only {items_that_changed_the_outputs} items changed any output");
}
