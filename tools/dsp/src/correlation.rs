//! Normalised auto- and cross-correlation (FFT-based, biased estimator) and whiteness tests
//! for model residuals.
//!
//! The biased estimator divides every lag by N rather than by the number of overlapping
//! samples N - k. It has lower variance, it is a positive semi-definite sequence, and it is
//! the one the +-1.96/sqrt(N) whiteness bounds and the Ljung-Box statistic are derived for.

use crate::distributions::{chi_squared_sf, standard_normal_quantile};
use crate::error::{check_finite, DspError};
use rustfft::num_complex::Complex64;
use rustfft::{Fft, FftPlanner};
use std::cell::RefCell;
use std::sync::Arc;

thread_local! {
    /// One planner per thread, which keeps the plans (and their twiddle factors) of every
    /// length it was asked for: the validation correlates records of the same few lengths
    /// thousands of times, and planning cost as much as the transforms. A planner returns the
    /// same algorithm for a length every time, so the results do not change.
    static PLANNER: RefCell<FftPlanner<f64>> = RefCell::new(FftPlanner::new());
}

/// The forward and inverse transforms of `len` points from this thread's planner.
fn plans(len: usize) -> (Arc<dyn Fft<f64>>, Arc<dyn Fft<f64>>) {
    PLANNER.with(|planner| {
        let mut planner = planner.borrow_mut();
        (planner.plan_fft_forward(len), planner.plan_fft_inverse(len))
    })
}

/// Normalised cross-correlation of two records at lags `-max_lag..=max_lag`.
#[derive(Debug, Clone, PartialEq)]
pub struct CrossCorrelation {
    /// Lags in samples; a positive lag k pairs `x[t]` with `y[t + k]` (y lagging x).
    pub lags: Vec<isize>,
    /// `r_xy(k) = sum_t (x[t] - mean x)(y[t + k] - mean y) / (N std x std y)`.
    pub values: Vec<f64>,
}

impl CrossCorrelation {
    /// The correlation at `lag`, if it was computed.
    pub fn at(&self, lag: isize) -> Option<f64> {
        let max_lag = *self.lags.last()?;
        if lag.abs() > max_lag {
            return None;
        }
        Some(self.values[(lag + max_lag) as usize])
    }

    /// The lag and value of the largest |r_xy|: the delay of y relative to x when y is a
    /// delayed, filtered copy of x.
    pub fn peak(&self) -> (isize, f64) {
        let index =
            (0..self.values.len()).max_by(|&a, &b| self.values[a].abs().total_cmp(&self.values[b].abs())).unwrap_or(0);
        (self.lags[index], self.values[index])
    }
}

/// Sum over t of (x[t] - mean x)(y[t + k] - mean y) for k = 0..len, and for negative k
/// stored at the end (circular index len' - |k|), computed with one zero-padded FFT each.
fn raw_cross_products(x: &[f64], y: &[f64]) -> (Vec<f64>, usize) {
    let n = x.len();
    let padded = (2 * n).next_power_of_two();
    let mean_x = x.iter().sum::<f64>() / n as f64;
    let mean_y = y.iter().sum::<f64>() / n as f64;
    let to_complex = |v: &[f64], mean: f64| {
        let mut buffer: Vec<Complex64> = v.iter().map(|&s| Complex64::new(s - mean, 0.0)).collect();
        buffer.resize(padded, Complex64::new(0.0, 0.0));
        buffer
    };
    let (forward, inverse) = plans(padded);
    let mut fx = to_complex(x, mean_x);
    forward.process(&mut fx);
    // An autocorrelation transforms its record once (the second transform would be the same).
    let same = std::ptr::eq(x, y);
    let fy = if same {
        None
    } else {
        let mut fy = to_complex(y, mean_y);
        forward.process(&mut fy);
        Some(fy)
    };
    // conj(X) Y transforms back to sum_t x[t] y[t + k]: the zero padding to at least 2N keeps
    // the circular correlation from wrapping around.
    let mut product: Vec<Complex64> = fx.iter().zip(fy.as_ref().unwrap_or(&fx)).map(|(a, b)| a.conj() * b).collect();
    inverse.process(&mut product);
    (product.iter().map(|c| c.re / padded as f64).collect(), padded)
}

fn check_correlation_input(x: &[f64], max_lag: usize) -> Result<(), DspError> {
    if x.len() < 2 {
        return Err(DspError::TooShort { needed: 2, got: x.len() });
    }
    if max_lag >= x.len() {
        return Err(DspError::invalid(
            "max_lag",
            format!("must be below the record length {}, got {max_lag}", x.len()),
        ));
    }
    check_finite(x)
}

/// Normalised autocorrelation r(k), k = 0..=max_lag, of `x` (mean removed, biased estimator,
/// r(0) = 1).
pub fn autocorrelation(x: &[f64], max_lag: usize) -> Result<Vec<f64>, DspError> {
    check_correlation_input(x, max_lag)?;
    let (raw, _) = raw_cross_products(x, x);
    if raw[0] <= 0.0 {
        return Err(DspError::ZeroVariance);
    }
    Ok(raw[..=max_lag].iter().map(|v| v / raw[0]).collect())
}

/// Normalised cross-correlation of sample-aligned `x` and `y` at lags `-max_lag..=max_lag`
/// (means removed, biased estimator). See [`CrossCorrelation`] for the sign of the lag.
pub fn cross_correlation(x: &[f64], y: &[f64], max_lag: usize) -> Result<CrossCorrelation, DspError> {
    if x.len() != y.len() {
        return Err(DspError::LengthMismatch { first: x.len(), second: y.len() });
    }
    check_correlation_input(x, max_lag)?;
    check_finite(y)?;
    let (raw, padded) = raw_cross_products(x, y);
    let norm = |v: &[f64]| {
        let mean = v.iter().sum::<f64>() / v.len() as f64;
        v.iter().map(|s| (s - mean).powi(2)).sum::<f64>()
    };
    let scale = (norm(x) * norm(y)).sqrt();
    if scale <= 0.0 {
        return Err(DspError::ZeroVariance);
    }
    let max = max_lag as isize;
    let lags: Vec<isize> = (-max..=max).collect();
    let values = lags
        .iter()
        .map(|&k| {
            let index = if k >= 0 { k as usize } else { padded - (-k) as usize };
            raw[index] / scale
        })
        .collect();
    Ok(CrossCorrelation { lags, values })
}

/// Half-width of the `confidence` band (e.g. 0.95) inside which the autocorrelation of white
/// noise of `samples` samples stays at each lag: z / sqrt(N), 1.96 / sqrt(N) for 95 %.
pub fn whiteness_bound(samples: usize, confidence: f64) -> f64 {
    standard_normal_quantile(0.5 + 0.5 * confidence) / (samples as f64).sqrt()
}

/// Summary of a whiteness test on a residual sequence.
#[derive(Debug, Clone, PartialEq)]
pub struct WhitenessTest {
    /// Samples in the sequence.
    pub samples: usize,
    /// Lags 1..=max_lag tested.
    pub max_lag: usize,
    /// The 95 % bound 1.96 / sqrt(N).
    pub bound_95: f64,
    /// Lags whose |r(k)| exceeds the bound (about 5 % of them for white noise).
    pub lags_outside: usize,
    /// lags_outside / max_lag.
    pub fraction_outside: f64,
    /// Ljung-Box portmanteau statistic Q = N (N + 2) sum_k r(k)^2 / (N - k).
    pub ljung_box_q: f64,
    /// Degrees of freedom of Q: max_lag minus the parameters fitted to produce the residuals.
    pub dof: usize,
    /// Probability that white noise gives a Q at least this large.
    pub p_value: f64,
}

impl WhitenessTest {
    /// True when the Ljung-Box test does not reject whiteness at `significance` (e.g. 0.05).
    pub fn is_white(&self, significance: f64) -> bool {
        self.p_value >= significance
    }
}

/// Tests whether `residuals` are white: counts autocorrelation lags 1..=max_lag outside the
/// 95 % bounds and computes the Ljung-Box statistic and its p-value (chi-squared with
/// max_lag - fitted_parameters degrees of freedom; pass the number of model parameters
/// estimated from the same data, or 0 for a raw sequence).
pub fn whiteness_test(residuals: &[f64], max_lag: usize, fitted_parameters: usize) -> Result<WhitenessTest, DspError> {
    if max_lag == 0 {
        return Err(DspError::invalid("max_lag", "must be at least 1"));
    }
    if fitted_parameters >= max_lag {
        return Err(DspError::invalid(
            "fitted_parameters",
            format!("must be below max_lag ({max_lag}) to leave degrees of freedom, got {fitted_parameters}"),
        ));
    }
    let r = autocorrelation(residuals, max_lag)?;
    let n = residuals.len() as f64;
    let bound_95 = whiteness_bound(residuals.len(), 0.95);
    let lags_outside = r[1..].iter().filter(|v| v.abs() > bound_95).count();
    let ljung_box_q = n * (n + 2.0) * (1..=max_lag).map(|k| r[k] * r[k] / (n - k as f64)).sum::<f64>();
    let dof = max_lag - fitted_parameters;
    Ok(WhitenessTest {
        samples: residuals.len(),
        max_lag,
        bound_95,
        lags_outside,
        fraction_outside: lags_outside as f64 / max_lag as f64,
        ljung_box_q,
        dof,
        p_value: chi_squared_sf(ljung_box_q, dof as f64),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_signals::white_noise;

    #[test]
    fn autocorrelation_matches_the_direct_biased_sum() {
        let x = white_noise(300, 1.0, 21);
        let r = autocorrelation(&x, 20).unwrap();
        let mean = x.iter().sum::<f64>() / 300.0;
        let c0: f64 = x.iter().map(|v| (v - mean).powi(2)).sum();
        for (k, rk) in r.iter().enumerate() {
            let direct: f64 = (0..300 - k).map(|t| (x[t] - mean) * (x[t + k] - mean)).sum::<f64>() / c0;
            assert!((rk - direct).abs() < 1e-12, "lag {k}");
        }
        assert_eq!(r[0], 1.0);
    }

    #[test]
    fn autocorrelation_of_white_noise_stays_inside_the_bounds() {
        let x = white_noise(10_000, 1.0, 22);
        let test = whiteness_test(&x, 50, 0).unwrap();
        assert!((test.bound_95 - 1.959_964 / 100.0).abs() < 1e-6);
        assert!(test.fraction_outside <= 0.12, "{test:?}");
        assert!(test.is_white(0.01), "{test:?}");
    }

    #[test]
    fn coloured_noise_fails_the_whiteness_test() {
        let e = white_noise(5_000, 1.0, 23);
        let mut x = vec![0.0; e.len()];
        for t in 1..e.len() {
            x[t] = 0.3 * x[t - 1] + e[t];
        }
        let test = whiteness_test(&x, 20, 0).unwrap();
        assert!(test.p_value < 1e-6, "{test:?}");
        let r = autocorrelation(&x, 1).unwrap();
        // An AR(1) process with coefficient 0.3 has r(1) = 0.3.
        assert!((r[1] - 0.3).abs() < 3.0 / (5_000f64).sqrt());
    }

    #[test]
    fn ljung_box_p_values_are_uniform_for_white_noise() {
        // Under the null hypothesis about 10 % of p-values fall below 0.1.
        let below = (0..200)
            .filter(|seed| whiteness_test(&white_noise(2_000, 1.0, 300 + seed), 10, 0).unwrap().p_value < 0.1)
            .count();
        assert!((8..=35).contains(&below), "{below} of 200 p-values below 0.1");
    }

    #[test]
    fn cross_correlation_finds_a_delay_and_its_sign() {
        let x = white_noise(4_000, 1.0, 24);
        let delay = 7;
        let y: Vec<f64> = (0..x.len()).map(|t| if t >= delay { 2.0 * x[t - delay] } else { 0.0 }).collect();
        let c = cross_correlation(&x, &y, 20).unwrap();
        let (lag, value) = c.peak();
        assert_eq!(lag, 7);
        assert!(value > 0.99);
        assert!(c.at(-7).unwrap().abs() < 0.1);
        assert_eq!(c.at(21), None);
    }

    #[test]
    fn degenerate_inputs_are_errors() {
        assert_eq!(autocorrelation(&[1.0, 1.0, 1.0], 1), Err(DspError::ZeroVariance));
        assert!(autocorrelation(&[1.0, 2.0], 2).is_err());
        assert!(whiteness_test(&white_noise(100, 1.0, 1), 5, 5).is_err());
    }
}
