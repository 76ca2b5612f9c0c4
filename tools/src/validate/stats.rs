//! Residual statistics as a control engineer reads them: RMS and NRMSE fit, autocorrelation
//! with its whiteness test, cross-correlation with the inputs, the effective number of
//! independent samples of a coloured residual, a residual spectrum, and the chi-squared tail
//! probability the effect tests use.
// TODO(lead): move autocorrelation, Welch PSD and the chi-squared functions to dsp (the dsp
// helper's versions can replace these one for one once `pub mod dsp` is in lib.rs).

/// Root mean square.
pub fn rms(x: &[f64]) -> f64 {
    if x.is_empty() {
        return f64::NAN;
    }
    (x.iter().map(|v| v * v).sum::<f64>() / x.len() as f64).sqrt()
}

/// NRMSE fit in percent, as system identification tools report it:
/// 100 (1 - ||residual|| / ||measured - mean(measured)||). 100 % is a perfect fit, 0 % no better
/// than the mean, negative worse.
pub fn nrmse_fit_percent(measured: &[f64], residual: &[f64]) -> f64 {
    let mean = measured.iter().sum::<f64>() / measured.len().max(1) as f64;
    let spread = measured.iter().map(|m| (m - mean).powi(2)).sum::<f64>().sqrt();
    let error = residual.iter().map(|r| r * r).sum::<f64>().sqrt();
    if spread == 0.0 {
        return f64::NAN;
    }
    100.0 * (1.0 - error / spread)
}

/// Normalised autocorrelation for lags 0..=max_lag (mean removed; lag 0 is 1).
pub fn autocorrelation(x: &[f64], max_lag: usize) -> Vec<f64> {
    let n = x.len();
    let mean = x.iter().sum::<f64>() / n.max(1) as f64;
    let centred: Vec<f64> = x.iter().map(|v| v - mean).collect();
    let c0: f64 = centred.iter().map(|v| v * v).sum();
    if c0 == 0.0 {
        return vec![1.0; max_lag.min(n.saturating_sub(1)) + 1];
    }
    (0..=max_lag.min(n.saturating_sub(1))).map(|k| centred[..n - k].iter().zip(&centred[k..]).map(|(a, b)| a * b).sum::<f64>() / c0).collect()
}

/// Normalised cross-correlation rho_xy(k) = corr(x(t), y(t + k)) for k in -max_lag..=max_lag.
pub fn cross_correlation(x: &[f64], y: &[f64], max_lag: usize) -> Vec<(isize, f64)> {
    let n = x.len().min(y.len());
    let mx = x[..n].iter().sum::<f64>() / n as f64;
    let my = y[..n].iter().sum::<f64>() / n as f64;
    let sx = x[..n].iter().map(|v| (v - mx).powi(2)).sum::<f64>().sqrt();
    let sy = y[..n].iter().map(|v| (v - my).powi(2)).sum::<f64>().sqrt();
    let max_lag = max_lag.min(n.saturating_sub(1)) as isize;
    (-max_lag..=max_lag)
        .map(|k| {
            let mut s = 0.0;
            for i in 0..n as isize {
                let j = i + k;
                if j >= 0 && j < n as isize {
                    s += (x[i as usize] - mx) * (y[j as usize] - my);
                }
            }
            (k, if sx > 0.0 && sy > 0.0 { s / (sx * sy) } else { 0.0 })
        })
        .collect()
}

/// Integrated autocorrelation time tau = 1 + 2 sum rho_k, summed until the autocorrelation
/// first drops below zero (the initial positive sequence; Geyer 1992). A white residual has
/// tau = 1; a residual correlated over m samples has about m. n / tau is the effective number
/// of independent samples, which keeps tests honest on coloured residuals.
pub fn correlation_time(x: &[f64]) -> f64 {
    let max_lag = (x.len() / 4).max(1);
    let mut lag_block = 64usize.min(max_lag);
    loop {
        let rho = autocorrelation(x, lag_block);
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

/// Ljung-Box whiteness test on lags 1..=lags: returns (Q, p-value). Small p: not white.
pub fn ljung_box(x: &[f64], lags: usize) -> (f64, f64) {
    let n = x.len() as f64;
    let rho = autocorrelation(x, lags);
    let q: f64 = rho.iter().enumerate().skip(1).map(|(k, r)| r * r / (n - k as f64)).sum::<f64>() * n * (n + 2.0);
    (q, chi_squared_sf(q, (rho.len() - 1) as f64))
}

/// Fraction of autocorrelation lags 1..=lags outside the 95 % whiteness band +-1.96/sqrt(n).
pub fn fraction_outside_whiteness_band(x: &[f64], lags: usize) -> f64 {
    let bound = 1.96 / (x.len() as f64).sqrt();
    let rho = autocorrelation(x, lags);
    rho[1..].iter().filter(|r| r.abs() > bound).count() as f64 / (rho.len() - 1).max(1) as f64
}

/// Welch power spectral density (one-sided, per Hz, Hann window, 50 % overlap).
/// Returns (frequencies, psd).
pub fn welch_psd(x: &[f64], sample_rate: f64, segment: usize) -> (Vec<f64>, Vec<f64>) {
    use rustfft::{num_complex::Complex64, FftPlanner};
    let segment = segment.min(x.len()).max(8);
    let step = segment / 2;
    let window: Vec<f64> = (0..segment).map(|i| 0.5 - 0.5 * (2.0 * std::f64::consts::PI * i as f64 / segment as f64).cos()).collect();
    let power: f64 = window.iter().map(|w| w * w).sum();
    let fft = FftPlanner::new().plan_fft_forward(segment);
    let bins = segment / 2 + 1;
    let mut psd = vec![0.0; bins];
    let mut count = 0;
    let mut start = 0;
    while start + segment <= x.len() {
        let chunk = &x[start..start + segment];
        let mean = chunk.iter().sum::<f64>() / segment as f64;
        let mut buffer: Vec<Complex64> = chunk.iter().zip(&window).map(|(v, w)| Complex64::new((v - mean) * w, 0.0)).collect();
        fft.process(&mut buffer);
        for (k, p) in psd.iter_mut().enumerate() {
            let scale = if k == 0 || (segment % 2 == 0 && k == segment / 2) { 1.0 } else { 2.0 };
            *p += scale * buffer[k].norm_sqr() / (power * sample_rate);
        }
        count += 1;
        start += step;
    }
    for p in &mut psd {
        *p /= count.max(1) as f64;
    }
    let freqs = (0..bins).map(|k| k as f64 * sample_rate / segment as f64).collect();
    (freqs, psd)
}

/// Upper tail probability of the chi-squared distribution, P(X > x) with `dof` degrees of
/// freedom, through the regularised incomplete gamma function (Numerical Recipes 6.2).
pub fn chi_squared_sf(x: f64, dof: f64) -> f64 {
    if x <= 0.0 {
        return 1.0;
    }
    let a = 0.5 * dof;
    let z = 0.5 * x;
    if z < a + 1.0 {
        // Series for P(a, z).
        let mut term = 1.0 / a;
        let mut sum = term;
        let mut ap = a;
        for _ in 0..10_000 {
            ap += 1.0;
            term *= z / ap;
            sum += term;
            if term.abs() < sum.abs() * 1e-15 {
                break;
            }
        }
        let p = sum * (-z + a * z.ln() - ln_gamma(a)).exp();
        (1.0 - p).clamp(0.0, 1.0)
    } else {
        // Continued fraction for Q(a, z) (modified Lentz).
        let tiny = 1e-300;
        let mut b = z + 1.0 - a;
        let mut c = 1.0 / tiny;
        let mut d = 1.0 / b;
        let mut h = d;
        for i in 1..10_000 {
            let an = -(i as f64) * (i as f64 - a);
            b += 2.0;
            d = an * d + b;
            if d.abs() < tiny {
                d = tiny;
            }
            c = b + an / c;
            if c.abs() < tiny {
                c = tiny;
            }
            d = 1.0 / d;
            let delta = d * c;
            h *= delta;
            if (delta - 1.0).abs() < 1e-15 {
                break;
            }
        }
        ((-z + a * z.ln() - ln_gamma(a)).exp() * h).clamp(0.0, 1.0)
    }
}

/// ln Gamma(x) for x > 0 (Lanczos, g = 7).
pub fn ln_gamma(x: f64) -> f64 {
    const C: [f64; 9] = [
        0.999_999_999_999_809_9,
        676.520_368_121_885_1,
        -1_259.139_216_722_402_8,
        771.323_428_777_653_1,
        -176.615_029_162_140_6,
        12.507_343_278_686_905,
        -0.138_571_095_265_720_1,
        9.984_369_578_019_572e-6,
        1.505_632_735_149_311_6e-7,
    ];
    if x < 0.5 {
        let pi = std::f64::consts::PI;
        return (pi / (pi * x).sin()).abs().ln() - ln_gamma(1.0 - x);
    }
    let x = x - 1.0;
    let mut sum = C[0];
    for (i, c) in C.iter().enumerate().skip(1) {
        sum += c / (x + i as f64);
    }
    let t = x + 7.5;
    0.5 * (2.0 * std::f64::consts::PI).ln() + (x + 0.5) * t.ln() - t + sum.ln()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn chi_squared_tail_matches_known_values() {
        // Tabulated: P(chi2_1 > 3.841) = 0.05, P(chi2_10 > 23.209) = 0.01, P(chi2_2 > x) = e^(-x/2).
        assert!((chi_squared_sf(3.841_458_8, 1.0) - 0.05).abs() < 1e-6);
        assert!((chi_squared_sf(23.209_251, 10.0) - 0.01).abs() < 1e-6);
        assert!((chi_squared_sf(7.0, 2.0) - (-3.5f64).exp()).abs() < 1e-12);
    }

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
        assert!(ljung_box(&white, 20).1 > 0.001);
        assert!(ljung_box(&smoothed, 20).1 < 1e-6);
    }

    #[test]
    fn nrmse_fit_is_100_for_a_perfect_model_and_0_for_the_mean() {
        let y = [1.0, 2.0, 3.0, 4.0];
        assert_eq!(nrmse_fit_percent(&y, &[0.0; 4]), 100.0);
        assert!((nrmse_fit_percent(&y, &[-1.5, -0.5, 0.5, 1.5])).abs() < 1e-12);
    }

    #[test]
    fn welch_psd_integrates_to_the_variance() {
        let x: Vec<f64> = (0..8192).map(|i| 2.0 * (i as f64 * 0.3).sin()).collect();
        let (f, p) = welch_psd(&x, 100.0, 1024);
        let df = f[1] - f[0];
        let power: f64 = p.iter().sum::<f64>() * df;
        assert!((power - 2.0).abs() < 0.05, "{power}");
    }
}
