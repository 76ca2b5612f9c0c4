//! The project's tools as a library: packaging and code generation, the coupled-antenna master,
//! signal processing, plotting, measured-data validation. The binaries in `src/bin` are thin
//! command-line fronts to it.
pub mod antenna;
pub mod dsp;
pub mod measured_log;
pub mod package;
pub mod plant_identification;
pub mod plot;
pub mod registry;
pub mod truth;
pub mod validate;
pub mod wind_spectra;
pub mod windfit;
