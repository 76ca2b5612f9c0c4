//! Fits to the band-averaged spectrum: the inertial-subrange slope and level with their
//! chi-squared weights, local slopes per half decade, and what the record's length lets the
//! spectrum identify of the Davenport peak.

use crate::davenport::DavenportSpectrum;
use crate::davenport::DAVENPORT_LENGTH_M;
use crate::error::WindFitError;
use crate::statistics::RecordStatistics;
use antenna_dsp::{
    self, digamma, standard_normal_quantile, trigamma, weighted_linear_regression, BandSpectrum, Spectrum,
};

/// The Kolmogorov inertial-subrange slope of a velocity spectrum.
pub const KOLMOGOROV_SLOPE: f64 = -5.0 / 3.0;

/// A straight-line fit of log10 PSD against log10 frequency over bands.
#[derive(Debug, Clone, PartialEq)]
pub struct SlopeFit {
    /// Fit range, Hz.
    pub band_hz: (f64, f64),
    /// Bands in the range.
    pub bands: usize,
    /// Raw Welch bins in those bands.
    pub raw_bins: usize,
    /// Fitted log-log slope.
    pub slope: f64,
    /// Its standard error (scaled up by the Birge ratio when the bands scatter more than their
    /// chi-squared statistics allow).
    pub slope_std_error: f64,
    /// Weighted residual sum of squares per degree of freedom.
    pub reduced_chi_squared: f64,
    /// (slope + 5/3) / standard error.
    pub deviation_from_kolmogorov_sigmas: f64,
    /// True when -5/3 lies inside the two-sided `confidence` interval of the slope.
    pub consistent_with_kolmogorov: bool,
    /// Frequency at which the fitted level is quoted (the weighted centre of the fit), Hz.
    pub pivot_hz: f64,
    /// Fitted PSD at the pivot, (m/s)^2/Hz.
    pub psd_at_pivot: f64,
}

/// The level of the inertial subrange with the slope fixed at -5/3.
#[derive(Debug, Clone, PartialEq)]
pub struct LevelFit {
    /// A in S(n) = A n^(-5/3), (m/s)^2 Hz^(2/3).
    pub level: f64,
    /// Relative standard error of A (from the band statistics, scaled by the Birge ratio).
    pub level_relative_error: f64,
    /// Weighted residual sum of squares per degree of freedom about the -5/3 line.
    pub reduced_chi_squared: f64,
}

/// What the inertial-subrange level implies for Eq. 2.
#[derive(Debug, Clone, PartialEq)]
pub struct ImpliedDavenport {
    /// kappa from the level.
    pub kappa: f64,
    /// Relative standard error of kappa: level and mean-speed parts combined.
    pub kappa_relative_error: f64,
    /// Part of the relative error from the level.
    pub kappa_relative_error_from_level: f64,
    /// Part from the uncertainty of the mean speed (kappa ~ v_m^(-8/3)).
    pub kappa_relative_error_from_mean: f64,
    /// `confidence` interval of kappa (log-normal).
    pub kappa_interval: (f64, f64),
    /// z0 at the effective height, m.
    pub z0_m: f64,
    /// z0 interval mapped from the kappa interval, m.
    pub z0_interval_m: (f64, f64),
}

/// Why the spectral peak (and so a full Davenport fit) is or is not identifiable.
#[derive(Debug, Clone, PartialEq)]
pub struct Identifiability {
    /// Peak of S(n), sqrt(3/5) v_m / L, Hz.
    pub peak_hz: f64,
    /// Peak of n S(n), sqrt(3) v_m / L, Hz.
    pub premultiplied_peak_hz: f64,
    /// v_m / (1200 sqrt 2), the formula quoted in the issue, Hz (a peak of neither).
    pub quoted_formula_hz: f64,
    /// 1 / record length, Hz.
    pub record_fundamental_hz: f64,
    /// Lowest non-zero Welch frequency, Hz.
    pub lowest_welch_hz: f64,
    /// Degrees of freedom there.
    pub lowest_welch_dof: f64,
    /// Record length in periods of the S(n) peak.
    pub peak_periods_in_record: f64,
    /// Fraction of Eq. 2's variance below the lowest Welch frequency (independent of kappa).
    pub variance_fraction_below_lowest_welch: f64,
    /// Record length that would resolve the peak with 3 Welch bins below it and 10 averaged
    /// half-overlapping segments (about +-3 dB at 95 %), s.
    pub record_needed_s: f64,
    /// True when the Welch estimate reaches below the S(n) peak with at least 3 bins.
    pub peak_identifiable: bool,
}

/// Local log-log slope over one half-decade.
#[derive(Debug, Clone, PartialEq)]
pub struct LocalSlope {
    /// Range, Hz.
    pub band_hz: (f64, f64),
    /// Slope.
    pub slope: f64,
    /// Standard error.
    pub std_error: f64,
}

/// log10 of the band PSDs with the chi-squared log bias removed, and their standard deviations.
/// E[ln(chi2_nu / nu)] = psi(nu/2) - ln(nu/2) and Var = psi'(nu/2), so bands with few degrees
/// of freedom neither drag the fit down nor count as much as the well-averaged ones.
fn log_band_values(bands: &BandSpectrum, selected: &[usize]) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
    let ln10 = std::f64::consts::LN_10;
    let mut x = Vec::new();
    let mut y = Vec::new();
    let mut sigma = Vec::new();
    for &i in selected {
        let half_dof = 0.5 * bands.dof[i];
        let bias = digamma(half_dof) - half_dof.ln();
        x.push(bands.frequency_hz[i].log10());
        y.push((bands.psd[i].ln() - bias) / ln10);
        sigma.push(trigamma(half_dof).sqrt() / ln10);
    }
    (x, y, sigma)
}

fn bands_in(bands: &BandSpectrum, (low, high): (f64, f64)) -> Vec<usize> {
    (0..bands.len()).filter(|&i| bands.frequency_hz[i] >= low && bands.frequency_hz[i] <= high).collect()
}

pub(crate) fn fit_slope(bands: &BandSpectrum, band_hz: (f64, f64), confidence: f64) -> Result<SlopeFit, WindFitError> {
    let selected = bands_in(bands, band_hz);
    if selected.len() < 4 {
        return Err(WindFitError::TooShort {
            reason: format!(
                "the fit range {:.3}..{:.3} Hz holds {} log-frequency bands, at least 4 are needed for a slope with an uncertainty",
                band_hz.0,
                band_hz.1,
                selected.len()
            ),
        });
    }
    let (x, y, sigma) = log_band_values(bands, &selected);
    let fit = weighted_linear_regression(&x, &y, &sigma)?;
    let weights: Vec<f64> = sigma.iter().map(|s| 1.0 / (s * s)).collect();
    let pivot_log = x.iter().zip(&weights).map(|(a, w)| a * w).sum::<f64>() / weights.iter().sum::<f64>();
    let deviation = (fit.slope - KOLMOGOROV_SLOPE) / fit.slope_std_error;
    let z = standard_normal_quantile(0.5 + 0.5 * confidence);
    Ok(SlopeFit {
        band_hz,
        bands: selected.len(),
        raw_bins: selected.iter().map(|&i| bands.bins[i]).sum(),
        slope: fit.slope,
        slope_std_error: fit.slope_std_error,
        reduced_chi_squared: fit.reduced_chi_squared.unwrap_or(f64::NAN),
        deviation_from_kolmogorov_sigmas: deviation,
        consistent_with_kolmogorov: deviation.abs() <= z,
        pivot_hz: 10f64.powf(pivot_log),
        psd_at_pivot: 10f64.powf(fit.predict(pivot_log)),
    })
}

pub(crate) fn fit_level(bands: &BandSpectrum, band_hz: (f64, f64)) -> LevelFit {
    let selected = bands_in(bands, band_hz);
    let (x, y, sigma) = log_band_values(bands, &selected);
    // log10 A = log10 S + (5/3) log10 n for every band; the weighted mean is the estimate.
    let compensated: Vec<f64> = x.iter().zip(&y).map(|(a, b)| b - KOLMOGOROV_SLOPE * a).collect();
    let weights: Vec<f64> = sigma.iter().map(|s| 1.0 / (s * s)).collect();
    let total: f64 = weights.iter().sum();
    let mean_log = compensated.iter().zip(&weights).map(|(c, w)| c * w).sum::<f64>() / total;
    let chi2: f64 = compensated.iter().zip(&weights).map(|(c, w)| w * (c - mean_log).powi(2)).sum();
    let reduced = chi2 / (selected.len() as f64 - 1.0).max(1.0);
    let log_error = (reduced.max(1.0) / total).sqrt();
    LevelFit {
        level: 10f64.powf(mean_log),
        level_relative_error: std::f64::consts::LN_10 * log_error,
        reduced_chi_squared: reduced,
    }
}

pub(crate) fn local_slopes(bands: &BandSpectrum) -> Vec<LocalSlope> {
    let (Some(&first), Some(&last)) = (bands.frequency_hz.first(), bands.frequency_hz.last()) else {
        return Vec::new();
    };
    let mut slopes = Vec::new();
    let mut exponent = (first.log10() * 2.0).floor() / 2.0;
    while exponent < last.log10() {
        let range = (10f64.powf(exponent), 10f64.powf(exponent + 0.5));
        let selected = bands_in(bands, range);
        if selected.len() >= 3 {
            let (x, y, sigma) = log_band_values(bands, &selected);
            if let Ok(fit) = weighted_linear_regression(&x, &y, &sigma) {
                slopes.push(LocalSlope { band_hz: range, slope: fit.slope, std_error: fit.slope_std_error });
            }
        }
        exponent += 0.5;
    }
    slopes
}

pub(crate) fn identifiability(statistics: &RecordStatistics, spectrum: &Spectrum) -> Identifiability {
    let v = statistics.mean_m_s;
    let model = DavenportSpectrum { v_mean_m_s: v, kappa: 1.0 };
    let peak_hz = model.peak_frequency_hz();
    let lowest_welch_hz = spectrum.resolution_hz();
    // To resolve a peak, the estimate needs a few bins below it (segments of at least 3 peak
    // periods) and enough segments for a usable confidence: 10 half-overlapped Hann segments
    // (19 dof, -2.4/+3.2 dB at 95 %) span (10 + 1) / 2 segment lengths.
    let segment_needed = 3.0 / peak_hz;
    Identifiability {
        peak_hz,
        premultiplied_peak_hz: model.premultiplied_peak_frequency_hz(),
        quoted_formula_hz: v / (DAVENPORT_LENGTH_M * 2f64.sqrt()),
        record_fundamental_hz: 1.0 / statistics.duration_s,
        lowest_welch_hz,
        lowest_welch_dof: spectrum.dof,
        peak_periods_in_record: statistics.duration_s * peak_hz,
        variance_fraction_below_lowest_welch: model.variance_below(lowest_welch_hz) / model.variance(),
        record_needed_s: 5.5 * segment_needed,
        peak_identifiable: 3.0 * lowest_welch_hz <= peak_hz,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_records::*;
    use crate::*;

    #[test]
    fn synthetic_power_law_slope_and_level_are_recovered_within_their_stated_uncertainty() {
        // Over many records the fitted slope and level must fall within 1.96 standard errors
        // of the truth about 95 % of the time: the uncertainty is neither too small nor
        // uselessly large. The spectrum flattens below 0.01 Hz (a finite variance, like real
        // wind) and is a -5/3 power law with level A well inside the fit range.
        let level = 0.02;
        let psd = move |f: f64| level * (f * f + 1e-4).powf(-5.0 / 6.0);
        let mut config = WindFitConfig::new(10.0);
        config.fit_band_hz = Some((0.25, 2.5));
        let (mut slope_inside, mut level_inside, mut slope_z_squares) = (0, 0, 0.0);
        let seeds = 40;
        for seed in 0..seeds {
            let record = synthetic_record(psd, 4.0, 1800.0, 20.0, 1000 + seed);
            let analysis = analyse(&record, &config).unwrap();
            let z = (analysis.slope.slope - KOLMOGOROV_SLOPE) / analysis.slope.slope_std_error;
            slope_z_squares += z * z;
            slope_inside += usize::from(z.abs() <= 1.96);
            let level_z = (analysis.level.level / level).ln() / analysis.level.level_relative_error;
            level_inside += usize::from(level_z.abs() <= 1.96);
            assert_eq!(analysis.slope.consistent_with_kolmogorov, z.abs() <= 1.96);
        }
        assert!(slope_inside >= 34, "slope within 1.96 sigma in {slope_inside} of {seeds} records");
        assert!(level_inside >= 34, "level within 1.96 sigma in {level_inside} of {seeds} records");
        let rms_z = (slope_z_squares / seeds as f64).sqrt();
        assert!(rms_z > 0.5, "slope errors are {rms_z} standard errors on average: the uncertainty is overstated");
    }

    #[test]
    fn a_slope_steeper_than_kolmogorov_is_reported_as_inconsistent() {
        let mut config = WindFitConfig::new(10.0);
        config.fit_band_hz = Some((0.25, 2.5));
        let record = synthetic_record(|f| 0.02 * f.powf(-2.2), 4.0, 1800.0, 20.0, 7);
        let analysis = analyse(&record, &config).unwrap();
        assert!((analysis.slope.slope + 2.2).abs() < 3.0 * analysis.slope.slope_std_error, "{:?}", analysis.slope);
        assert!(!analysis.slope.consistent_with_kolmogorov);
        assert!(report_markdown(&analysis, &[], &[]).contains("steeper by"));
    }

    #[test]
    fn kappa_and_z0_are_recovered_from_a_davenport_record() {
        let truth = DavenportSpectrum::from_roughness(10.0, 10.0, 0.05);
        let mut config = WindFitConfig::new(10.0);
        config.fit_band_hz = Some((0.25, 2.5));
        let record = synthetic_record(|n| truth.psd(n), truth.v_mean_m_s, 1800.0, 20.0, 11);
        let analysis = analyse(&record, &config).unwrap();
        let (low, high) = analysis.implied.kappa_interval;
        assert!(low < truth.kappa && truth.kappa < high, "kappa {} not in {low}..{high}", truth.kappa);
        let (z0_low, z0_high) = analysis.implied.z0_interval_m;
        assert!(z0_low < 0.05 && 0.05 < z0_high, "z0 interval {z0_low}..{z0_high}");
        // At 10 m/s the record spans 15 peak periods and resolves the peak.
        assert!(analysis.identifiability.peak_identifiable);
    }
}
