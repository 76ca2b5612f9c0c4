//! A master's step arithmetic does not change the results: every packaged FMU stepped with
//! OMSimulator's steps, `h = (t + 1e-3) - t` with the time accumulated by addition (1e-3 give or
//! take an ulp of `t`), gives bit for bit what it gives with exact 1e-3 steps, from t = 1000 s
//! where those ulps are largest for a run of this length (the runtime's rule,
//! `fmu_runtime::exports::grid_step`).

use antenna_tests::{open, packaged_fmus};
use fmu_import::{Fmu, Instance};

const START_S: f64 = 1000.0;
const STEP_S: f64 = 1e-3;
const STEPS: usize = 3000;

/// Each Real input moves as a slow sine about its start value, a twentieth of its range (at
/// most 100 units) high, each at its own frequency: enough to reverse the plants' motors and
/// flip their encoders' counts.
fn inputs_at(fmu: &Fmu, time: f64) -> (Vec<u32>, Vec<f64>) {
    let parse = |s: &Option<String>| s.as_deref().and_then(|t| t.parse::<f64>().ok());
    fmu.description
        .variables
        .iter()
        .filter(|v| v.causality == "input" && v.type_name == "Real")
        .enumerate()
        .map(|(k, v)| {
            let start = parse(&v.start).unwrap_or(0.0);
            let amplitude = match (parse(&v.min), parse(&v.max)) {
                (Some(lo), Some(hi)) => 0.05 * (hi - lo).min(2e3),
                _ => 1.0,
            };
            let frequency = 0.7 + 0.37 * k as f64;
            (v.value_reference, start + amplitude * (std::f64::consts::TAU * frequency * (time - START_S)).sin())
        })
        .unzip()
}

fn run(fmu: &Fmu, oms_arithmetic: bool) -> (Vec<Vec<u64>>, usize) {
    let mut instance: Instance = fmu.instantiate("arithmetic", false).unwrap();
    instance.initialize(START_S, &[]).unwrap();
    let outputs: Vec<u32> = fmu
        .description
        .variables
        .iter()
        .filter(|v| v.causality == "output" && v.type_name == "Real")
        .map(|v| v.value_reference)
        .collect();
    let mut time = START_S;
    let mut off_grid = 0;
    let mut record = Vec::with_capacity(STEPS);
    for k in 0..STEPS {
        // The exact master's points are the start plus k steps; OMSimulator's accumulate.
        let (current, step) = if oms_arithmetic {
            let next = time + STEP_S;
            (time, next - time)
        } else {
            (START_S + k as f64 * STEP_S, STEP_S)
        };
        off_grid += usize::from(step != STEP_S);
        let (vrs, values) = inputs_at(fmu, START_S + k as f64 * STEP_S);
        instance.set_real(&vrs, &values).unwrap();
        instance.do_step(current, step).unwrap();
        time = current + step;
        let mut values = vec![0.0; outputs.len()];
        instance.get_real(&outputs, &mut values).unwrap();
        record.push(values.iter().map(|v| v.to_bits()).collect());
    }
    (record, off_grid)
}

#[test]
fn every_fmu_gives_bit_for_bit_the_same_outputs_under_omsimulators_step_arithmetic() {
    for path in packaged_fmus() {
        let fmu = open(path.file_stem().unwrap().to_str().unwrap());
        let name = &fmu.description.model_identifier;
        let (exact, _) = run(&fmu, false);
        let (oms, off_grid) = run(&fmu, true);
        assert!(off_grid > STEPS / 10, "{name}: only {off_grid} steps off 1e-3: the test would pass vacuously");
        let moving = (0..exact[0].len()).filter(|&j| exact.iter().any(|row| row[j] != exact[0][j])).count();
        assert!(moving > 0, "{name}: no output moved");
        for (k, (a, b)) in exact.iter().zip(&oms).enumerate() {
            assert_eq!(a, b, "{name}: step {k} differs ({off_grid} of {STEPS} steps were off 1e-3)");
        }
        println!("{name}: {moving} outputs moving, {off_grid} of {STEPS} steps off 1e-3, bit for bit");
    }
}
