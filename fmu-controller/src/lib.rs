//! The Antenna Control Unit (ACU) logic of the MeerKAT positioner model: one discrete-time
//! controller per axis, implementing the architecture of the seed paper's Fig. 3.
//!
//! ```text
//! position command ─► command profiler ─► position loop ─►(+)─► velocity PI ─►(+)─► torque ─► currents
//!  + command velocity   (steps only)        P (+ I)       ▲ v_ff            ▲ J N a_ff + friction ff
//!                                           limits        │                 │
//! encoder ──────────────────────────────────┘  motor speeds (mean) ─────────┘
//! azimuth: torque bias + differential speed loop split the torque between the two motors
//! ```
//!
//! * [`AzimuthController`] and [`ElevationController`] each execute one sample per call of
//!   `sample`; [`timing::SampleScheduler`] runs them inside a master's communication steps
//!   with the computation/transport delay.
//! * [`params`] holds every parameter with its unit, default and an `enabled` flag per
//!   feature.
//! * [`linear`] gives the loops' frequency responses for Bode plots and margins.
//!
//! Everything is plain safe Rust; the FMI wiring lives elsewhere. See `docs/controller.md`
//! for the design, the laws, the tuning and the margins.

#![forbid(unsafe_code)]

pub mod azimuth;
mod cascade;
pub mod elevation;
pub mod filters;
pub mod friction_feedforward;
pub mod linear;
pub mod params;
pub mod position_loop;
pub mod profiler;
pub mod status;
pub mod timing;
pub mod torque_bias;
pub mod velocity_loop;

pub use azimuth::{AzimuthController, AzimuthGains, AzimuthInputs, AzimuthOutputs};
pub use cascade::{CascadeState, ControlMode};
pub use elevation::{ElevationController, ElevationInputs, ElevationOutputs};
pub use params::{AzimuthControllerParams, CascadeParams, ElevationControllerParams};
pub use status::AxisStatus;
pub use timing::{SampleScheduler, SampledController, SchedulerState};

pub mod fmi;
