//! Signal processing shared by the analysis tools and the tests: Welch spectra with honest
//! confidence intervals, cross spectra and frequency-response estimates, log-frequency band
//! averaging, correlation and whiteness tests, the basic statistics of a record, and the
//! conditioning of a record before a fit (Savitzky-Golay filters, noise estimates, interpolation).
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
pub mod conditioning;
pub mod correlation;
pub mod distributions;
pub mod error;
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
pub use error::DspError;
pub use expectation::expected_welch_psd;
pub use lpsd::{expected_lpsd, lpsd, lpsd_segment_len, FrequencyEstimate};
pub use rustfft::num_complex::Complex64;
pub use spectral::{
    coherence, transfer_function_h1, unwrap_phase_deg, welch_csd, welch_psd, CrossSpectrum, Detrend, Spectrum,
    TransferEstimate, WelchConfig,
};
pub use stats::{
    fit_percent_from_model, fit_percent_from_residual, kurtosis_excess, linear_regression, max_moving_average,
    max_moving_centred_rms, max_moving_rms, mean, moving_average, moving_centred_rms, moving_rms, rms, sample_variance,
    skewness, std_dev, variance, weighted_least_squares, weighted_linear_regression, window_samples, LineFit,
    WindowExtreme,
};
pub use window::Window;
