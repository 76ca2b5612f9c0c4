//! A modal model of the antenna structure between the drives' load side (where the encoders
//! sit) and the RF beam: the deflections that the encoders never see. No C here; the
//! `fmu-structure-cdylib` crate exports it as the `Structure` FMU.
//!
//! * [`modes`]: the modes file (frequency, damping, modal stiffness, participation factors) and
//!   the static compliance it implies.
//! * [`dynamics`]: the modes stepped with their exact zero-order-hold solution.
//! * [`fmi`]: the `Structure` variable table and FMU.
//!
//! See `docs/structure-model.md` for the equations, the file format and the defaults.

#![forbid(unsafe_code)]

pub mod dynamics;
pub mod fmi;
pub mod modes;
