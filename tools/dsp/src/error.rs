//! The error of the signal-processing functions, and the input checks they share.

/// Why a signal-processing function could not produce a result.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum DspError {
    /// The input had fewer samples than the operation needs.
    #[error("input too short: {got} samples, at least {needed} needed")]
    TooShort {
        /// Samples required.
        needed: usize,
        /// Samples given.
        got: usize,
    },
    /// Two inputs that must be sample-aligned have different lengths.
    #[error("inputs differ in length: {first} and {second} samples")]
    LengthMismatch {
        /// Length of the first input.
        first: usize,
        /// Length of the second input.
        second: usize,
    },
    /// A sample is NaN or infinite.
    #[error("sample {index} is not finite")]
    NonFinite {
        /// Index of the first offending sample.
        index: usize,
    },
    /// The input is constant, so a normalised quantity is undefined.
    #[error("input has zero variance")]
    ZeroVariance,
    /// A parameter is outside its valid range.
    #[error("invalid {name}: {reason}")]
    InvalidParameter {
        /// Name of the parameter.
        name: &'static str,
        /// What is wrong with it.
        reason: String,
    },
}

impl DspError {
    pub(crate) fn invalid(name: &'static str, reason: impl Into<String>) -> Self {
        DspError::InvalidParameter { name, reason: reason.into() }
    }
}

/// Returns the index of the first non-finite sample, so estimators can refuse NaN input
/// instead of silently returning a NaN spectrum.
pub(crate) fn check_finite(x: &[f64]) -> Result<(), DspError> {
    match x.iter().position(|v| !v.is_finite()) {
        Some(index) => Err(DspError::NonFinite { index }),
        None => Ok(()),
    }
}

/// Checks a sample rate is positive and finite.
pub(crate) fn check_sample_rate(sample_rate_hz: f64) -> Result<(), DspError> {
    if sample_rate_hz > 0.0 && sample_rate_hz.is_finite() {
        Ok(())
    } else {
        Err(DspError::invalid("sample_rate_hz", format!("must be positive and finite, got {sample_rate_hz}")))
    }
}
