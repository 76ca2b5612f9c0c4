//! Statistics of the record in the time domain (moments, integral time scale, gusts, block
//! summaries per averaging period) and what Eq. 2 or a measured spectrum predicts for them.

use crate::config::WindFitConfig;
use crate::davenport::DavenportSpectrum;
use crate::error::WindFitError;
use crate::record::WindRecord;
use antenna_dsp as dsp;
use antenna_dsp::{
    self, autocorrelation, kurtosis_excess, max_moving_average, moving_average, skewness, window_samples,
};
use fmu_wind::davenport::{peak_factor, GustMoments};

/// One-number statistics of the record.
#[derive(Debug, Clone, PartialEq)]
pub struct RecordStatistics {
    /// Samples.
    pub samples: usize,
    /// Sample rate, Hz.
    pub sample_rate_hz: f64,
    /// Length, s.
    pub duration_s: f64,
    /// Mean speed, m/s.
    pub mean_m_s: f64,
    /// Standard error of the mean from the integral time scale, m/s.
    pub mean_std_error_m_s: f64,
    /// Integral time scale (autocorrelation integrated to its first zero), s.
    pub integral_time_scale_s: f64,
    /// Standard deviation (population), m/s.
    pub std_m_s: f64,
    /// std / mean.
    pub turbulence_intensity: f64,
    /// Largest moving average over the gust window (the 3-s gust), m/s.
    pub gust_m_s: f64,
    /// Time at the start of the gust window, s.
    pub gust_time_s: f64,
    /// gust / mean.
    pub gust_factor: f64,
    /// Standard deviation of the gust-window moving average, m/s.
    pub gust_window_std_m_s: f64,
    /// (gust - mean) / gust_window_std: the observed peak factor.
    pub observed_peak_factor: f64,
    /// Skewness of the speed.
    pub skewness: f64,
    /// Excess kurtosis of the speed.
    pub kurtosis_excess: f64,
}

/// Predicted variance and gust statistics of a record of given length from a spectrum.
#[derive(Debug, Clone, PartialEq)]
pub struct GustPrediction {
    /// Which spectrum.
    pub label: String,
    /// kappa of the spectrum when it is Eq. 2, else NaN.
    pub kappa: f64,
    /// Expected standard deviation within a record of the averaging period, m/s.
    pub sigma_m_s: f64,
    /// sigma / v_m.
    pub turbulence_intensity: f64,
    /// Standard deviation of the gust-window moving average about the period mean, m/s.
    pub gust_window_sigma_m_s: f64,
    /// Mean zero up-crossing rate of that moving average, Hz.
    pub crossing_rate_hz: f64,
    /// Davenport's peak factor for that rate over the period.
    pub peak_factor: f64,
    /// Expected largest gust-window average, m/s.
    pub gust_m_s: f64,
    /// gust / v_m.
    pub gust_factor: f64,
}

/// Expected statistics of a stationary Gaussian wind record from its one-sided PSD `psd`
/// (per Hz) with mean `v_mean_m_s`, over an averaging period `period_s`, for gusts averaged
/// over `gust_window_s`, integrating the spectrum up to `upper_hz`.
///
/// The record's own mean removes the eddies slower than the record, so the variance is
/// `int S(n) (1 - sinc^2(pi n T)) dn`; the gust-window average adds the low-pass
/// `sinc^2(pi n tau)`. The expected maximum is `v_m + g sigma_tau`, with Davenport's (1964)
/// peak factor `g = sqrt(2 ln(nu T)) + 0.5772 / sqrt(2 ln(nu T))` and `nu` the zero
/// up-crossing rate `sqrt(m2 / m0)` of the averaged process (clamped at `nu T = e`).
/// The integral is `fmu_wind::davenport::GustMoments`, the one behind `expected_gust`, so a
/// generator's PSD passed here is comparable with the measured row.
pub fn predict_gust(
    label: &str,
    psd: &dyn Fn(f64) -> f64,
    v_mean_m_s: f64,
    period_s: f64,
    gust_window_s: f64,
    upper_hz: f64,
) -> GustPrediction {
    let moments = GustMoments::of_spectrum(psd, gust_window_s, period_s, upper_hz);
    let crossing_rate_hz = moments.crossing_rate_hz();
    let peak_factor = peak_factor(crossing_rate_hz, period_s);
    let gust_window_sigma_m_s = moments.m0.sqrt();
    let gust_m_s = v_mean_m_s + peak_factor * gust_window_sigma_m_s;
    let m_record = moments.record_variance;
    GustPrediction {
        label: label.to_string(),
        kappa: f64::NAN,
        sigma_m_s: m_record.sqrt(),
        turbulence_intensity: m_record.sqrt() / v_mean_m_s,
        gust_window_sigma_m_s,
        crossing_rate_hz,
        peak_factor,
        gust_m_s,
        gust_factor: gust_m_s / v_mean_m_s,
    }
}

/// The expected record variance of Eq. 2 per unit kappa, used to find the kappa that matches
/// the measured variance (the prediction is linear in kappa).
pub(crate) fn davenport_record_variance_per_kappa(v_mean_m_s: f64, period_s: f64, gust_window_s: f64) -> f64 {
    let unit = DavenportSpectrum { v_mean_m_s, kappa: 1.0 };
    let prediction = predict_gust("", &|n| unit.psd(n), v_mean_m_s, period_s, gust_window_s, 1e3 / gust_window_s);
    prediction.sigma_m_s.powi(2)
}

/// Statistics of one block of the record.
#[derive(Debug, Clone, PartialEq)]
pub struct BlockStatistics {
    /// Start time from the record start, s.
    pub start_s: f64,
    /// Mean speed, m/s.
    pub mean_m_s: f64,
    /// Standard deviation, m/s.
    pub std_m_s: f64,
    /// Largest gust-window average within the block, m/s.
    pub gust_m_s: f64,
}

impl BlockStatistics {
    /// std / mean.
    pub fn turbulence_intensity(&self) -> f64 {
        self.std_m_s / self.mean_m_s
    }

    /// gust / mean.
    pub fn gust_factor(&self) -> f64 {
        self.gust_m_s / self.mean_m_s
    }
}

/// Turbulence intensity and gust factor over non-overlapping blocks of one averaging period.
#[derive(Debug, Clone, PartialEq)]
pub struct PeriodSummary {
    /// Averaging period, s.
    pub period_s: f64,
    /// The blocks.
    pub blocks: Vec<BlockStatistics>,
    /// Expected gust factor from Eq. 2 with the kappa of the -5/3 level.
    pub predicted_gust_factor_fitted: f64,
    /// Expected gust factor from the measured spectrum.
    pub predicted_gust_factor_measured: f64,
}

impl PeriodSummary {
    /// Mean of the blocks' turbulence intensities.
    pub fn mean_turbulence_intensity(&self) -> f64 {
        dsp::mean(&self.blocks.iter().map(BlockStatistics::turbulence_intensity).collect::<Vec<_>>())
    }

    /// Mean of the blocks' gust factors.
    pub fn mean_gust_factor(&self) -> f64 {
        dsp::mean(&self.blocks.iter().map(BlockStatistics::gust_factor).collect::<Vec<_>>())
    }

    /// Largest block gust factor.
    pub fn max_gust_factor(&self) -> f64 {
        self.blocks.iter().map(BlockStatistics::gust_factor).fold(f64::NAN, f64::max)
    }
}

pub(crate) fn record_statistics(record: &WindRecord, config: &WindFitConfig) -> Result<RecordStatistics, WindFitError> {
    let speed = &record.speed_m_s;
    let fs = record.sample_rate_hz;
    let mean = dsp::mean(speed);
    if mean.is_nan() || mean <= 0.0 {
        return Err(WindFitError::MeanSpeedNotPositive(mean));
    }
    let std = dsp::std_dev(speed);
    let window = window_samples(config.gust_window_s, fs).max(1);
    let gust = max_moving_average(speed, window).ok_or_else(|| WindFitError::TooShort {
        reason: format!("{} samples do not hold one {} s gust window", speed.len(), config.gust_window_s),
    })?;
    let averaged = moving_average(speed, window);
    let gust_window_std = dsp::std_dev(&averaged);
    // Integral time scale: the autocorrelation integrated to its first zero crossing (the
    // usual estimator; beyond it the estimate is noise). The mean of a record of length T
    // then has variance sigma^2 2 T_int / T (Lenschow et al. 1994).
    let correlation = autocorrelation(speed, speed.len() / 2)?;
    let first_zero = correlation.iter().position(|r| *r <= 0.0).unwrap_or(correlation.len());
    let integral_time_scale_s = (correlation[..first_zero].iter().sum::<f64>() - 0.5) / fs;
    let duration = record.duration_s();
    Ok(RecordStatistics {
        samples: speed.len(),
        sample_rate_hz: fs,
        duration_s: duration,
        mean_m_s: mean,
        mean_std_error_m_s: std * (2.0 * integral_time_scale_s / duration).min(1.0).sqrt(),
        integral_time_scale_s,
        std_m_s: std,
        turbulence_intensity: std / mean,
        gust_m_s: gust.value,
        gust_time_s: record.time_s[gust.start] - record.time_s[0],
        gust_factor: gust.value / mean,
        gust_window_std_m_s: gust_window_std,
        observed_peak_factor: (gust.value - mean) / gust_window_std,
        skewness: skewness(speed),
        kurtosis_excess: kurtosis_excess(speed),
    })
}

/// A spectrum interpolated log-log between band values, constant beyond the ends (the record
/// high-pass in [`predict_gust`] takes care of the unresolved low end).
pub(crate) fn interpolate_log_log<'a>(frequency_hz: &'a [f64], psd: &'a [f64]) -> impl Fn(f64) -> f64 + 'a {
    move |n: f64| {
        if frequency_hz.is_empty() {
            return 0.0;
        }
        if n <= frequency_hz[0] {
            return psd[0];
        }
        if n >= frequency_hz[frequency_hz.len() - 1] {
            return psd[psd.len() - 1];
        }
        let i = frequency_hz.partition_point(|f| *f <= n);
        let (f0, f1) = (frequency_hz[i - 1].ln(), frequency_hz[i].ln());
        let t = (n.ln() - f0) / (f1 - f0);
        (psd[i - 1].ln() * (1.0 - t) + psd[i].ln() * t).exp()
    }
}

pub(crate) fn period_summaries(
    record: &WindRecord,
    config: &WindFitConfig,
    fitted: &DavenportSpectrum,
    measured: &dyn Fn(f64) -> f64,
    v_mean: f64,
) -> Vec<PeriodSummary> {
    let fs = record.sample_rate_hz;
    let window = window_samples(config.gust_window_s, fs).max(1);
    let mut summaries = Vec::new();
    for &period in &config.averaging_periods_s {
        let block_len = window_samples(period, fs);
        if block_len < window || block_len > record.speed_m_s.len() {
            continue;
        }
        let blocks = record
            .speed_m_s
            .chunks_exact(block_len)
            .enumerate()
            .filter_map(|(i, block)| {
                Some(BlockStatistics {
                    start_s: (i * block_len) as f64 / fs,
                    mean_m_s: dsp::mean(block),
                    std_m_s: dsp::std_dev(block),
                    gust_m_s: max_moving_average(block, window)?.value,
                })
            })
            .collect();
        let upper = 1e3 / config.gust_window_s;
        summaries.push(PeriodSummary {
            period_s: period,
            blocks,
            predicted_gust_factor_fitted: predict_gust(
                "",
                &|n| fitted.psd(n),
                v_mean,
                period,
                config.gust_window_s,
                upper,
            )
            .gust_factor,
            predicted_gust_factor_measured: predict_gust("", measured, v_mean, period, config.gust_window_s, 0.5 * fs)
                .gust_factor,
        });
    }
    summaries
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_records::*;
    use crate::*;
    use antenna_dsp::{self as dsp, moving_average};

    #[test]
    fn gust_prediction_matches_simulated_davenport_records() {
        // Expected record variance, 3-s-average variance and peak factor against the average
        // over simulated records. The simulated records have no power above their Nyquist
        // frequency, so the prediction integrates to there. Tolerances are three standard
        // errors of the simulated average, plus 5 % for the peak-factor formula, which is an
        // asymptotic approximation.
        let model = DavenportSpectrum::from_roughness(10.0, 10.0, 0.05);
        let period = 600.0;
        let fs = 10.0;
        let prediction = predict_gust("", &|n| model.psd(n), 10.0, period, 3.0, 0.5 * fs);
        let (mut variance, mut gust_variance, mut peak) = (Vec::new(), Vec::new(), Vec::new());
        for seed in 0..100 {
            let record = synthetic_record(|n| model.psd(n), 10.0, period, fs, 500 + seed);
            let averaged = moving_average(&record.speed_m_s, 30);
            let mean = dsp::mean(&record.speed_m_s);
            variance.push(dsp::variance(&record.speed_m_s));
            gust_variance.push(dsp::variance(&averaged));
            peak.push((averaged.iter().copied().fold(f64::MIN, f64::max) - mean) / prediction.gust_window_sigma_m_s);
        }
        let check = |values: &[f64], expected: f64, model_tolerance: f64, what: &str| {
            let mean = dsp::mean(values);
            let standard_error = dsp::sample_variance(values).sqrt() / (values.len() as f64).sqrt();
            assert!(
                (mean - expected).abs() < 3.0 * standard_error + model_tolerance * expected,
                "{what}: simulated {mean} +- {standard_error}, predicted {expected}"
            );
        };
        check(&variance, prediction.sigma_m_s.powi(2), 0.0, "record variance");
        check(&gust_variance, prediction.gust_window_sigma_m_s.powi(2), 0.0, "3-s average variance");
        check(&peak, prediction.peak_factor, 0.05, "peak factor");
    }

    #[test]
    fn averaging_period_summary_covers_whole_blocks() {
        let record = synthetic_record(|f| 0.02 * f.powf(KOLMOGOROV_SLOPE), 5.0, 1800.0, 20.0, 3);
        let analysis = analyse(&record, &WindFitConfig::new(10.0)).unwrap();
        let counts: Vec<(f64, usize)> = analysis.periods.iter().map(|p| (p.period_s, p.blocks.len())).collect();
        assert_eq!(counts, vec![(60.0, 30), (300.0, 6), (600.0, 3), (1800.0, 1)]);
        let whole = &analysis.periods[3].blocks[0];
        assert!((whole.gust_m_s - analysis.statistics.gust_m_s).abs() < 1e-12);
        let csv = gust_summary_csv(&analysis);
        assert_eq!(csv.lines().count(), 1 + 30 + 6 + 3 + 1);
    }
}
