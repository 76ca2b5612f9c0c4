//! Residual statistics the validate tool needs beyond `antenna_dsp`: the integrated
//! autocorrelation time (the effective number of independent samples of a coloured residual)
//! and the NRMSE fit of a residual. Autocorrelation, cross-correlation, the whiteness test,
//! Welch spectra and the chi-squared distribution come from `antenna_dsp`.

/// NRMSE fit in percent of a residual against the measured signal it is the misfit of:
/// 100 (1 - ||residual|| / ||measured - mean(measured)||), as `dsp::nrmse_fit_percent` computes
/// it for a model; 100 % is a perfect fit, 0 % no better than the mean, negative worse.
pub fn nrmse_fit_percent(measured: &[f64], residual: &[f64]) -> f64 {
    let model: Vec<f64> = measured.iter().zip(residual).map(|(m, r)| m - r).collect();
    antenna_dsp::nrmse_fit_percent(measured, &model)
}

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
    let mut lag_block = 64usize.min(max_lag);
    loop {
        let Ok(rho) = antenna_dsp::autocorrelation(x, lag_block) else { return 1.0 };
        let mut tau = 1.0;
        let mut ended = false;
        for &r in &rho[1..] {
            if r <= 0.0 {
                ended = true;
                break;
            }
            tau += 2.0 * r;
        }
        if ended || lag_block >= max_lag {
            return tau.max(1.0);
        }
        lag_block = (lag_block * 4).min(max_lag);
    }
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

    #[test]
    fn nrmse_fit_is_100_for_a_perfect_model_and_0_for_the_mean() {
        let y = [1.0, 2.0, 3.0, 4.0];
        assert_eq!(nrmse_fit_percent(&y, &[0.0; 4]), 100.0);
        assert!((nrmse_fit_percent(&y, &[-1.5, -0.5, 0.5, 1.5])).abs() < 1e-12);
    }
}
