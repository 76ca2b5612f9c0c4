//! Welch estimates at chosen frequencies with constant relative resolution (the LPSD method of
//! Troebs and Heinzel, 2006), and their exact expectation for a process of known
//! autocovariance.
//!
//! An FFT-based Welch estimate has one segment length, so its resolution is the same number of
//! hertz at every frequency: too coarse at the lowest frequencies of a wind spectrum, needlessly
//! fine (and noisy) at the highest. Here each frequency gets its own segment, a fixed number of
//! its periods long, and the DFT is evaluated at that one frequency, so every estimate has
//! about the same relative resolution and many more averaged segments at high frequencies.
//! Conventions are those of the crate: one-sided densities per Hz, Hann windows normalised by
//! their power, 50 % overlap.

use crate::window::Window;
use std::f64::consts::PI;

/// The Hann correlation between neighbouring 50 %-overlapped segments (Welch 1967), which sets
/// the equivalent degrees of freedom of an average of overlapped segments.
const HANN_HALF_OVERLAP_CORRELATION: f64 = 0.167;

/// One estimate of [`lpsd`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FrequencyEstimate {
    /// Frequency, Hz.
    pub frequency_hz: f64,
    /// Estimate of the one-sided spectrum per hertz.
    pub psd: f64,
    /// Equivalent degrees of freedom (chi-squared) of the estimate.
    pub dof: f64,
    /// Segment length in samples.
    pub segment_len: usize,
    /// Number of averaged segments.
    pub segments: usize,
}

/// Segment length (samples) used at `frequency_hz`: `cycles` periods of that frequency, at
/// least 8 samples.
pub fn lpsd_segment_len(frequency_hz: f64, sample_rate_hz: f64, cycles: f64) -> usize {
    (cycles * sample_rate_hz / frequency_hz).round().max(8.0) as usize
}

/// Welch estimates of the one-sided spectrum per hertz at `frequencies_hz`, each from segments
/// `cycles` periods long (Hann window, 50 % overlap).
///
/// Frequencies whose segment would not fit 4 times into the record are skipped, so the result
/// may be shorter than `frequencies_hz`. The degrees of freedom use the Hann 50 %-overlap
/// correlation between neighbouring segments.
pub fn lpsd(samples: &[f64], sample_rate_hz: f64, frequencies_hz: &[f64], cycles: f64) -> Vec<FrequencyEstimate> {
    let step = 1.0 / sample_rate_hz;
    let mut out = Vec::new();
    for &f in frequencies_hz {
        let len = lpsd_segment_len(f, sample_rate_hz, cycles);
        if 4 * len > samples.len() {
            continue;
        }
        let window = Window::Hann.coefficients(len);
        let norm: f64 = window.iter().map(|w| w * w).sum();
        let (c, s) = ((2.0 * PI * f * step).cos(), (2.0 * PI * f * step).sin());
        let hop = len / 2;
        let mut total = 0.0;
        let mut count = 0usize;
        let mut start = 0;
        while start + len <= samples.len() {
            // A rotating phasor instead of a sine and cosine per sample; it restarts at 1 for
            // each segment, so its rounding cannot accumulate over the record.
            let (mut re, mut im) = (0.0, 0.0);
            let (mut pr, mut pi) = (1.0, 0.0);
            for (w, x) in window.iter().zip(&samples[start..start + len]) {
                re += w * x * pr;
                im -= w * x * pi;
                let t = pr * c - pi * s;
                pi = pr * s + pi * c;
                pr = t;
            }
            total += 2.0 * step * (re * re + im * im) / norm;
            count += 1;
            start += hop;
        }
        let k = count as f64;
        let rho2 = HANN_HALF_OVERLAP_CORRELATION * HANN_HALF_OVERLAP_CORRELATION;
        let dof = 2.0 * k * k / (k + 2.0 * (k - 1.0) * rho2);
        out.push(FrequencyEstimate { frequency_hz: f, psd: total / k, dof, segment_len: len, segments: count });
    }
    out
}

/// The exact expected value of [`lpsd`]'s estimate at `frequency_hz` for a zero-mean stationary
/// process with autocovariance `autocovariance(m)` at a lag of `m` samples: window leakage and
/// aliasing included.
///
/// With `c(m) = sum_t w_t w_(t+m)`, the expected windowed periodogram at angle `theta` per
/// sample is `(2 / (fs sum w^2)) (R(0) c(0) + 2 sum_(m >= 1) R(m) c(m) cos(theta m))`.
pub fn expected_lpsd(
    autocovariance: impl Fn(usize) -> f64,
    sample_rate_hz: f64,
    frequency_hz: f64,
    cycles: f64,
) -> f64 {
    let len = lpsd_segment_len(frequency_hz, sample_rate_hz, cycles);
    let window = Window::Hann.coefficients(len);
    let lag_products = crate::expectation::window_lag_products(&window);
    let theta = 2.0 * PI * frequency_hz / sample_rate_hz;
    let sum: f64 = (1..len).map(|m| autocovariance(m) * lag_products[m] * (theta * m as f64).cos()).sum();
    2.0 * (autocovariance(0) * lag_products[0] + 2.0 * sum) / (sample_rate_hz * lag_products[0])
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_signals::white_noise;

    #[test]
    fn segments_hold_the_requested_number_of_periods() {
        assert_eq!(lpsd_segment_len(0.5, 20.0, 8.0), 320);
        assert_eq!(lpsd_segment_len(100.0, 20.0, 8.0), 8);
    }

    #[test]
    fn white_noise_expectation_is_twice_the_variance_over_the_sample_rate() {
        let expected = expected_lpsd(|m| if m == 0 { 4.0 } else { 0.0 }, 50.0, 3.0, 8.0);
        assert!((expected / (2.0 * 4.0 / 50.0) - 1.0).abs() < 1e-12, "{expected}");
    }

    #[test]
    fn expectation_of_an_ar1_process_equals_the_direct_double_sum() {
        let phi: f64 = 0.9;
        let r = |m: usize| phi.powi(m as i32) / (1.0 - phi * phi);
        let (fs, f, cycles) = (10.0, 0.7, 6.0);
        let len = lpsd_segment_len(f, fs, cycles);
        let w = Window::Hann.coefficients(len);
        let power: f64 = w.iter().map(|v| v * v).sum();
        let theta = 2.0 * PI * f / fs;
        let mut total = 0.0;
        for s in 0..len {
            for t in 0..len {
                total += w[s] * w[t] * r(s.abs_diff(t)) * (theta * (s as f64 - t as f64)).cos();
            }
        }
        let direct = 2.0 * total / (fs * power);
        let fast = expected_lpsd(r, fs, f, cycles);
        assert!((fast / direct - 1.0).abs() < 1e-10, "{fast} vs {direct}");
    }

    #[test]
    fn white_noise_estimates_lie_in_their_confidence_band() {
        let (fs, sigma) = (20.0, 1.5);
        let x = white_noise(200_000, sigma, 41);
        let frequencies: Vec<f64> = (0..20).map(|i| 0.05 * 1.3f64.powi(i)).collect();
        let estimates = lpsd(&x, fs, &frequencies, 8.0);
        assert!(estimates.len() > 15);
        let level = 2.0 * sigma * sigma / fs;
        let outside = estimates
            .iter()
            .filter(|e| {
                let (low, high) =
                    crate::distributions::ChiSquaredInterval::new(e.dof, 0.99).unwrap().estimate_factors();
                !(low..=high).contains(&(e.psd / level))
            })
            .count();
        assert!(outside <= 1, "{outside} of {} outside their 99 % band", estimates.len());
        // A record too short for 4 segments at the lowest frequency skips it.
        assert!(lpsd(&x[..1000], fs, &[0.05, 5.0], 8.0).len() == 1);
    }
}
