//! Shared helpers for the integration tests: find the packaged `.fmu` files and open them
//! through the importer, exactly as an external master would, plus the small bits of
//! bookkeeping several tests share (reading variables by name, comparing records).

use std::path::PathBuf;

use fmi2_ffi::Status;
use fmu_import::{Fmu, ImportError, Instance};

/// The two plant FMUs the plant tests run on.
pub const PLANTS: [&str; 2] = ["AzimuthPlant", "ElevationPlant"];

const PACKAGE_HINT: &str = "package the FMUs first (cargo xtask package)";

/// The packaged FMU with this model identifier. The test command packages before testing; a
/// missing file is a failure with instructions, never a silent skip.
pub fn fmu_path(model_identifier: &str) -> PathBuf {
    let path = antenna_fmus::fmu_path(model_identifier);
    assert!(path.is_file(), "{} is missing: {PACKAGE_HINT}", path.display());
    path
}

/// Every `.fmu` in the packaging folder, sorted, so that FMUs added later are covered by the
/// tests that apply to all of them. Fails if there is none.
pub fn packaged_fmus() -> Vec<PathBuf> {
    let directory = antenna_fmus::fmu_directory();
    let entries = std::fs::read_dir(&directory)
        .unwrap_or_else(|e| panic!("cannot read {}: {e}; {PACKAGE_HINT}", directory.display()));
    let mut paths: Vec<PathBuf> = entries
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "fmu"))
        .collect();
    paths.sort();
    assert!(!paths.is_empty(), "no .fmu in {}: {PACKAGE_HINT}", directory.display());
    for plant in PLANTS {
        fmu_path(plant);
    }
    paths
}

pub fn open(model_identifier: &str) -> Fmu {
    Fmu::open(fmu_path(model_identifier)).unwrap_or_else(|e| panic!("cannot open {model_identifier}: {e}"))
}

/// An instance through setup and initialisation with the given start values.
pub fn initialized(fmu: &Fmu, name: &str, reals: &[(&str, f64)]) -> Instance {
    let mut instance = fmu.instantiate(name, false).unwrap_or_else(|e| panic!("instantiate {name}: {e}"));
    let values: Vec<(u32, f64)> = reals.iter().map(|(n, v)| (fmu.description.vr(n).unwrap(), *v)).collect();
    instance.initialize(0.0, &values).unwrap_or_else(|e| panic!("initialise {name}: {e}"));
    instance
}

/// Reads Real variables by name.
pub fn reals(fmu: &Fmu, instance: &mut Instance, names: &[&str]) -> Result<Vec<f64>, ImportError> {
    let vrs = fmu.description.vrs(names)?;
    let mut values = vec![f64::NAN; vrs.len()];
    instance.get_real(&vrs, &mut values)?;
    Ok(values)
}

/// Reads one Real variable by name, panicking with the FMU's messages on failure.
pub fn real(fmu: &Fmu, instance: &mut Instance, name: &str) -> f64 {
    reals(fmu, instance, &[name]).unwrap_or_else(|e| panic!("get {name}: {e}"))[0]
}

/// Sets Real variables by name, panicking with the FMU's messages on failure.
pub fn set_reals(fmu: &Fmu, instance: &mut Instance, values: &[(&str, f64)]) {
    let names: Vec<&str> = values.iter().map(|(n, _)| *n).collect();
    let vrs = fmu.description.vrs(&names).unwrap();
    let v: Vec<f64> = values.iter().map(|(_, v)| *v).collect();
    instance.set_real(&vrs, &v).unwrap_or_else(|e| panic!("set {names:?}: {e}"));
}

/// Names of every output of a given type, in model-description order.
pub fn outputs_of_type(fmu: &Fmu, type_name: &str) -> Vec<String> {
    fmu.description
        .variables
        .iter()
        .filter(|v| v.causality == "output" && v.type_name == type_name)
        .map(|v| v.name.clone())
        .collect()
}

/// Every Real and Integer output of an instance as exact bit patterns, for bitwise comparisons.
pub fn output_bits(fmu: &Fmu, instance: &mut Instance) -> Vec<u64> {
    let real_names = outputs_of_type(fmu, "Real");
    let integer_names = outputs_of_type(fmu, "Integer");
    let real_names: Vec<&str> = real_names.iter().map(String::as_str).collect();
    let mut bits: Vec<u64> = reals(fmu, instance, &real_names).unwrap().iter().map(|v| v.to_bits()).collect();
    if !integer_names.is_empty() {
        let names: Vec<&str> = integer_names.iter().map(String::as_str).collect();
        let vrs = fmu.description.vrs(&names).unwrap();
        let mut values = vec![0; vrs.len()];
        instance.get_integer(&vrs, &mut values).unwrap();
        bits.extend(values.iter().map(|&v| v as u32 as u64));
    }
    bits
}

/// Largest difference of `simulated` from `reference`, as a fraction of the reference's range.
pub fn error_relative_to_range(simulated: &[f64], reference: &[f64]) -> f64 {
    assert_eq!(simulated.len(), reference.len(), "records of different lengths");
    let max = reference.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let min = reference.iter().copied().fold(f64::INFINITY, f64::min);
    assert!(max > min, "the reference record is constant: a range-relative error means nothing");
    let worst = simulated.iter().zip(reference).map(|(s, r)| (s - r).abs()).fold(0.0, f64::max);
    worst / (max - min)
}

/// A deterministic, piecewise-constant test signal in [-1, 1), changing with `index` (a
/// splitmix64 hash, so no generator state needs carrying between calls).
pub fn test_signal(index: u64, seed: u64) -> f64 {
    let mut z = index.wrapping_add(seed.wrapping_mul(0x2545_F491_4F6C_DD1D)).wrapping_mul(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^= z >> 31;
    (z >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
}

/// Asserts that a call failed with exactly fmi2Error and that the FMU explained why through the
/// logger, under logStatusError; returns the messages.
pub fn expect_error<T: std::fmt::Debug>(
    result: Result<T, ImportError>,
    instance: &Instance,
    what: &str,
) -> Vec<String> {
    match result {
        Err(ImportError::Call { status: Status::Error, messages, .. }) => {
            assert!(!messages.is_empty(), "{what}: fmi2Error without a logged message");
            let logged = instance.log_records();
            assert!(
                logged
                    .iter()
                    .any(|r| r.status == Status::Error && r.category == "logStatusError" && !r.message.is_empty()),
                "{what}: no message under logStatusError ({logged:?})"
            );
            messages
        }
        other => panic!("{what}: expected fmi2Error, got {other:?}"),
    }
}

/// The value reference of a variable, from the model description.
pub fn vr(fmu: &Fmu, name: &str) -> u32 {
    fmu.description.vr(name).unwrap()
}

/// The Real inputs of a model, from its model description.
pub fn real_inputs(fmu: &Fmu) -> Vec<String> {
    fmu.description
        .variables
        .iter()
        .filter(|v| v.causality == "input" && v.type_name == "Real")
        .map(|v| v.name.clone())
        .collect()
}
