//! Basic statistics of a record: moments, moving averages and RMS (gusts, worst windows),
//! straight-line fits with their uncertainties, the weighted linear least-squares solver every
//! identification uses, and the NRMSE fit percentage that compares a model output (or its
//! residual) with a measurement.
//!
//! Reductions of an empty slice return NaN; windowed functions return an empty result (or
//! `None`) when the window is empty or longer than the record.

use crate::error::DspError;
use nalgebra::{DMatrix, DVector};

/// Arithmetic mean.
pub fn mean(x: &[f64]) -> f64 {
    x.iter().sum::<f64>() / x.len() as f64
}

/// Population variance, the mean squared deviation from the mean (divides by N). This is the
/// variance a PSD integrates to.
pub fn variance(x: &[f64]) -> f64 {
    let m = mean(x);
    x.iter().map(|v| (v - m).powi(2)).sum::<f64>() / x.len() as f64
}

/// Unbiased sample variance (divides by N - 1); NaN for fewer than two samples.
pub fn sample_variance(x: &[f64]) -> f64 {
    if x.len() < 2 {
        return f64::NAN;
    }
    let m = mean(x);
    x.iter().map(|v| (v - m).powi(2)).sum::<f64>() / (x.len() - 1) as f64
}

/// Population standard deviation, sqrt of [`variance`].
pub fn std_dev(x: &[f64]) -> f64 {
    variance(x).sqrt()
}

/// Root mean square (about zero, not about the mean).
pub fn rms(x: &[f64]) -> f64 {
    (x.iter().map(|v| v * v).sum::<f64>() / x.len() as f64).sqrt()
}

/// Skewness, the third standardised moment (0 for a Gaussian).
pub fn skewness(x: &[f64]) -> f64 {
    let m = mean(x);
    let s = std_dev(x);
    x.iter().map(|v| ((v - m) / s).powi(3)).sum::<f64>() / x.len() as f64
}

/// Excess kurtosis, the fourth standardised moment minus 3 (0 for a Gaussian).
pub fn kurtosis_excess(x: &[f64]) -> f64 {
    let m = mean(x);
    let s = std_dev(x);
    x.iter().map(|v| ((v - m) / s).powi(4)).sum::<f64>() / x.len() as f64 - 3.0
}

/// The number of samples that spans `duration_s` at `sample_rate_hz`, rounded (e.g. 60 for a
/// 3-s window at 20 Hz).
pub fn window_samples(duration_s: f64, sample_rate_hz: f64) -> usize {
    (duration_s * sample_rate_hz).round().max(0.0) as usize
}

/// Sums of every run of `window` consecutive values, with a compensated running sum so a long
/// record does not accumulate rounding error.
fn moving_sums(x: &[f64], window: usize) -> Vec<f64> {
    if window == 0 || window > x.len() {
        return Vec::new();
    }
    let mut sums = Vec::with_capacity(x.len() - window + 1);
    let mut sum: f64 = x[..window].iter().sum();
    sums.push(sum);
    for t in window..x.len() {
        sum += x[t] - x[t - window];
        // Re-sum exactly now and then so the running update cannot drift.
        if (t - window + 1).is_multiple_of(4096) {
            sum = x[t + 1 - window..=t].iter().sum();
        }
        sums.push(sum);
    }
    sums
}

/// Trailing-edge moving average: entry i is the mean of `x[i..i + window]`, so the result has
/// `len - window + 1` entries (only whole windows). A 3-s gust is the maximum of the moving
/// average over 3 s of samples.
pub fn moving_average(x: &[f64], window: usize) -> Vec<f64> {
    moving_sums(x, window).into_iter().map(|s| s / window as f64).collect()
}

/// Moving RMS over whole windows of `window` samples (entry i covers `x[i..i + window]`).
pub fn moving_rms(x: &[f64], window: usize) -> Vec<f64> {
    let squares: Vec<f64> = x.iter().map(|v| v * v).collect();
    moving_sums(&squares, window).into_iter().map(|s| (s.max(0.0) / window as f64).sqrt()).collect()
}

/// Moving RMS of a two-component signal about each window's own mean: entry i is
/// `sqrt(var(x[i..i + window].0) + var(x[i..i + window].1))`, the population variances. For a
/// pointing error on the sky (cross-elevation, elevation) this is the jitter after centring:
/// what is left when the offset that persists over the window is taken out.
///
/// The sums run about the whole record's mean, so that a large common offset does not cost the
/// small variances their digits.
pub fn moving_centred_rms(x: &[[f64; 2]], window: usize) -> Vec<f64> {
    if window == 0 || window > x.len() {
        return Vec::new();
    }
    let n = x.len() as f64;
    let mut variance = vec![0.0; x.len() - window + 1];
    for axis in 0..2 {
        let overall = x.iter().map(|p| p[axis]).sum::<f64>() / n;
        let shifted: Vec<f64> = x.iter().map(|p| p[axis] - overall).collect();
        let squares: Vec<f64> = shifted.iter().map(|v| v * v).collect();
        let sums = moving_sums(&shifted, window);
        let square_sums = moving_sums(&squares, window);
        for ((v, s), q) in variance.iter_mut().zip(&sums).zip(&square_sums) {
            let mean = s / window as f64;
            *v += (q / window as f64 - mean * mean).max(0.0);
        }
    }
    variance.into_iter().map(f64::sqrt).collect()
}

/// Maximum of [`moving_centred_rms`] (the worst 10-s jitter after centring), or `None` if no
/// whole window fits.
pub fn max_moving_centred_rms(x: &[[f64; 2]], window: usize) -> Option<WindowExtreme> {
    max_of(&moving_centred_rms(x, window))
}

/// The largest value of a windowed statistic and where its window starts.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WindowExtreme {
    /// Index of the first sample of the window.
    pub start: usize,
    /// The statistic over that window.
    pub value: f64,
}

fn max_of(values: &[f64]) -> Option<WindowExtreme> {
    values.iter().enumerate().max_by(|a, b| a.1.total_cmp(b.1)).map(|(start, &value)| WindowExtreme { start, value })
}

/// Maximum of the moving average (e.g. the 3-s gust), or `None` if no whole window fits.
pub fn max_moving_average(x: &[f64], window: usize) -> Option<WindowExtreme> {
    max_of(&moving_average(x, window))
}

/// Maximum of the moving RMS (e.g. the worst 10-s tracking error), or `None` if no whole
/// window fits.
pub fn max_moving_rms(x: &[f64], window: usize) -> Option<WindowExtreme> {
    max_of(&moving_rms(x, window))
}

/// NRMSE fit in percent of a model output against the measurement it models,
/// 100 (1 - ||measured - model|| / ||measured - mean(measured)||): 100 is a perfect fit, 0 is no
/// better than the measured mean, and it is negative for worse. NaN if the lengths differ or
/// the measurement is constant. For a residual instead of a model output, use
/// [`fit_percent_from_residual`].
pub fn fit_percent_from_model(measured: &[f64], model: &[f64]) -> f64 {
    if measured.len() != model.len() || measured.is_empty() {
        return f64::NAN;
    }
    let m = mean(measured);
    let error: f64 = measured.iter().zip(model).map(|(y, yhat)| (y - yhat).powi(2)).sum();
    let spread: f64 = measured.iter().map(|y| (y - m).powi(2)).sum();
    if spread == 0.0 {
        return f64::NAN;
    }
    100.0 * (1.0 - (error / spread).sqrt())
}

/// NRMSE fit in percent of a residual (measured minus model) against the measurement it is the
/// misfit of: 100 (1 - ||residual|| / ||measured - mean(measured)||), the same figure as
/// [`fit_percent_from_model`] for the model `measured - residual`.
///
/// The model is formed and the misfit taken from it, as the validation tool has always done,
/// rather than summing the squared residual directly: `measured - (measured - residual)` is not
/// always `residual` to the last bit, and the published validation figures come from this
/// round trip.
pub fn fit_percent_from_residual(measured: &[f64], residual: &[f64]) -> f64 {
    let model: Vec<f64> = measured.iter().zip(residual).map(|(m, r)| m - r).collect();
    fit_percent_from_model(measured, &model)
}

/// A fitted straight line y = intercept + slope x with its uncertainties.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LineFit {
    /// Fitted slope.
    pub slope: f64,
    /// Fitted value at x = 0.
    pub intercept: f64,
    /// Standard error of the slope.
    pub slope_std_error: f64,
    /// Standard error of the intercept.
    pub intercept_std_error: f64,
    /// Covariance of slope and intercept.
    pub covariance: f64,
    /// Root mean square of the residuals (unweighted).
    pub residual_rms: f64,
    /// For a weighted fit: the weighted residual sum of squares over its degrees of freedom,
    /// about 1 when the stated uncertainties and the straight line both hold.
    pub reduced_chi_squared: Option<f64>,
    /// Number of points.
    pub points: usize,
}

impl LineFit {
    /// The fitted value at `x`.
    pub fn predict(&self, x: f64) -> f64 {
        self.intercept + self.slope * x
    }

    /// Standard error of the fitted value at `x` (uses the slope-intercept covariance).
    pub fn prediction_std_error(&self, x: f64) -> f64 {
        (self.intercept_std_error.powi(2) + x * x * self.slope_std_error.powi(2) + 2.0 * x * self.covariance)
            .max(0.0)
            .sqrt()
    }
}

fn check_line_input(x: &[f64], y: &[f64]) -> Result<(), DspError> {
    if x.len() != y.len() {
        return Err(DspError::LengthMismatch { first: x.len(), second: y.len() });
    }
    if x.len() < 3 {
        return Err(DspError::TooShort { needed: 3, got: x.len() });
    }
    crate::error::check_finite(x)?;
    crate::error::check_finite(y)
}

/// Ordinary least-squares straight line. The standard errors come from the residual scatter
/// (n - 2 degrees of freedom), so they include any misfit of the straight line.
pub fn linear_regression(x: &[f64], y: &[f64]) -> Result<LineFit, DspError> {
    check_line_input(x, y)?;
    let n = x.len() as f64;
    let x_mean = mean(x);
    let y_mean = mean(y);
    let sxx: f64 = x.iter().map(|v| (v - x_mean).powi(2)).sum();
    if sxx == 0.0 {
        return Err(DspError::invalid("x", "all x values are equal, so the slope is undefined"));
    }
    let sxy: f64 = x.iter().zip(y).map(|(a, b)| (a - x_mean) * (b - y_mean)).sum();
    let slope = sxy / sxx;
    let intercept = y_mean - slope * x_mean;
    let rss: f64 = x.iter().zip(y).map(|(a, b)| (b - intercept - slope * a).powi(2)).sum();
    let s2 = rss / (n - 2.0);
    let slope_var = s2 / sxx;
    Ok(LineFit {
        slope,
        intercept,
        slope_std_error: slope_var.sqrt(),
        intercept_std_error: (s2 * (1.0 / n + x_mean * x_mean / sxx)).sqrt(),
        covariance: -x_mean * slope_var,
        residual_rms: (rss / n).sqrt(),
        reduced_chi_squared: None,
        points: x.len(),
    })
}

/// Weighted least-squares straight line for points with standard deviations `sigma_y`.
///
/// The standard errors start from the stated `sigma_y` and are scaled up by
/// sqrt(reduced chi-squared) when the scatter about the line exceeds what those uncertainties
/// allow (the Birge ratio), so a curved spectrum or an underestimated sigma widens the
/// uncertainty instead of hiding behind it. They are never scaled down.
pub fn weighted_linear_regression(x: &[f64], y: &[f64], sigma_y: &[f64]) -> Result<LineFit, DspError> {
    check_line_input(x, y)?;
    if sigma_y.len() != x.len() {
        return Err(DspError::LengthMismatch { first: x.len(), second: sigma_y.len() });
    }
    if let Some(index) = sigma_y.iter().position(|s| !(*s > 0.0 && s.is_finite())) {
        return Err(DspError::invalid("sigma_y", format!("entry {index} must be positive and finite")));
    }
    let weights: Vec<f64> = sigma_y.iter().map(|s| 1.0 / (s * s)).collect();
    let sw: f64 = weights.iter().sum();
    let x_mean = x.iter().zip(&weights).map(|(a, w)| a * w).sum::<f64>() / sw;
    let y_mean = y.iter().zip(&weights).map(|(b, w)| b * w).sum::<f64>() / sw;
    let sxx: f64 = x.iter().zip(&weights).map(|(a, w)| w * (a - x_mean).powi(2)).sum();
    if sxx == 0.0 {
        return Err(DspError::invalid("x", "all x values are equal, so the slope is undefined"));
    }
    let sxy: f64 = x.iter().zip(y).zip(&weights).map(|((a, b), w)| w * (a - x_mean) * (b - y_mean)).sum();
    let slope = sxy / sxx;
    let intercept = y_mean - slope * x_mean;
    let residuals: Vec<f64> = x.iter().zip(y).map(|(a, b)| b - intercept - slope * a).collect();
    let chi2: f64 = residuals.iter().zip(&weights).map(|(r, w)| w * r * r).sum();
    let reduced = chi2 / (x.len() as f64 - 2.0);
    let inflation = reduced.max(1.0);
    let slope_var = inflation / sxx;
    Ok(LineFit {
        slope,
        intercept,
        slope_std_error: slope_var.sqrt(),
        intercept_std_error: (inflation * (1.0 / sw + x_mean * x_mean / sxx)).sqrt(),
        covariance: -x_mean * slope_var,
        residual_rms: (residuals.iter().map(|r| r * r).sum::<f64>() / x.len() as f64).sqrt(),
        reduced_chi_squared: Some(reduced),
        points: x.len(),
    })
}

/// Solves a small weighted least-squares problem `min sum w_i (y_i - X_i b)^2` through the
/// normal equations with columns scaled to unit norm and a pseudo-inverse, so collinear
/// columns give a finite (minimum-norm) answer instead of a failure. Returns the coefficients
/// and the inverse of the weighted normal matrix (the covariance when the weights are
/// 1/variance).
///
/// `columns` holds one regressor per entry, each as long as `y` and `weights`. Columns that are
/// zero over long stretches (hat functions of a slowly varying nuisance) are summed only where
/// they are not, which gives the same sums at a fraction of the cost.
pub fn weighted_least_squares(columns: &[Vec<f64>], y: &[f64], weights: &[f64]) -> (Vec<f64>, DMatrix<f64>) {
    let k = columns.len();
    if k == 0 {
        return (Vec::new(), DMatrix::zeros(0, 0));
    }
    let mut gram = DMatrix::<f64>::zeros(k, k);
    let mut rhs = DVector::<f64>::zeros(k);
    // Each column's runs of non-zero values: a column that is zero over most rows (a hat
    // function of a slowly varying nuisance) costs only where it is not, the same sums.
    let runs: Vec<Vec<(usize, usize)>> = columns.iter().map(|c| non_zero_runs(c)).collect();
    for a in 0..k {
        for b in a..k {
            let mut s = 0.0;
            let (mut i, mut j) = (0, 0);
            while i < runs[a].len() && j < runs[b].len() {
                let (start, end) = (runs[a][i].0.max(runs[b][j].0), runs[a][i].1.min(runs[b][j].1));
                if start < end {
                    s += columns[a][start..end]
                        .iter()
                        .zip(&columns[b][start..end])
                        .zip(&weights[start..end])
                        .map(|((x, z), w)| w * x * z)
                        .sum::<f64>();
                }
                if runs[a][i].1 <= runs[b][j].1 {
                    i += 1;
                } else {
                    j += 1;
                }
            }
            gram[(a, b)] = s;
            gram[(b, a)] = s;
        }
        rhs[a] = runs[a]
            .iter()
            .map(|&(start, end)| {
                columns[a][start..end]
                    .iter()
                    .zip(&y[start..end])
                    .zip(&weights[start..end])
                    .map(|((x, v), w)| w * x * v)
                    .sum::<f64>()
            })
            .sum();
    }
    let scale: Vec<f64> = (0..k).map(|a| if gram[(a, a)] > 0.0 { 1.0 / gram[(a, a)].sqrt() } else { 0.0 }).collect();
    let scaled = DMatrix::from_fn(k, k, |a, b| gram[(a, b)] * scale[a] * scale[b]);
    let svd = scaled.svd(true, true);
    let inverse_scaled = svd.pseudo_inverse(1e-10).unwrap_or_else(|_| DMatrix::zeros(k, k));
    let inverse = DMatrix::from_fn(k, k, |a, b| inverse_scaled[(a, b)] * scale[a] * scale[b]);
    let beta = &inverse * rhs;
    (beta.iter().copied().collect(), inverse)
}

/// The half-open index ranges where `x` is not zero, runs of zeros shorter than 64 samples
/// bridged (they cost less to sum than to skip).
fn non_zero_runs(x: &[f64]) -> Vec<(usize, usize)> {
    let mut runs: Vec<(usize, usize)> = Vec::new();
    for (i, v) in x.iter().enumerate() {
        if *v != 0.0 {
            match runs.last_mut() {
                Some(last) if i - last.1 < 64 => last.1 = i + 1,
                _ => runs.push((i, i + 1)),
            }
        }
    }
    runs
}

/// The Bartlett-weighted long-run sum of a record `g`: `sum over |l| <= lags of
/// (1 - |l|/(lags + 1)) sum_i g[i] g[i + l]`, the Newey-West estimate of the variance of the sum
/// of `g` (times nothing: the caller scales it).
///
/// The triangle is the self-convolution of a box of `lags + 1` samples, so the sum equals the
/// sum of the squared window sums of `g` over every window of `lags + 1` samples that overlaps
/// the record (cut at its ends), divided by `lags + 1`: one pass over the record whatever the
/// number of lags, where the lag-by-lag sums cost a pass per lag. As a sum of squares it is
/// never negative. The window sum slides by adding the entering and taking the leaving
/// sample, and is summed afresh every `RESUM` windows so rounding cannot build up along a long
/// record.
pub fn bartlett_long_run_sum(g: &[f64], lags: usize) -> f64 {
    const RESUM: usize = 4096;
    let n = g.len();
    if n == 0 {
        return 0.0;
    }
    let width = lags + 1;
    // Window k covers samples max(k, 0)..min(k + width, n) for k = -lags..n-1, written here
    // with k + lags as the index so that it stays unsigned.
    let bounds = |shifted: usize| (shifted.saturating_sub(lags), (shifted + 1).min(n));
    let mut total = 0.0;
    let mut window = 0.0;
    for shifted in 0..n + lags {
        let (first, end) = bounds(shifted);
        if shifted % RESUM == 0 {
            window = g[first..end].iter().sum();
        } else {
            if end > bounds(shifted - 1).1 {
                window += g[end - 1];
            }
            if first > bounds(shifted - 1).0 {
                window -= g[first - 1];
            }
        }
        total += window * window;
    }
    total / width as f64
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_signals::white_noise;

    #[test]
    fn bartlett_long_run_sum_equals_the_lag_by_lag_sum() {
        // The direct Newey-West sum, lag by lag, on noise with a mean and a slow part (so the
        // window sums do not cancel), for lag counts from none to beyond the record.
        let noise = white_noise(5000, 1.0, 11);
        let g: Vec<f64> = noise.iter().enumerate().map(|(i, v)| v + 0.3 + (i as f64 * 0.01).sin()).collect();
        for lags in [0, 1, 3, 17, 250, 4999, 7000] {
            let lag_sum = |l: usize| g.iter().zip(g.iter().skip(l)).map(|(a, b)| a * b).sum::<f64>();
            let direct = lag_sum(0)
                + (1..=lags.min(g.len() - 1))
                    .map(|l| 2.0 * (1.0 - l as f64 / (lags as f64 + 1.0)) * lag_sum(l))
                    .sum::<f64>();
            let fast = bartlett_long_run_sum(&g, lags);
            assert!((fast - direct).abs() <= 1e-11 * direct.abs(), "lags {lags}: {fast} against {direct}");
        }
        assert_eq!(bartlett_long_run_sum(&[], 5), 0.0);
        assert_eq!(bartlett_long_run_sum(&[2.0], 0), 4.0);
    }

    #[test]
    fn moments_of_a_known_sequence() {
        let x = [2.0, 4.0, 4.0, 4.0, 5.0, 5.0, 7.0, 9.0];
        assert_eq!(mean(&x), 5.0);
        assert_eq!(variance(&x), 4.0);
        assert_eq!(std_dev(&x), 2.0);
        assert!((sample_variance(&x) - 32.0 / 7.0).abs() < 1e-15);
        assert!((rms(&[3.0, -4.0]) - (12.5f64).sqrt()).abs() < 1e-15);
        assert!(mean(&[]).is_nan());
        assert!(skewness(&[1.0, 2.0, 3.0]).abs() < 1e-15);
    }

    #[test]
    fn gaussian_noise_has_no_skew_or_excess_kurtosis() {
        let x = white_noise(100_000, 1.0, 31);
        assert!(skewness(&x).abs() < 0.03);
        assert!(kurtosis_excess(&x).abs() < 0.06);
    }

    #[test]
    fn moving_average_covers_whole_windows_and_finds_the_gust() {
        let x = [1.0, 1.0, 1.0, 4.0, 4.0, 4.0, 1.0];
        let ma = moving_average(&x, 3);
        assert_eq!(ma.len(), 5);
        assert_eq!(ma[0], 1.0);
        assert_eq!(ma[3], 4.0);
        assert_eq!(max_moving_average(&x, 3), Some(WindowExtreme { start: 3, value: 4.0 }));
        assert!(moving_average(&x, 8).is_empty());
        assert_eq!(max_moving_average(&x, 0), None);
    }

    #[test]
    fn moving_average_stays_exact_over_a_long_record() {
        let x: Vec<f64> = (0..100_000).map(|t| 1e6 + (t % 7) as f64 * 0.1).collect();
        let ma = moving_average(&x, 7);
        // Every whole window of the period-7 pattern averages to 1e6 + 0.3.
        assert!(ma.iter().all(|v| (v - (1e6 + 0.3)).abs() < 1e-8));
    }

    #[test]
    fn moving_rms_finds_the_worst_window() {
        let mut x = vec![0.1; 1000];
        for v in &mut x[600..610] {
            *v = 2.0;
        }
        let worst = max_moving_rms(&x, 10).unwrap();
        assert_eq!(worst.start, 600);
        assert!((worst.value - 2.0).abs() < 1e-12);
        assert_eq!(moving_rms(&x, 10).len(), 991);
    }

    #[test]
    fn centred_rms_ignores_each_windows_offset_and_counts_its_spread() {
        // A large constant offset on both axes and a square wave of amplitude 0.5 on one: about
        // each window's mean the RMS is the wave's 0.5 wherever the window holds whole periods.
        let x: Vec<[f64; 2]> = (0..1000).map(|k| [1e4 + if k % 2 == 0 { 0.5 } else { -0.5 }, -3e3]).collect();
        let centred = moving_centred_rms(&x, 100);
        assert_eq!(centred.len(), 901);
        assert!(centred.iter().all(|v| (v - 0.5).abs() < 1e-9), "{:?}", &centred[..3]);
        // A step of 2 in the second component halfway through a window of 4 gives a spread of 1.
        let step: Vec<[f64; 2]> = (0..4).map(|k| [0.0, if k < 2 { 0.0 } else { 2.0 }]).collect();
        let worst = max_moving_centred_rms(&step, 4).unwrap();
        assert!((worst.value - 1.0).abs() < 1e-12 && worst.start == 0);
        assert!(max_moving_centred_rms(&step, 5).is_none());
    }

    #[test]
    fn fit_percent_is_100_for_a_perfect_model_and_0_for_the_mean() {
        let y = [1.0, 3.0, 2.0, 5.0];
        assert!((fit_percent_from_model(&y, &y) - 100.0).abs() < 1e-12);
        assert!(fit_percent_from_model(&y, &[2.75; 4]).abs() < 1e-12);
        let half: Vec<f64> = y.iter().map(|v| 2.75 + 0.5 * (v - 2.75)).collect();
        assert!((fit_percent_from_model(&y, &half) - 50.0).abs() < 1e-12);
        assert!(fit_percent_from_model(&y, &[1.0]).is_nan());
    }

    #[test]
    fn fit_percent_from_a_residual_is_100_for_zero_and_0_for_the_deviation_from_the_mean() {
        let y = [1.0, 2.0, 3.0, 4.0];
        assert_eq!(fit_percent_from_residual(&y, &[0.0; 4]), 100.0);
        assert!((fit_percent_from_residual(&y, &[-1.5, -0.5, 0.5, 1.5])).abs() < 1e-12);
        // The residual of a model is measured minus model: both forms give the same figure.
        let model = [1.5, 1.5, 3.5, 3.5];
        let residual: Vec<f64> = y.iter().zip(&model).map(|(a, b)| a - b).collect();
        assert_eq!(fit_percent_from_residual(&y, &residual), fit_percent_from_model(&y, &model));
    }

    #[test]
    fn line_fit_recovers_slope_within_its_standard_error() {
        let noise = white_noise(200, 0.5, 32);
        let x: Vec<f64> = (0..200).map(|i| i as f64 * 0.1).collect();
        let y: Vec<f64> = x.iter().zip(&noise).map(|(a, e)| 1.5 - 0.7 * a + e).collect();
        let fit = linear_regression(&x, &y).unwrap();
        // sigma / sqrt(sum (x - mean)^2) = 0.5 / sqrt(200 * 33.33) = 0.0061.
        assert!((fit.slope_std_error - 0.5 / (6666.5f64).sqrt()).abs() < 0.001);
        assert!((fit.slope + 0.7).abs() < 3.0 * fit.slope_std_error);
        assert!((fit.intercept - 1.5).abs() < 3.0 * fit.intercept_std_error);
        let sigma = vec![0.5; 200];
        let weighted = weighted_linear_regression(&x, &y, &sigma).unwrap();
        assert!((weighted.slope - fit.slope).abs() < 1e-12);
        assert!((weighted.reduced_chi_squared.unwrap() - 1.0).abs() < 0.25);
    }

    #[test]
    fn weighted_fit_inflates_errors_when_points_scatter_more_than_stated() {
        let noise = white_noise(100, 1.0, 33);
        let x: Vec<f64> = (0..100).map(f64::from).collect();
        let y: Vec<f64> = x.iter().zip(&noise).map(|(a, e)| 2.0 * a + e).collect();
        let honest = weighted_linear_regression(&x, &y, &vec![1.0; 100]).unwrap();
        let overconfident = weighted_linear_regression(&x, &y, &vec![0.1; 100]).unwrap();
        assert!(overconfident.reduced_chi_squared.unwrap() > 50.0);
        assert!((overconfident.slope_std_error / honest.slope_std_error - 1.0).abs() < 0.3);
    }

    #[test]
    fn least_squares_fits_a_quadratic_within_its_covariance() {
        let x: Vec<f64> = (0..50).map(|i| i as f64 / 10.0).collect();
        let noise = white_noise(50, 0.01, 34);
        let y: Vec<f64> = x.iter().zip(&noise).map(|(a, e)| 1.0 - 2.0 * a + 0.5 * a * a + e).collect();
        let columns: Vec<Vec<f64>> = (0..3).map(|c| x.iter().map(|v| v.powi(c)).collect()).collect();
        // Weights of 1/sigma^2 make the inverse normal matrix the parameters' covariance.
        let (parameters, covariance) = weighted_least_squares(&columns, &y, &[1e4; 50]);
        for (c, (estimate, truth)) in parameters.iter().zip([1.0, -2.0, 0.5]).enumerate() {
            let error = covariance[(c, c)].sqrt();
            assert!((estimate - truth).abs() < 4.0 * error, "{estimate} vs {truth} +- {error}");
        }
    }

    #[test]
    fn least_squares_recovers_coefficients_and_survives_collinearity() {
        let x1: Vec<f64> = (0..100).map(|i| i as f64).collect();
        let x2: Vec<f64> = (0..100).map(|i| ((i * 7) % 13) as f64).collect();
        let y: Vec<f64> = x1.iter().zip(&x2).map(|(a, b)| 2.0 * a - 0.5 * b).collect();
        let w = vec![1.0; 100];
        let (beta, _) = weighted_least_squares(&[x1.clone(), x2], &y, &w);
        assert!((beta[0] - 2.0).abs() < 1e-9 && (beta[1] + 0.5).abs() < 1e-9);
        let (beta, _) = weighted_least_squares(&[x1.clone(), x1.clone()], &x1, &w);
        assert!((beta[0] + beta[1] - 1.0).abs() < 1e-9);
    }

    #[test]
    fn least_squares_sums_only_the_non_zero_runs_of_sparse_columns() {
        // A hat function that is zero outside a short stretch must give the same answer as the
        // dense sums would.
        let n = 1000;
        let hat: Vec<f64> = (0..n)
            .map(|i| if (300..420).contains(&i) { 1.0 - ((i as f64 - 360.0) / 60.0).abs() } else { 0.0 })
            .collect();
        let ramp: Vec<f64> = (0..n).map(|i| i as f64 / n as f64).collect();
        let y: Vec<f64> = hat.iter().zip(&ramp).map(|(h, r)| 3.0 * h - 2.0 * r).collect();
        let (beta, _) = weighted_least_squares(&[hat, ramp], &y, &vec![1.0; n]);
        assert!((beta[0] - 3.0).abs() < 1e-9 && (beta[1] + 2.0).abs() < 1e-9, "{beta:?}");
        assert_eq!(non_zero_runs(&[0.0, 1.0, 0.0, 2.0, 0.0]), vec![(1, 4)]);
    }
}
