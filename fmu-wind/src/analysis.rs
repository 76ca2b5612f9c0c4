//! Statistics of generated gust records: spectral estimates with confidence intervals, and the
//! scatter that a finite record of a Davenport process must show. Used by the tests and the
//! `gust_statistics` example; no part of the FMU's stepping.
//!
//! Everything here is exact for a filter in modal form: the autocovariance of the output is
//! `R(tau) = sum_i g_i exp(-p_i |tau|)` with `g_i = r_i sum_j q r_j / (p_i + p_j)`, from which
//! the expected value of a windowed spectral estimate (leakage and aliasing included) and the
//! variance of a record's sample variance follow in closed form.

use crate::shaping::{ShapingFilter, NOISE_INTENSITY};
use std::f64::consts::PI;

/// The autocovariance weights `g_i` of `R(tau) = sum_i g_i exp(-p_i |tau|)`.
pub fn autocovariance_weights(filter: &ShapingFilter) -> Vec<f64> {
    let (p, r) = (filter.rates(), filter.residues());
    (0..p.len()).map(|i| r[i] * (0..p.len()).map(|j| NOISE_INTENSITY * r[j] / (p[i] + p[j])).sum::<f64>()).collect()
}

/// The output autocovariance `R(tau)`.
pub fn autocovariance(filter: &ShapingFilter, tau: f64) -> f64 {
    autocovariance_weights(filter).iter().zip(filter.rates()).map(|(g, p)| g * (-p * tau.abs()).exp()).sum()
}

/// `1 - (1 - exp(-x)) / x`, accurate for small `x`.
fn one_minus_mean_exp(x: f64) -> f64 {
    if x < 1e-4 {
        x / 2.0 - x * x / 6.0
    } else {
        1.0 + (-x).exp_m1() / x
    }
}

/// Standard deviation of the sample variance `(1/T) integral v^2 dt` of a zero-mean record of
/// length `duration`, for a Gaussian process: `Var = (4/T) integral_0^T (1 - tau/T) R(tau)^2 dtau`.
///
/// The Davenport process has eddies of many minutes, so a 2 h record holds few independent
/// samples: this is the scatter a test must allow, computed rather than guessed.
pub fn sample_variance_std(filter: &ShapingFilter, duration: f64) -> f64 {
    let g = autocovariance_weights(filter);
    let p = filter.rates();
    let mut var = 0.0;
    for i in 0..p.len() {
        for k in 0..p.len() {
            let a = p[i] + p[k];
            var += g[i] * g[k] * one_minus_mean_exp(a * duration) / a;
        }
    }
    (4.0 / duration * var).sqrt()
}

/// Standard deviation of the sample correlation coefficient of two independent records.
pub fn independent_correlation_std(filter: &ShapingFilter, duration: f64) -> f64 {
    sample_variance_std(filter, duration) / 2f64.sqrt() / filter.stationary_variance()
}

/// One spectral estimate.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SpectralEstimate {
    /// Frequency, Hz.
    pub frequency: f64,
    /// Welch estimate of the one-sided spectrum per hertz.
    pub psd: f64,
    /// Equivalent degrees of freedom (chi-square) of the estimate.
    pub dof: f64,
    /// Segment length in samples.
    pub segment: usize,
    /// Number of averaged segments.
    pub segments: usize,
}

/// The Hann window of length `n`.
fn hann(n: usize) -> Vec<f64> {
    (0..n).map(|k| 0.5 - 0.5 * (2.0 * PI * (k as f64 + 0.5) / n as f64).cos()).collect()
}

/// Segment length (samples) used at frequency `f`: `bins` cycles of `f` per segment.
pub fn segment_length(f: f64, step: f64, bins: f64) -> usize {
    (bins / (f * step)).round().max(8.0) as usize
}

/// Welch estimates of the one-sided spectrum per hertz at chosen frequencies.
///
/// Each frequency gets its own segment length, `bins` periods long (constant relative
/// resolution, as in the LPSD method of Troebs and Heinzel), a Hann window and 50 % overlap;
/// the DFT is evaluated at that one frequency. Frequencies whose segment would not fit 4 times
/// into the record are skipped. The degrees of freedom use the Hann 50 %-overlap correlation
/// 0.167 between neighbouring segments (Welch 1967).
pub fn welch_psd(samples: &[f64], step: f64, frequencies: &[f64], bins: f64) -> Vec<SpectralEstimate> {
    let mut out = Vec::new();
    for &f in frequencies {
        let len = segment_length(f, step, bins);
        if 4 * len > samples.len() {
            continue;
        }
        let window = hann(len);
        let norm: f64 = window.iter().map(|w| w * w).sum();
        let (c, s) = ((2.0 * PI * f * step).cos(), (2.0 * PI * f * step).sin());
        let hop = len / 2;
        let mut total = 0.0;
        let mut count = 0usize;
        let mut start = 0;
        while start + len <= samples.len() {
            // Rotating phasor instead of sin/cos per sample; renormalised each segment.
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
        let rho2 = 0.167f64 * 0.167;
        let dof = 2.0 * k * k / (k + 2.0 * (k - 1.0) * rho2);
        out.push(SpectralEstimate { frequency: f, psd: total / k, dof, segment: len, segments: count });
    }
    out
}

/// The exact expected value of [`welch_psd`]'s estimate for a record of `filter`'s output
/// sampled every `step`: window leakage and aliasing included.
///
/// With `R(m h) = sum_i g_i rho_i^|m|`, `rho_i = exp(-p_i h)`, the expected windowed
/// periodogram is `(2 h / sum w^2) sum_i g_i Re(2 sum_k w_k u_k - sum_k w_k^2)` where
/// `u_k = w_k + z_i u_(k-1)`, `z_i = rho_i exp(j 2 pi f h)`: one recursion per mode.
pub fn expected_welch_psd(filter: &ShapingFilter, step: f64, frequency: f64, bins: f64) -> f64 {
    let len = segment_length(frequency, step, bins);
    let window = hann(len);
    let norm: f64 = window.iter().map(|w| w * w).sum();
    let theta = 2.0 * PI * frequency * step;
    let g = autocovariance_weights(filter);
    let mut total = 0.0;
    for (gi, p) in g.iter().zip(filter.rates()) {
        let rho = (-p * step).exp();
        let (zr, zi) = (rho * theta.cos(), rho * theta.sin());
        let (mut ur, mut ui) = (0.0, 0.0);
        let mut acc = 0.0;
        for &w in &window {
            let t = w + zr * ur - zi * ui;
            ui = zr * ui + zi * ur;
            ur = t;
            acc += w * ur;
        }
        total += gi * (2.0 * acc - norm);
    }
    2.0 * step * total / norm
}

/// Standard normal quantile (Acklam's rational approximation, relative error below 1.2e-9).
#[allow(clippy::excessive_precision)] // Acklam's published coefficients, kept verbatim.
pub fn normal_quantile(p: f64) -> f64 {
    assert!(p > 0.0 && p < 1.0, "probability must be in (0, 1)");
    const A: [f64; 6] = [
        -3.969683028665376e1,
        2.209460984245205e2,
        -2.759285104469687e2,
        1.383577518672690e2,
        -3.066479806614716e1,
        2.506628277459239e0,
    ];
    const B: [f64; 5] =
        [-5.447609879822406e1, 1.615858368580409e2, -1.556989798598866e2, 6.680131188771972e1, -1.328068155288572e1];
    const C: [f64; 6] = [
        -7.784894002430293e-3,
        -3.223964580411365e-1,
        -2.400758277161838e0,
        -2.549732539343734e0,
        4.374664141464968e0,
        2.938163982698783e0,
    ];
    const D: [f64; 4] = [7.784695709041462e-3, 3.224671290700398e-1, 2.445134137142996e0, 3.754408661907416e0];
    let tail = |q: f64| {
        (((((C[0] * q + C[1]) * q + C[2]) * q + C[3]) * q + C[4]) * q + C[5])
            / ((((D[0] * q + D[1]) * q + D[2]) * q + D[3]) * q + 1.0)
    };
    if p < 0.02425 {
        tail((-2.0 * p.ln()).sqrt())
    } else if p > 1.0 - 0.02425 {
        -tail((-2.0 * (1.0 - p).ln()).sqrt())
    } else {
        let q = p - 0.5;
        let r = q * q;
        (((((A[0] * r + A[1]) * r + A[2]) * r + A[3]) * r + A[4]) * r + A[5]) * q
            / (((((B[0] * r + B[1]) * r + B[2]) * r + B[3]) * r + B[4]) * r + 1.0)
    }
}

/// Chi-square quantile by the Wilson-Hilferty approximation (good to ~1 % for dof >= 10).
pub fn chi_square_quantile(dof: f64, p: f64) -> f64 {
    let a = 2.0 / (9.0 * dof);
    dof * (1.0 - a + normal_quantile(p) * a.sqrt()).powi(3)
}

/// The two-sided `confidence` interval of a spectral estimate with `dof` degrees of freedom, as
/// factors on the true value: the estimate lies within `[lo S, hi S]` with that probability.
pub fn psd_interval(dof: f64, confidence: f64) -> (f64, f64) {
    let alpha = 1.0 - confidence;
    (chi_square_quantile(dof, alpha / 2.0) / dof, chi_square_quantile(dof, 1.0 - alpha / 2.0) / dof)
}

/// Generates `duration` seconds of gust at step `step` with `seed`.
pub fn record(filter: &ShapingFilter, seed: u64, step: f64, duration: f64) -> Vec<f64> {
    let mut generator = crate::gust::GustGenerator::new(filter.clone(), seed);
    let n = (duration / step).round() as usize;
    (0..n).map(|_| generator.step(step)).collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::davenport::Davenport;

    #[test]
    fn normal_and_chi_square_quantiles_match_tabulated_values() {
        assert!((normal_quantile(0.975) - 1.959964).abs() < 1e-6);
        assert!((normal_quantile(0.005) + 2.575829).abs() < 1e-6);
        // chi2(0.975; 50) = 71.420, chi2(0.025; 50) = 32.357.
        assert!((chi_square_quantile(50.0, 0.975) / 71.420 - 1.0).abs() < 2e-3);
        assert!((chi_square_quantile(50.0, 0.025) / 32.357 - 1.0).abs() < 5e-3);
    }

    #[test]
    fn autocovariance_at_zero_is_the_stationary_variance() {
        let f = ShapingFilter::davenport(&Davenport::new(3.0, 10.0, 0.4).unwrap());
        assert!((autocovariance(&f, 0.0) / f.stationary_variance() - 1.0).abs() < 1e-9);
    }

    #[test]
    fn a_two_hour_record_at_3_m_per_s_scatters_by_about_four_percent() {
        // PHYSICS-NOTES point 8: about 4 % (1 sigma) at 3 m/s and 2.3 % at 9.5 m/s for the
        // sample standard deviation of a 2 h record.
        let rel = |v: f64| {
            let f = ShapingFilter::davenport(&Davenport::new(v, 10.0, 0.4).unwrap());
            0.5 * sample_variance_std(&f, 7200.0) / f.stationary_variance()
        };
        let (r3, r95) = (rel(3.0), rel(9.5));
        assert!((r3 - 0.04).abs() < 0.005, "3 m/s: {r3}");
        assert!((r95 - 0.023).abs() < 0.003, "9.5 m/s: {r95}");
    }

    #[test]
    fn expected_welch_estimate_is_close_to_the_true_spectrum_away_from_nyquist() {
        let f = ShapingFilter::davenport(&Davenport::new(9.5, 10.0, 0.4).unwrap());
        for freq in [0.01, 0.1, 1.0] {
            let expected = expected_welch_psd(&f, 0.01, freq, 16.0);
            let truth = f.psd_one_sided_per_hz(freq);
            assert!((expected / truth - 1.0).abs() < 0.03, "f = {freq}: {expected} vs {truth}");
        }
    }
}
