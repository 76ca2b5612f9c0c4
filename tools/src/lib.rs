//! The project's tools as a library: packaging and code generation, the coupled-antenna master,
//! signal processing, plotting, measured-data validation. The binaries in `src/bin` are thin
//! command-line fronts to it.
pub mod antenna;
pub mod package;
pub mod registry;
pub mod measured_log;
pub mod truth;
pub mod validate;
pub mod dsp;
pub mod plot;
pub mod windfit;
pub mod wind_spectra;
pub mod plant_identification;
