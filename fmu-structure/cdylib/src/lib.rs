//! The shared library of the structure FMU. It holds nothing but the exported C API: the model
//! lives in the `fmu-structure` library, so that tools can link several model crates without
//! their `fmi2*` symbols clashing.

#![forbid(unsafe_code)]

fmu_runtime::export_fmi2!(fmu_structure::fmi::StructureModel);
