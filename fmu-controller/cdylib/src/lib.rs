//! The shared library of the controller FMUs. It holds nothing but the exported C API: the
//! models live in the `fmu-controller` library, so that tools can link several model crates
//! without their `fmi2*` symbols clashing.

#![forbid(unsafe_code)]

fmu_runtime::export_fmi2!(fmu_controller::fmi::AzimuthControllerModel, fmu_controller::fmi::ElevationControllerModel);
