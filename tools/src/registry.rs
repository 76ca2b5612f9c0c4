//! The list of model crates and the FMUs each one ships.

use fmu_runtime::package::FmuSpec;

/// All FMU specifications of all model crates.
pub fn fmus() -> Vec<FmuSpec> {
    let mut specs = Vec::new();
    specs.extend(fmu_plant::fmi::fmus());
    specs.extend(fmu_wind::fmi::fmus());
    specs.extend(fmu_controller::fmi::fmus());
    specs
}

/// The cargo package that builds a given library.
pub fn package_of(library_name: &str) -> &'static str {
    match library_name {
        "fmu_plant_ffi" => "fmu-plant-cdylib",
        "fmu_wind_ffi" => "fmu-wind-cdylib",
        "fmu_controller_ffi" => "fmu-controller-cdylib",
        other => panic!("no cargo package known for library {other}"),
    }
}
