//! Physics of the MeerKAT antenna positioner: the azimuth and elevation drive trains.
//!
//! The physics modules know nothing of FMI; [`fmi`] holds the two FMUs' variable tables and
//! maps them onto the parameter, input and output types, and the C API itself lives in
//! `fmu-runtime`. Everything here is plain, safe Rust with SI units inside (rad, rad/s, N m, A,
//! kg m^2, s); degrees appear only at the API edge in names ending in `_deg`.
//!
//! * [`analytic`]: the seed paper's two-mass model (Fig. 4) in the frequency domain, with Eq. 1
//!   corrected, and an independent partial-fraction step response used to check the simulator.
//! * [`azimuth`]: two motors, each with its own compliant, backlash-afflicted pinion path to a
//!   load whose inertia depends on elevation.
//! * [`elevation`]: one motor driving a preloaded jackscrew whose length, stiffness and
//!   transmission ratio depend on elevation.
//! * [`params`]: parameter types shared by both axes (motors, friction, periodic torques,
//!   numerics).
//! * [`sensors`]: the encoder between the true load angle and its reading (graduation,
//!   interpolation and eccentricity errors, noise, counting) and the motor speed signals.
//!
//! The integrator (module `drivetrain`) is hybrid and piecewise linear: within a discrete mode
//! (which bodies stick, which pinions are in contact) one step is one exact zero-order-hold
//! matrix-vector product; mode switches are localised by dyadic subdivision. See
//! `docs/plant-model.md` for the equations, parameter values and measured errors.

#![forbid(unsafe_code)]
// The drive-train code indexes several parallel per-path arrays with one path index; an index
// loop says that more plainly than zipped iterators.
#![allow(clippy::needless_range_loop)]

pub mod analytic;
pub mod azimuth;
mod cache;
mod delay;
mod drivetrain;
pub mod elevation;
pub mod error;
mod floor;
pub mod params;
pub mod sensors;

pub use azimuth::{AzimuthInputs, AzimuthOutputs, AzimuthParams, AzimuthPlant};
pub use drivetrain::{DriveState, Mesh, Motion, NumericsStatistics, PathState};
pub use elevation::{ElevationInputs, ElevationOutputs, ElevationParams, ElevationPlant, JackscrewParams};
pub use error::PlantError;
pub use params::{CoggingParams, FrictionParams, MotorParams, NumericsParams, PeriodicTorqueParams};
pub use sensors::{CountMode, EncoderErrors, PeriodicError, SampleClock, SensorParams};

pub mod fmi;
