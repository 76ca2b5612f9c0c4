//! The `ModelStructure` each packaged FMU declares, checked against what its values really
//! depend on, through the C ABI as a master sees them: every initial unknown declares its
//! dependencies (none left out, which would say "depends on every known" and make a master
//! such as OMSimulator see an initial loop through every connection), and no input changes an
//! initial unknown or a direct-feedthrough output that does not declare it.

use antenna_tests::{open, packaged_fmus};
use fmu_import::{Fmu, Instance, ScalarVariable};

/// The value of every variable at the 1-based `indices`, as bits (a change of the last bit
/// counts).
fn values_at(fmu: &Fmu, instance: &mut Instance, indices: &[usize]) -> Vec<u64> {
    indices
        .iter()
        .map(|&index| {
            let v = &fmu.description.variables[index - 1];
            let vr = [v.value_reference];
            match v.type_name.as_str() {
                "Real" => {
                    let mut x = [0.0];
                    instance.get_real(&vr, &mut x).unwrap();
                    x[0].to_bits()
                }
                "Integer" | "Enumeration" => {
                    let mut x = [0];
                    instance.get_integer(&vr, &mut x).unwrap();
                    x[0] as u64
                }
                "Boolean" => {
                    let mut x = [false];
                    instance.get_boolean(&vr, &mut x).unwrap();
                    u64::from(x[0])
                }
                _ => 0,
            }
        })
        .collect()
}

/// Sets one input to another value inside its range: a Real moved by a tenth of its range (or
/// by one where it has none), an Integer or Enumeration by one, a Boolean toggled.
fn perturb(instance: &mut Instance, input: &ScalarVariable) {
    let vr = [input.value_reference];
    let parse = |s: &Option<String>| s.as_deref().and_then(|t| t.parse::<f64>().ok());
    let start = parse(&input.start).unwrap_or(0.0);
    let (min, max) = (parse(&input.min), parse(&input.max));
    match input.type_name.as_str() {
        "Real" => {
            let step = match (min, max) {
                (Some(lo), Some(hi)) => 0.1 * (hi - lo).min(2e3),
                _ => 1.0,
            };
            let up = start + step;
            let value = if max.is_none_or(|hi| up <= hi) { up } else { start - step };
            instance.set_real(&vr, &[value]).unwrap();
        }
        "Integer" | "Enumeration" => {
            let up = start + 1.0;
            let value = if max.is_none_or(|hi| up <= hi) { up } else { start - 1.0 };
            instance.set_integer(&vr, &[value as i32]).unwrap();
        }
        "Boolean" => {
            let on = input.start.as_deref() == Some("true");
            instance.set_boolean(&vr, &[!on]).unwrap();
        }
        other => panic!("{}: input of type {other}", input.name),
    }
}

/// The 1-based indices of the inputs.
fn inputs(fmu: &Fmu) -> Vec<usize> {
    (1..=fmu.description.variables.len()).filter(|&i| fmu.description.variables[i - 1].causality == "input").collect()
}

/// The initial unknowns' values after initialisation, with `changed` perturbed in
/// Initialization Mode.
fn initial_values(fmu: &Fmu, unknowns: &[usize], changed: Option<usize>) -> Vec<u64> {
    let mut instance = fmu.instantiate("structure", false).unwrap();
    instance.setup_experiment(0.0, None).unwrap();
    instance.enter_initialization_mode().unwrap();
    if let Some(index) = changed {
        perturb(&mut instance, &fmu.description.variables[index - 1]);
    }
    instance.exit_initialization_mode().unwrap();
    values_at(fmu, &mut instance, unknowns)
}

#[test]
fn every_initial_unknown_declares_the_inputs_its_value_depends_on_and_no_others_change_it() {
    for path in packaged_fmus() {
        let fmu = open(path.file_stem().unwrap().to_str().unwrap());
        let name = &fmu.description.model_identifier;
        let declared = &fmu.description.initial_unknown_dependencies;
        assert!(!declared.is_empty(), "{name}: no InitialUnknowns");
        for (index, dependencies) in declared {
            let variable = &fmu.description.variables[index - 1].name;
            let dependencies = dependencies.as_ref().unwrap_or_else(|| {
                panic!("{name}: the initial unknown {variable} leaves its dependencies out (every known, every input)")
            });
            for d in dependencies {
                let known = &fmu.description.variables[d - 1];
                assert!(
                    known.causality == "input" || known.causality == "parameter",
                    "{name}: {variable} depends on {}, which is no known of initialisation",
                    known.name
                );
            }
        }
        let unknowns: Vec<usize> = declared.iter().map(|(i, _)| *i).collect();
        let baseline = initial_values(&fmu, &unknowns, None);
        let mut changed_any = 0;
        for input in inputs(&fmu) {
            let after = initial_values(&fmu, &unknowns, Some(input));
            for (k, (index, dependencies)) in declared.iter().enumerate() {
                if after[k] != baseline[k] {
                    changed_any += 1;
                    assert!(
                        dependencies.as_ref().is_some_and(|d| d.contains(&input)),
                        "{name}: the input {} changes the initial value of {}, which does not declare it",
                        fmu.description.variables[input - 1].name,
                        fmu.description.variables[index - 1].name
                    );
                }
            }
        }
        println!("{name}: {} initial unknowns, {changed_any} moved by an input, each declaring it", unknowns.len());
    }
}

#[test]
fn no_input_changes_an_output_that_does_not_declare_it_within_a_step() {
    for path in packaged_fmus() {
        let fmu = open(path.file_stem().unwrap().to_str().unwrap());
        let name = fmu.description.model_identifier.clone();
        let outputs: Vec<usize> = fmu.description.output_dependencies.iter().map(|(i, _)| *i).collect();
        for input in inputs(&fmu) {
            let mut instance = fmu.instantiate("outputs", false).unwrap();
            instance.initialize(0.0, &[]).unwrap();
            instance.do_step(0.0, 1e-3).unwrap();
            let before = values_at(&fmu, &mut instance, &outputs);
            perturb(&mut instance, &fmu.description.variables[input - 1]);
            let after = values_at(&fmu, &mut instance, &outputs);
            for (k, (index, dependencies)) in fmu.description.output_dependencies.iter().enumerate() {
                if after[k] != before[k] {
                    assert!(
                        dependencies.as_ref().is_some_and(|d| d.contains(&input)),
                        "{name}: the input {} changes the output {} within a step, which does not declare it",
                        fmu.description.variables[input - 1].name,
                        fmu.description.variables[index - 1].name
                    );
                }
            }
        }
    }
}
