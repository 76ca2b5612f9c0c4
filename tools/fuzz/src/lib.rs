//! A random call-sequence fuzzer for the packaged FMUs, through their C ABI as any master
//! calls them (`fmu-import`), with an oracle of the FMI 2.0 co-simulation state table and the
//! properties every FMU of this project promises (docs/fmu-robustness.md): no abort, no hang,
//! no NaN or infinity after fmi2OK, every fmi2Error with a logged message, states that
//! round-trip bit for bit, damaged states refused, fmi2Reset equal to a fresh instance, two
//! instances on two threads equal to a serial run. A failure is reproducible from its FMU and
//! seed and is reported with the smallest call sequence found that still fails.

pub mod campaign;
pub mod oracle;
pub mod rng;
pub mod runner;
pub mod sequence;
pub mod target;

/// The FMUs of the project, by model identifier.
pub const FMUS: [&str; 6] =
    ["AzimuthPlant", "ElevationPlant", "AzimuthController", "ElevationController", "Wind", "Structure"];

/// The packaged file of an FMU (`target/fmu/<name>.fmu`, or `MEERKAT_FMU_DIR`).
pub fn fmu_path(name: &str) -> std::path::PathBuf {
    antenna_fmus::fmu_path(name)
}
