//! Physics of the MeerKAT wind unit: the along-wind gust and the wind torques on the azimuth
//! and elevation axes. No FMI code here; the lead wires these types to FMI variables.
//!
//! * [`davenport`]: Eq. 2 of the seed paper, turbulence intensity, expected 3-s gusts and the
//!   roughness length that matches a gust factor.
//! * [`prototype`]: the normalised rational approximation of Davenport's shape and its
//!   deterministic generator.
//! * [`shaping`]: shaping filters (the Davenport filter derived for the given mean speed, or
//!   the paper's H3/H10) in modal state-space form, with the noise convention.
//! * [`gust`]: the seeded, step-size-independent gust generator with save/restore.
//! * [`coefficients`]: torque coefficient surfaces from a replaceable table.
//! * [`torque`]: azimuth and elevation torques, quadratic or linearised, split into mean and
//!   gust parts.
//! * [`site`]: site constants (air density, roughness lengths for the requirement scenarios).
//! * [`error`]: the typed errors of the constructors above.
//! * [`analysis`]: autocovariance and finite-record statistics for the tests, the examples and
//!   the wind-spectra tool (spectral estimates come from `antenna_dsp`).
//!
//! See `docs/wind-model.md` for the conventions, the design and its measured accuracy.

#![forbid(unsafe_code)]

pub mod admittance;
pub mod analysis;
pub mod coefficients;
pub mod davenport;
pub mod error;
pub mod fmi;
pub mod gust;
pub mod prototype;
pub mod shaping;
pub mod site;
pub mod torque;
