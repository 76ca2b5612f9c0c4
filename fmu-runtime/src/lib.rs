//! The exporter's side of the FMI 2.0 co-simulation C API, written once for every model of this
//! project: the legal-state table, the variable tables that drive get/set, start values and the
//! generated `modelDescription.xml`, FMU states and parameter files.
//!
//! With the importer (`fmu-import`) this is where C meets Rust, the only crates with `unsafe`.
//! Model crates implement [`model::Model`] in safe Rust and call [`export_fmi2!`].

pub mod call_error;
pub mod checks;
pub mod exports;
pub mod files;
pub use fmi2_ffi as ffi;
pub mod instance;
pub mod model;
pub mod package;
pub mod params;
pub mod phase;
pub mod seed;
pub mod state;
pub mod state_error;
pub mod units;
pub mod variables;
pub mod xml;

pub use model::{Context, DefaultExperiment, Model, ModelInfo, Notes};
pub use state::{InstanceState, StateError, StateHeader};
pub use variables::{EnumerationType, Values, Var, VariableSet};
