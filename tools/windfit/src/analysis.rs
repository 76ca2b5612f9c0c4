//! The whole analysis of one record, in order: statistics, Welch spectrum and bands, the
//! inertial-subrange fits, the kappa they imply, what the record cannot identify, and the gust
//! predictions and averaging-period summaries; [`WindAnalysis`] holds everything found.

use crate::config::WindFitConfig;
use crate::davenport::DavenportSpectrum;
use crate::error::WindFitError;
use crate::record::WindRecord;
use crate::spectrum_fit::{
    fit_level, fit_slope, identifiability, local_slopes, Identifiability, ImpliedDavenport, LevelFit, LocalSlope,
    SlopeFit,
};
use crate::statistics::{
    davenport_record_variance_per_kappa, interpolate_log_log, period_summaries, predict_gust, record_statistics,
    GustPrediction, PeriodSummary, RecordStatistics,
};
use antenna_dsp::{self, log_band_average, standard_normal_quantile, welch_psd, BandSpectrum, Spectrum, WelchConfig};

/// Everything the analysis found.
#[derive(Debug, Clone, PartialEq)]
pub struct WindAnalysis {
    /// Settings used.
    pub config: WindFitConfig,
    /// Source of the record.
    pub source: String,
    /// Speed column analysed.
    pub column: String,
    /// One-number statistics.
    pub statistics: RecordStatistics,
    /// Welch PSD.
    pub spectrum: Spectrum,
    /// Band-averaged PSD.
    pub bands: BandSpectrum,
    /// Free-slope fit over the inertial range.
    pub slope: SlopeFit,
    /// Level with the slope fixed at -5/3.
    pub level: LevelFit,
    /// Local slopes per half-decade.
    pub local_slopes: Vec<LocalSlope>,
    /// kappa and z0 from the level.
    pub implied: ImpliedDavenport,
    /// kappa for which Eq. 2's expected record variance equals the measured variance.
    pub kappa_from_variance: f64,
    /// kappa of the reference roughness (the paper's z0).
    pub kappa_reference: f64,
    /// Peak frequencies and identifiability.
    pub identifiability: Identifiability,
    /// Predicted record statistics: Eq. 2 (fitted, variance-matched, reference) and the
    /// measured spectrum.
    pub predictions: Vec<GustPrediction>,
    /// Turbulence intensity and gust factor per averaging period.
    pub periods: Vec<PeriodSummary>,
}

/// Runs the whole analysis on `record`.
pub fn analyse(record: &WindRecord, config: &WindFitConfig) -> Result<WindAnalysis, WindFitError> {
    config.validate()?;
    let fs = record.sample_rate_hz;
    let statistics = record_statistics(record, config)?;
    let v_mean = statistics.mean_m_s;

    let segment = config.segment_samples(record.speed_m_s.len(), fs);
    if segment < 64 {
        return Err(WindFitError::TooShort {
            reason: format!("{} samples give Welch segments of only {segment} samples", record.speed_m_s.len()),
        });
    }
    let spectrum = welch_psd(&record.speed_m_s, fs, &WelchConfig::new(segment))?;
    let bands = log_band_average(&spectrum, config.bands_per_decade)?;

    let band_hz = config.fit_band(v_mean, fs);
    let slope = fit_slope(&bands, band_hz, config.confidence)?;
    let level = fit_level(&bands, band_hz);

    let fitted = DavenportSpectrum::from_inertial_level(v_mean, level.level);
    let from_mean = 8.0 / 3.0 * statistics.mean_std_error_m_s / v_mean;
    let kappa_relative_error = level.level_relative_error.hypot(from_mean);
    let z = standard_normal_quantile(0.5 + 0.5 * config.confidence);
    let kappa_interval =
        (fitted.kappa * (-z * kappa_relative_error).exp(), fitted.kappa * (z * kappa_relative_error).exp());
    let height = config.effective_height_m();
    let implied = ImpliedDavenport {
        kappa: fitted.kappa,
        kappa_relative_error,
        kappa_relative_error_from_level: level.level_relative_error,
        kappa_relative_error_from_mean: from_mean,
        kappa_interval,
        z0_m: DavenportSpectrum::roughness_for_kappa(height, fitted.kappa),
        z0_interval_m: (
            DavenportSpectrum::roughness_for_kappa(height, kappa_interval.0),
            DavenportSpectrum::roughness_for_kappa(height, kappa_interval.1),
        ),
    };

    let duration = statistics.duration_s;
    let kappa_from_variance =
        statistics.std_m_s.powi(2) / davenport_record_variance_per_kappa(v_mean, duration, config.gust_window_s);
    let reference = DavenportSpectrum::from_roughness(v_mean, height, config.reference_z0_m);
    let upper = 1e3 / config.gust_window_s;
    let mut predictions = Vec::new();
    for (label, model) in [
        ("Eq. 2, kappa from the -5/3 level", fitted),
        (
            "Eq. 2, kappa matching the record variance",
            DavenportSpectrum { v_mean_m_s: v_mean, kappa: kappa_from_variance },
        ),
        ("Eq. 2, reference z0", reference),
    ] {
        let mut prediction = predict_gust(label, &|n| model.psd(n), v_mean, duration, config.gust_window_s, upper);
        prediction.kappa = model.kappa;
        predictions.push(prediction);
    }
    let (predictions, periods) = {
        let measured = interpolate_log_log(&bands.frequency_hz, &bands.psd);
        predictions.push(predict_gust(
            "measured spectrum (Gaussian)",
            &measured,
            v_mean,
            duration,
            config.gust_window_s,
            0.5 * fs,
        ));
        (predictions, period_summaries(record, config, &fitted, &measured, v_mean))
    };

    Ok(WindAnalysis {
        config: config.clone(),
        source: record.source.clone(),
        column: record.column.clone(),
        identifiability: identifiability(&statistics, &spectrum),
        local_slopes: local_slopes(&bands),
        statistics,
        spectrum,
        bands,
        slope,
        level,
        implied,
        kappa_from_variance,
        kappa_reference: reference.kappa,
        predictions,
        periods,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_records::*;
    use crate::*;

    #[test]
    fn records_that_cannot_be_analysed_are_errors_not_panics() {
        let config = WindFitConfig::new(10.0);
        let constant = WindRecord::from_samples("constant", vec![3.0; 20_000], 20.0);
        assert!(matches!(analyse(&constant, &config), Err(WindFitError::Dsp(_))), "{:?}", analyse(&constant, &config));
        let calm = WindRecord::from_samples("calm", vec![0.0; 20_000], 20.0);
        assert!(matches!(analyse(&calm, &config), Err(WindFitError::MeanSpeedNotPositive(mean)) if mean == 0.0));
        let short = synthetic_record(|f| 0.02 * f.powf(KOLMOGOROV_SLOPE), 4.0, 2.0, 20.0, 1);
        assert!(matches!(analyse(&short, &config), Err(WindFitError::TooShort { .. })));
        let mut bad = config.clone();
        bad.reference_z0_m = 20.0;
        let record = synthetic_record(|f| 0.02 * f.powf(KOLMOGOROV_SLOPE), 4.0, 600.0, 20.0, 2);
        assert!(matches!(analyse(&record, &bad), Err(WindFitError::RoughnessAboveHeight { .. })));
    }
}
