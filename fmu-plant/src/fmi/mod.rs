//! The FMI 2.0 face of the plant: two co-simulation FMUs, `AzimuthPlant` and
//! `ElevationPlant`, served by one shared library (crate `fmu-plant-cdylib`; the GUID chooses
//! the model). The axes differ
//! in their ports, and FMI 2.0 has no structural parameters, hence two FMUs.

pub mod azimuth;
mod common;
pub mod elevation;

pub use azimuth::{AzVar, AzimuthPlantModel};
pub use elevation::{ElVar, ElevationPlantModel};

use fmu_runtime::package::{default_parameter_file, FmuSpec};

/// Files shipped in each plant FMU's `resources/` folder: the default parameter set (generated
/// from the variable table) and the linear Eq. 1 configuration.
fn azimuth_resources() -> Vec<(String, Vec<u8>)> {
    vec![
        ("defaults.params".into(), default_parameter_file::<AzimuthPlantModel>().into_bytes()),
        ("linear.params".into(), LINEAR_PARAMS.as_bytes().to_vec()),
    ]
}

fn elevation_resources() -> Vec<(String, Vec<u8>)> {
    vec![
        ("defaults.params".into(), default_parameter_file::<ElevationPlantModel>().into_bytes()),
        ("linear.params".into(), LINEAR_PARAMS.as_bytes().to_vec()),
    ]
}

const LINEAR_PARAMS: &str = "# The paper's linear Eq. 1 configuration: friction (except the viscous B_M), backlash,\n# saturation, delay, cogging, extra torques and encoder quantisation are ignored; the elevation\n# geometry is frozen at geometry.frozen_elevation.\nlinear_configuration = true\n";

/// The FMUs this crate ships.
pub fn fmus() -> Vec<FmuSpec> {
    vec![
        FmuSpec::of::<AzimuthPlantModel>("fmu_plant_ffi", azimuth_resources),
        FmuSpec::of::<ElevationPlantModel>("fmu_plant_ffi", elevation_resources),
    ]
}
