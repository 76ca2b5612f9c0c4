//! The shared FMU runtime: the FMI 2.0 co-simulation C API implemented once for every model
//! of this project, the importer a master uses to load `.fmu` files through that same C API,
//! and the linear-system numerics the models share.
//!
//! This crate is the only place with `unsafe` code: it is where C meets Rust. Model crates
//! implement [`model::Model`] in safe Rust and call [`export_fmi2!`].

pub mod exports;
pub mod ffi;
pub mod import;
pub mod instance;
pub mod linear;
pub mod model;
pub mod package;
pub mod params;
pub mod state;
pub mod units;
pub mod variables;
pub mod xml;

pub use model::{Context, DefaultExperiment, Model, ModelInfo, Notes};
pub use state::{StateError, StateReader, StateWriter};
pub use variables::{EnumerationType, Values, Var, VariableSet};
