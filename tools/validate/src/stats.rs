//! The residual statistic the validate tool needs beyond `antenna_dsp`: the integrated
//! autocorrelation time (the effective number of independent samples of a coloured residual).
//! Autocorrelation, cross-correlation, the whiteness test, the fit percentage of a residual,
//! Welch spectra and the chi-squared distribution come from `antenna_dsp`.

/// Integrated autocorrelation time tau = 1 + 2 sum rho_k, summed until the autocorrelation
/// first drops below zero (the initial positive sequence; Geyer 1992). A white residual has
/// tau = 1; a residual correlated over m samples has about m. n / tau is the effective number
/// of independent samples, which keeps tests honest on coloured residuals. A constant record
/// has tau = 1.
pub fn correlation_time(x: &[f64]) -> f64 {
    let max_lag = (x.len() / 4).max(1).min(x.len().saturating_sub(1));
    if max_lag == 0 {
        return 1.0;
    }
    // One transform gives every lag, and a lag's value does not depend on how many are asked
    // for: the sum runs over the lags in order until the first that is not positive.
    let Ok(rho) = antenna_dsp::autocorrelation(x, max_lag) else { return 1.0 };
    let mut tau = 1.0;
    for &r in &rho[1..] {
        if r <= 0.0 {
            break;
        }
        tau += 2.0 * r;
    }
    f64::max(tau, 1.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn correlation_time_is_one_for_white_and_longer_for_smoothed_noise() {
        use rand::SeedableRng;
        use rand_distr::Distribution;
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
        let normal = rand_distr::Normal::new(0.0, 1.0).unwrap();
        let white: Vec<f64> = (0..20_000).map(|_| normal.sample(&mut rng)).collect();
        assert!((correlation_time(&white) - 1.0).abs() < 0.2, "{}", correlation_time(&white));
        // A 9-sample moving average has tau = 9 exactly (triangular autocorrelation).
        let smoothed: Vec<f64> = white.windows(9).map(|w| w.iter().sum::<f64>()).collect();
        let tau = correlation_time(&smoothed);
        assert!((tau - 9.0).abs() < 1.5, "{tau}");
        assert_eq!(correlation_time(&[2.0; 100]), 1.0);
    }
}
