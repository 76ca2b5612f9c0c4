//! Shared helpers for the integration tests: find the packaged `.fmu` files and open them
//! through the importer, exactly as an external master would.

use std::path::PathBuf;

use fmu_runtime::import::{Fmu, Instance};

/// The packaged FMU with this model identifier. The test command packages before testing; a
/// missing file is a failure with instructions, never a silent skip.
pub fn fmu_path(model_identifier: &str) -> PathBuf {
    let path = antenna_tools::package::fmu_path(model_identifier);
    assert!(
        path.is_file(),
        "{} is missing: package the FMUs first (cargo run --release -p antenna-tools --bin package)",
        path.display()
    );
    path
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
