//! What a finite record of the gust must show: the autocovariance of a shaping filter, the
//! scatter of a record's sample variance, and seeded records. Used by the tests, the examples
//! and the wind-spectra tool; no part of the FMU's stepping.
//!
//! Everything here is exact for a filter in modal form: the autocovariance of the output is
//! `R(tau) = sum_i g_i exp(-p_i |tau|)` with `g_i = r_i sum_j q r_j / (p_i + p_j)`, from which
//! the variance of a record's sample variance follows in closed form, and the expected value of
//! a windowed spectral estimate through `antenna_dsp` ([`sampled_autocovariance`] is its
//! input). Spectral estimates and their confidence intervals are `antenna_dsp`'s; this crate
//! does not depend on it, so the FMU's library carries none of it.

use crate::shaping::{ShapingFilter, NOISE_INTENSITY};

/// The autocovariance weights `g_i` of `R(tau) = sum_i g_i exp(-p_i |tau|)`.
pub fn autocovariance_weights(filter: &ShapingFilter) -> Vec<f64> {
    let (p, r) = (filter.rates(), filter.residues());
    (0..p.len()).map(|i| r[i] * (0..p.len()).map(|j| NOISE_INTENSITY * r[j] / (p[i] + p[j])).sum::<f64>()).collect()
}

/// The output autocovariance `R(tau)`.
pub fn autocovariance(filter: &ShapingFilter, tau: f64) -> f64 {
    autocovariance_weights(filter).iter().zip(filter.rates()).map(|(g, p)| g * (-p * tau.abs()).exp()).sum()
}

/// The autocovariance of records of `filter`'s output sampled every `step`, as a function of
/// the lag in samples: `R(m step)`, the form `antenna_dsp`'s exact spectral expectations take.
pub fn sampled_autocovariance(filter: &ShapingFilter, step: f64) -> impl Fn(usize) -> f64 {
    let weights = autocovariance_weights(filter);
    let rates = filter.rates().to_vec();
    move |lag| weights.iter().zip(&rates).map(|(g, p)| g * (-p * step * lag as f64).exp()).sum()
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
    fn sampled_autocovariance_is_the_autocovariance_at_whole_steps() {
        let f = ShapingFilter::davenport(&Davenport::new(9.5, 10.0, 0.4).unwrap());
        let sampled = sampled_autocovariance(&f, 0.05);
        for lag in [0usize, 1, 40, 2000] {
            let direct = autocovariance(&f, lag as f64 * 0.05);
            assert!((sampled(lag) / direct - 1.0).abs() < 1e-12, "lag {lag}: {} vs {direct}", sampled(lag));
        }
    }
}
