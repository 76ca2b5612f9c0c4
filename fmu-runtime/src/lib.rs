//! The shared FMU runtime.
pub mod linear;
