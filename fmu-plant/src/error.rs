//! Why a plant cannot be built or stepped: the errors of [`crate::AzimuthPlant`] and
//! [`crate::ElevationPlant`], which the FMUs log with `fmi2Error`.

use std::fmt::Debug;

/// Why a plant refuses its parameters, its initial state or a step.
#[derive(Debug, thiserror::Error)]
pub enum PlantError {
    /// Fields that break their constraints; each problem names the field and the constraint
    /// it must meet (`gear_ratio (0) must be finite and positive`).
    #[error("invalid {axis} parameters: {}", .problems.join("; "))]
    InvalidParameters { axis: &'static str, problems: Vec<String> },
    /// Dynamics faster than the exact discretisation represents accurately (`max_rate`).
    #[error(
        "invalid {axis} parameters: the drive's fastest rate, {rate_of}, is {rate:.3e} 1/s, above the {max_rate:e} 1/s \
         up to which the exact discretisation keeps about 1e-9 relative accuracy (the default drive's fastest is \
         about 1.4e3 1/s; docs/plant-model.md, section 7): a stiffness, damping or current-loop bandwidth \
         this large, an inertia this small, or a damping this small beside backlash, is outside any real drive"
    )]
    TooFast { axis: &'static str, rate_of: String, rate: f64, max_rate: f64 },
    #[error("initial {axis} angle ({angle}) must be finite")]
    InitialAngleNotFinite { axis: &'static str, angle: f64 },
    #[error("step size ({h}) must be finite and positive")]
    StepNotPositive { h: f64 },
    #[error("{axis} inputs must be finite: {inputs:?}")]
    InputsNotFinite { axis: &'static str, inputs: Box<dyn Debug + Send + Sync> },
    /// A step whose state came out NaN or infinite; it was undone.
    #[error(
        "the {axis} step of {h} s from t = {time} s produced a non-finite state (NaN or infinity) and was undone: \
         the plant is as it was before the step. Likely cause: {cause}"
    )]
    NonFiniteStep { axis: &'static str, time: f64, h: f64, cause: String },
}
