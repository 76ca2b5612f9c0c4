//! Signal processing shared by the analysis tools and the tests: Welch spectra with honest
//! confidence intervals, cross spectra and frequency-response estimates, log-frequency band
//! averaging, correlation and whiteness tests, and the basic statistics of a record.
//!
//! Conventions, stated once for the whole module:
//! - Spectra are **one-sided densities per Hz**: a real signal's variance equals the integral of
//!   its PSD from 0 to the Nyquist frequency, and a sine of amplitude A contributes A^2/2.
//! - Windows are normalised by their power (sum of squared coefficients), so the window changes
//!   the resolution and leakage of a density estimate but not its level.
//! - Cross spectra are S_xy = E[conj(X) Y], so the frequency response from x to y is
//!   H1 = S_xy / S_xx.
//! - Confidence intervals use the chi-squared distribution with the equivalent degrees of
//!   freedom of the estimate (Percival & Walden, 1993, eq. 292b), which accounts for the window
//!   and the segment overlap.
//! - [`expected_welch_psd`] gives the exact expectation of a Welch estimate for a process of
//!   known autocovariance (window leakage and aliasing included), to compare estimates with.
//! - Functions that can be misconfigured return [`DspError`] instead of panicking; the simple
//!   statistics return NaN for an empty input, as floating-point reductions conventionally do.

pub mod bands;
pub mod comparison;
pub mod correlation;
pub mod distributions;
pub mod expectation;
pub mod lpsd;
pub mod spectral;
pub mod stats;
pub mod window;

/// Seeded noise and processes with an exactly known spectrum, for this crate's tests and, through
/// the `test-signals` feature, for the tests of the crates that use it.
#[cfg(any(test, feature = "test-signals"))]
pub mod test_signals;

pub use bands::{log_band_average, BandSpectrum};
pub use comparison::ResponseComparison;
pub use correlation::{
    autocorrelation, cross_correlation, whiteness_bound, whiteness_test, CrossCorrelation, WhitenessTest,
};
pub use distributions::{
    chi_squared_cdf, chi_squared_quantile, chi_squared_sf, digamma, standard_normal_quantile, trigamma,
    ChiSquaredInterval,
};
pub use expectation::expected_welch_psd;
pub use lpsd::{expected_lpsd, lpsd, lpsd_segment_len, FrequencyEstimate};
pub use rustfft::num_complex::Complex64;
pub use spectral::{
    coherence, transfer_function_h1, unwrap_phase_deg, welch_csd, welch_psd, CrossSpectrum, Detrend, Spectrum,
    TransferEstimate, WelchConfig,
};
pub use stats::{
    fit_percent_from_model, fit_percent_from_residual, kurtosis_excess, linear_regression, max_moving_average,
    max_moving_rms, mean, moving_average, moving_rms, rms, sample_variance, skewness, std_dev, variance,
    weighted_least_squares, weighted_linear_regression, window_samples, LineFit, WindowExtreme,
};
pub use window::Window;

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
