//! The exact expected value of a Welch estimate for a process whose autocovariance is known.
//!
//! A Welch estimate is unbiased for the window-smoothed, aliased spectrum, not for the spectrum
//! itself: where the spectrum is steep on the scale of a bin (the lowest bins of a Davenport
//! gust, whose -5/3 fall is smoothed by the Hann window's main lobe and sidelobes) the estimate
//! reads a few per cent off even with infinitely many segments. Comparing an estimate with the
//! spectrum through a chi-squared band then rejects correct records. For a stationary process
//! with autocovariance `R(m)` (lag in samples) the expectation is exact and cheap:
//!
//! `E |X_k|^2 = sum_m R(m) c(|m|) exp(-j 2 pi k m / L)`, `c(m) = sum_t w_t w_(t+m)`,
//!
//! which is `2 Re A_k - a_0` with `A` the length-`L` DFT of `a_m = R(m) c(m)`, `m = 0..L-1`
//! (`c` vanishes beyond `L - 1`). Sampling enters through `R(m)`, so aliasing is included.

use crate::error::DspError;
use crate::spectral::{Detrend, Spectrum, WelchConfig, BIN_CORRELATION_OFFSETS};
use rustfft::num_complex::Complex64;
use rustfft::FftPlanner;

/// The exact expected value of [`crate::spectral::welch_psd`] with `config` applied to `record_len`
/// samples at `sample_rate_hz` of a zero-mean stationary process with autocovariance
/// `autocovariance(m)` at a lag of `m` samples.
///
/// Returned as a [`Spectrum`] with the same bins, degrees of freedom and bin correlation as the
/// estimate would have, so that [`crate::bands::log_band_average`] turns it into the expected band
/// averages (the mean of a band is the mean of its bins' expectations).
///
/// Only `Detrend::None` is supported: removing each segment's mean makes the estimate a
/// function of the segment's position as well as of the lag, so no lag-only formula exists;
/// a process known to have zero mean needs no detrending.
pub fn expected_welch_psd(
    autocovariance: impl Fn(usize) -> f64,
    record_len: usize,
    sample_rate_hz: f64,
    config: &WelchConfig,
) -> Result<Spectrum, DspError> {
    crate::error::check_sample_rate(sample_rate_hz)?;
    if config.detrend != Detrend::None {
        return Err(DspError::invalid(
            "detrend",
            "the exact expectation needs Detrend::None (segment detrending is not a function of the lag alone)",
        ));
    }
    let len = config.segment_len;
    if len < 2 {
        return Err(DspError::invalid("segment_len", format!("must be at least 2, got {len}")));
    }
    if record_len < len {
        return Err(DspError::TooShort { needed: len, got: record_len });
    }
    let window = config.window.coefficients(len);
    let window_power: f64 = window.iter().map(|w| w * w).sum();
    let lag_products = window_lag_products(&window);
    let mut a: Vec<Complex64> = (0..len).map(|m| Complex64::new(autocovariance(m) * lag_products[m], 0.0)).collect();
    let a0 = a[0].re;
    FftPlanner::<f64>::new().plan_fft_forward(len).process(&mut a);
    let psd = (0..=len / 2)
        .map(|k| {
            let one_sided = if k == 0 || (len.is_multiple_of(2) && k == len / 2) { 1.0 } else { 2.0 };
            one_sided * (2.0 * a[k].re - a0) / (sample_rate_hz * window_power)
        })
        .collect();
    let segments = config.segment_count(record_len);
    Ok(Spectrum {
        frequency_hz: (0..=len / 2).map(|k| k as f64 * sample_rate_hz / len as f64).collect(),
        psd,
        dof: config.equivalent_dof(segments),
        segments,
        segment_len: len,
        sample_rate_hz,
        window: config.window,
        bin_correlation: config.bin_correlation(segments, BIN_CORRELATION_OFFSETS),
    })
}

/// `c(m) = sum_t w_t w_(t+m)` for `m = 0..len-1`, through a zero-padded FFT (the direct sum
/// is quadratic in the segment length, which reaches 10^5 samples for 10-minute segments at
/// millisecond steps).
pub(crate) fn window_lag_products(window: &[f64]) -> Vec<f64> {
    let len = window.len();
    let padded = 2 * len;
    let mut planner = FftPlanner::<f64>::new();
    let mut buffer: Vec<Complex64> = window
        .iter()
        .map(|&w| Complex64::new(w, 0.0))
        .chain(std::iter::repeat_n(Complex64::new(0.0, 0.0), padded - len))
        .collect();
    planner.plan_fft_forward(padded).process(&mut buffer);
    for value in buffer.iter_mut() {
        *value = Complex64::new(value.norm_sqr(), 0.0);
    }
    planner.plan_fft_inverse(padded).process(&mut buffer);
    buffer[..len].iter().map(|c| c.re / padded as f64).collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::spectral::welch_psd;
    use crate::window::Window;
    use rand::SeedableRng;
    use rand_distr::{Distribution, StandardNormal};

    #[test]
    fn white_noise_expectation_is_flat_at_twice_the_variance_over_the_sample_rate() {
        let config = WelchConfig::new(256).with_detrend(Detrend::None);
        let expected = expected_welch_psd(|m| if m == 0 { 4.0 } else { 0.0 }, 4096, 50.0, &config).unwrap();
        for (k, p) in expected.psd.iter().enumerate() {
            let edge = k == 0 || k == 128;
            let level = if edge { 4.0 / 50.0 } else { 2.0 * 4.0 / 50.0 };
            assert!((p / level - 1.0).abs() < 1e-12, "bin {k}: {p} vs {level}");
        }
        assert_eq!(expected.segments, config.segment_count(4096));
    }

    #[test]
    fn expectation_equals_the_direct_double_sum_for_an_ar1_process() {
        // R(m) = phi^m / (1 - phi^2): the double sum over the window, written out, is the
        // definition; the FFT route must agree with it for every window.
        let phi: f64 = 0.93;
        let r = |m: usize| phi.powi(m as i32) / (1.0 - phi * phi);
        let (len, fs) = (64usize, 10.0);
        for window in [Window::Hann, Window::Rectangular, Window::Blackman] {
            let config = WelchConfig::new(len).with_window(window).with_detrend(Detrend::None);
            let fast = expected_welch_psd(r, 640, fs, &config).unwrap();
            let w = window.coefficients(len);
            let power: f64 = w.iter().map(|v| v * v).sum();
            for k in 0..=len / 2 {
                let theta = 2.0 * std::f64::consts::PI * k as f64 / len as f64;
                let mut total = 0.0;
                for s in 0..len {
                    for t in 0..len {
                        total += w[s] * w[t] * r(s.abs_diff(t)) * (theta * (s as f64 - t as f64)).cos();
                    }
                }
                let one_sided = if k == 0 || k == len / 2 { 1.0 } else { 2.0 };
                let direct = one_sided * total / (fs * power);
                assert!((fast.psd[k] / direct - 1.0).abs() < 1e-10, "{window:?} bin {k}: {} vs {direct}", fast.psd[k]);
            }
        }
    }

    #[test]
    fn averaged_estimates_of_an_ar1_record_converge_to_the_expectation() {
        // A strongly coloured record: near DC the Hann leakage makes the expectation differ
        // from the sampled spectrum, and the estimate must follow the expectation.
        let phi: f64 = 0.995;
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(17);
        let n = 1 << 20;
        let mut x = Vec::with_capacity(n);
        let mut state: f64 = StandardNormal.sample(&mut rng);
        state /= (1.0 - phi * phi).sqrt();
        for _ in 0..n {
            let e: f64 = StandardNormal.sample(&mut rng);
            state = phi * state + e;
            x.push(state);
        }
        let config = WelchConfig::new(512).with_detrend(Detrend::None);
        let estimate = welch_psd(&x, 1.0, &config).unwrap();
        let expected = expected_welch_psd(|m| phi.powi(m as i32) / (1.0 - phi * phi), n, 1.0, &config).unwrap();
        // 4095 segments: each bin's relative standard error is about sqrt(2 / dof) = 2.6 %, so
        // the bins 1-8 (where leakage matters most) pooled are within a few per cent.
        let pooled_estimate: f64 = estimate.psd[1..9].iter().sum();
        let pooled_expected: f64 = expected.psd[1..9].iter().sum();
        let standard_error = (2.0 / expected.dof).sqrt();
        assert!(
            (pooled_estimate / pooled_expected - 1.0).abs() < 4.0 * standard_error,
            "{pooled_estimate} vs {pooled_expected}"
        );
    }

    #[test]
    fn detrended_configurations_are_refused() {
        let config = WelchConfig::new(64);
        assert!(expected_welch_psd(|_| 1.0, 640, 1.0, &config).is_err());
    }
}
