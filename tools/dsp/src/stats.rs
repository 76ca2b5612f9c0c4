//! Basic statistics of a record: moments, moving averages and RMS (gusts, worst windows),
//! straight-line and general least-squares fits with their uncertainties, and the NRMSE fit
//! percentage used to compare a model output with a measurement.
//!
//! Reductions of an empty slice return NaN; windowed functions return an empty result (or
//! `None`) when the window is empty or longer than the record.

use super::DspError;
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
        if (t - window + 1) % 4096 == 0 {
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

/// NRMSE fit in percent, 100 (1 - ||y - y_model|| / ||y - mean(y)||): 100 is a perfect fit,
/// 0 is no better than the measured mean, and it is negative for worse. NaN if the lengths
/// differ or the measurement is constant.
pub fn nrmse_fit_percent(measured: &[f64], model: &[f64]) -> f64 {
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
    super::check_finite(x)?;
    super::check_finite(y)
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

/// Result of a general linear least-squares fit y ~ A p.
#[derive(Debug, Clone, PartialEq)]
pub struct LeastSquaresFit {
    /// Fitted parameters p.
    pub parameters: Vec<f64>,
    /// Covariance of the parameters, s^2 (A^T A)^-1 with s^2 = RSS / (n - p).
    pub covariance: DMatrix<f64>,
    /// Root mean square of the residuals.
    pub residual_rms: f64,
}

impl LeastSquaresFit {
    /// Standard errors of the parameters (square roots of the covariance diagonal).
    pub fn std_errors(&self) -> Vec<f64> {
        (0..self.parameters.len()).map(|i| self.covariance[(i, i)].max(0.0).sqrt()).collect()
    }
}

/// Solves the linear least-squares problem `design * p ~ y` by SVD (robust to poorly scaled
/// columns) and returns the parameters with their covariance from the residual scatter.
/// `design` has one row per observation and one column per parameter.
pub fn least_squares(design: &DMatrix<f64>, y: &[f64]) -> Result<LeastSquaresFit, DspError> {
    let (rows, columns) = design.shape();
    if rows != y.len() {
        return Err(DspError::LengthMismatch { first: rows, second: y.len() });
    }
    if rows <= columns {
        return Err(DspError::TooShort { needed: columns + 1, got: rows });
    }
    super::check_finite(design.as_slice())?;
    super::check_finite(y)?;
    let svd = design.clone().svd(true, true);
    let largest = svd.singular_values.max();
    let tolerance = largest * rows.max(columns) as f64 * f64::EPSILON;
    if svd.singular_values.iter().any(|&s| s <= tolerance) {
        return Err(DspError::invalid(
            "design",
            "columns are linearly dependent, so the parameters are not identifiable",
        ));
    }
    let observations = DVector::from_column_slice(y);
    let parameters = svd.solve(&observations, tolerance).map_err(|e| DspError::invalid("design", e.to_string()))?;
    let residuals = &observations - design * &parameters;
    let rss = residuals.norm_squared();
    let s2 = rss / (rows - columns) as f64;
    let normal_inverse = (design.transpose() * design)
        .try_inverse()
        .ok_or_else(|| DspError::invalid("design", "normal matrix is singular"))?;
    Ok(LeastSquaresFit {
        parameters: parameters.iter().copied().collect(),
        covariance: normal_inverse * s2,
        residual_rms: (rss / rows as f64).sqrt(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_signals::white_noise;

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
    fn nrmse_fit_is_100_for_perfect_and_0_for_the_mean() {
        let y = [1.0, 3.0, 2.0, 5.0];
        assert!((nrmse_fit_percent(&y, &y) - 100.0).abs() < 1e-12);
        assert!(nrmse_fit_percent(&y, &[2.75; 4]).abs() < 1e-12);
        let half: Vec<f64> = y.iter().map(|v| 2.75 + 0.5 * (v - 2.75)).collect();
        assert!((nrmse_fit_percent(&y, &half) - 50.0).abs() < 1e-12);
        assert!(nrmse_fit_percent(&y, &[1.0]).is_nan());
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
    fn least_squares_fits_a_quadratic_and_rejects_dependent_columns() {
        let x: Vec<f64> = (0..50).map(|i| i as f64 / 10.0).collect();
        let noise = white_noise(50, 0.01, 34);
        let y: Vec<f64> = x.iter().zip(&noise).map(|(a, e)| 1.0 - 2.0 * a + 0.5 * a * a + e).collect();
        let design = DMatrix::from_fn(50, 3, |r, c| x[r].powi(c as i32));
        let fit = least_squares(&design, &y).unwrap();
        let errors = fit.std_errors();
        for (p, (estimate, error)) in [1.0, -2.0, 0.5].iter().zip(fit.parameters.iter().zip(&errors)) {
            assert!((estimate - p).abs() < 4.0 * error, "{estimate} vs {p} +- {error}");
        }
        let dependent = DMatrix::from_fn(50, 2, |r, _| x[r]);
        assert!(least_squares(&dependent, &y).is_err());
    }
}
