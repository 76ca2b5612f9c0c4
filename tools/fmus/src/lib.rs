//! The project's FMUs: the model crates and the FMUs each one ships, the cargo package that
//! builds each shared library, and where the packaged `.fmu` files and the committed model
//! descriptions live. Build tasks, the coupled master, the validation tool and the tests all
//! find the FMUs through here.

pub mod parameters;

use std::path::{Path, PathBuf};

use fmu_runtime::package::FmuSpec;

/// All FMU specifications of all model crates.
pub fn fmus() -> Vec<FmuSpec> {
    let mut specs = Vec::new();
    specs.extend(fmu_plant::fmi::fmus());
    specs.extend(fmu_wind::fmi::fmus());
    specs.extend(fmu_controller::fmi::fmus());
    specs.extend(fmu_structure::fmi::fmus());
    specs
}

/// The cargo package that builds a given library.
pub fn package_of(library_name: &str) -> &'static str {
    match library_name {
        "fmu_plant_ffi" => "fmu-plant-cdylib",
        "fmu_wind_ffi" => "fmu-wind-cdylib",
        "fmu_controller_ffi" => "fmu-controller-cdylib",
        "fmu_structure_ffi" => "fmu-structure-cdylib",
        other => panic!("no cargo package known for library {other}"),
    }
}

/// Every FMU the project ships, in packaging order.
pub fn all_fmus() -> Vec<FmuSpec> {
    fmus()
}

/// The workspace root (the folder with the top-level Cargo.toml).
pub fn workspace_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../..")
        .canonicalize()
        .expect("tools/fmus lives two folders below the workspace root")
}

/// The documented folder the packaged `.fmu` files are written to: `target/fmu/`, or the
/// folder named by the environment variable `MEERKAT_FMU_DIR` (to run the tools on FMUs
/// packaged elsewhere, for example a profiling build).
pub fn fmu_directory() -> PathBuf {
    match std::env::var_os("MEERKAT_FMU_DIR") {
        Some(dir) => PathBuf::from(dir),
        None => workspace_root().join("target").join("fmu"),
    }
}

/// The path of one packaged FMU.
pub fn fmu_path(model_identifier: &str) -> PathBuf {
    fmu_directory().join(format!("{model_identifier}.fmu"))
}

/// Where the committed model descriptions live.
pub fn model_description_directory() -> PathBuf {
    workspace_root().join("modelDescription")
}
