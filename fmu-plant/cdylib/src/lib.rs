//! The shared library of the plant FMUs. It holds nothing but the exported C API: the models
//! live in the `fmu-plant` library, so that tools can link several model crates without their
//! `fmi2*` symbols clashing.

#![forbid(unsafe_code)]

fmu_runtime::export_fmi2!(fmu_plant::fmi::AzimuthPlantModel, fmu_plant::fmi::ElevationPlantModel);
