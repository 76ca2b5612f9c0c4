//! The FMI 2.0 face of the controller: two co-simulation FMUs, `AzimuthController` and
//! `ElevationController`, served by one shared library (crate `fmu-controller-cdylib`; the GUID
//! chooses the model).

pub mod azimuth;
pub mod common;
pub mod elevation;
mod variables;

pub use azimuth::{AzCtrlVar, AzimuthControllerModel};
pub use elevation::{ElCtrlVar, ElevationControllerModel};

use fmu_runtime::package::{default_parameter_file, FmuSpec};

use crate::params::ParameterError;
use crate::timing::ClockError;

/// Why a controller FMU refuses a call; logged with `fmi2Error`.
#[derive(Debug, thiserror::Error)]
pub enum ControllerFmuError {
    #[error(transparent)]
    Parameters(#[from] ParameterError),
    #[error(transparent)]
    Clock(#[from] ClockError),
    /// A step before fmi2ExitInitializationMode built the controller.
    #[error("the controller is not initialised")]
    NotInitialised,
}
use fmu_runtime::EnumerationType;

/// The controller's modes, as an FMI enumeration (values match `ControlMode::index`).
pub static CONTROL_MODE: EnumerationType = EnumerationType {
    name: "ControlMode",
    description: "What the controller does with its commands.",
    items: &[
        ("position", "Position control of Fig. 3: profiler, position loop, velocity loop."),
        ("velocity", "Velocity mode for identification: command.velocity_mode drives the velocity loop directly."),
        (
            "open_loop_current",
            "Velocity controller off: command.open_loop_current goes to the motors (with bias on azimuth).",
        ),
    ],
};

/// The FMUs this crate ships.
pub fn fmus() -> Vec<FmuSpec> {
    vec![
        FmuSpec::of::<AzimuthControllerModel>("fmu_controller_ffi", || {
            vec![("defaults.params".into(), default_parameter_file::<AzimuthControllerModel>().into_bytes())]
        }),
        FmuSpec::of::<ElevationControllerModel>("fmu_controller_ffi", || {
            vec![("defaults.params".into(), default_parameter_file::<ElevationControllerModel>().into_bytes())]
        }),
    ]
}
