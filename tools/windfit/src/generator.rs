//! fmu-wind's gust generator beside the record: the exact spectrum of the Davenport shaping
//! filter for the fitted kappa and a generated record analysed like the measured one, with the
//! Markdown section that compares them.

use crate::analysis::{analyse, WindAnalysis};
use crate::config::WindFitConfig;
use crate::davenport::DavenportSpectrum;
use crate::error::WindFitError;
use crate::record::WindRecord;
use crate::statistics::{predict_gust, GustPrediction};
use antenna_dsp::{self, log_band_average, welch_psd, WelchConfig};
use std::fmt::Write as _;

/// A spectrum to draw over the measured one: a generated record analysed like the measured
/// one, or a model PSD. This is the hook for the fmu-wind gust generator.
#[derive(Debug, Clone, PartialEq)]
pub struct ComparisonCurve {
    /// Legend name.
    pub name: String,
    /// Frequencies, Hz.
    pub frequency_hz: Vec<f64>,
    /// One-sided PSD per Hz.
    pub psd: Vec<f64>,
}

impl ComparisonCurve {
    /// The band-averaged Welch PSD of a generated record, with the same segment length and
    /// bands as the measured analysis, so the two are directly comparable.
    pub fn from_record(
        name: &str,
        speed_m_s: &[f64],
        sample_rate_hz: f64,
        config: &WindFitConfig,
    ) -> Result<Self, WindFitError> {
        let segment = config.segment_samples(speed_m_s.len(), sample_rate_hz);
        let spectrum = welch_psd(speed_m_s, sample_rate_hz, &WelchConfig::new(segment))?;
        let bands = log_band_average(&spectrum, config.bands_per_decade)?;
        Ok(Self { name: name.to_string(), frequency_hz: bands.frequency_hz, psd: bands.psd })
    }

    /// A model PSD (e.g. `|n| generator.psd_one_sided_per_hz(n)`) evaluated at `frequency_hz`.
    pub fn from_psd(name: &str, frequency_hz: &[f64], psd: impl Fn(f64) -> f64) -> Self {
        Self {
            name: name.to_string(),
            frequency_hz: frequency_hz.to_vec(),
            psd: frequency_hz.iter().map(|&n| psd(n)).collect(),
        }
    }
}

/// The project's gust generator (`fmu-wind`) set up for the parameters fitted to a measured
/// record: the Davenport shaping filter for the record's mean speed and the kappa of the -5/3
/// level (the filter the Wind FMU derives at initialisation for those parameters), and a record
/// it generated with the same length and sample rate as the measured one, analysed exactly as
/// the measured one.
#[derive(Debug, Clone, PartialEq)]
pub struct GeneratorComparison {
    /// Seed of the generated record.
    pub seed: u64,
    /// The Davenport parameters the filter was derived for.
    pub davenport: fmu_wind::davenport::Davenport,
    /// Number of states of the filter.
    pub filter_order: usize,
    /// Largest |dB| difference between the filter's exact spectrum and Eq. 2 at the measured
    /// analysis's Welch bins (its design error where the record has data).
    pub design_error_db: f64,
    /// The generated record (mean speed plus gust), analysed with the measured record's settings.
    pub generated: WindAnalysis,
    /// Relative scatter (1 sigma) of the sample standard deviation of one record of this length
    /// about the filter's (about the known mean, `fmu_wind::analysis::sample_variance_std`): how
    /// far one generated record may lie from the expectation.
    pub std_scatter: f64,
    /// Expected statistics of a record of the measured length from the filter's exact spectrum.
    pub prediction: GustPrediction,
    /// The curves to overlay: the filter's exact spectrum and the generated record's Welch PSD.
    pub curves: Vec<ComparisonCurve>,
}

/// Sets up the generator for `analysis` (fitted to `record`) and generates a record of the same
/// length and sample rate with `seed` (`fmu_wind::gust::GustGenerator`, exact discretisation,
/// started in its stationary distribution). The generated speed is the along-wind
/// `v_m + v_t`, which may dip below zero at high turbulence intensity, where a measured
/// horizontal speed (a magnitude) cannot.
pub fn compare_generator(
    record: &WindRecord,
    analysis: &WindAnalysis,
    seed: u64,
) -> Result<GeneratorComparison, WindFitError> {
    use fmu_wind::davenport::Davenport;
    use fmu_wind::gust::GustGenerator;
    use fmu_wind::shaping::ShapingFilter;
    let config = &analysis.config;
    let v_mean = analysis.statistics.mean_m_s;
    let davenport = Davenport::new(v_mean, config.effective_height_m(), analysis.implied.z0_m)?;
    let filter = ShapingFilter::davenport(&davenport);
    let fs = record.sample_rate_hz;
    let mut generator = GustGenerator::new(filter.clone(), seed);
    let speeds: Vec<f64> = (0..record.speed_m_s.len()).map(|_| v_mean + generator.step(1.0 / fs)).collect();
    let generated_record = WindRecord::from_samples(&format!("generator (fmu-wind, seed {seed})"), speeds, fs);
    let generated = analyse(&generated_record, config)?;
    let std_scatter = 0.5 * fmu_wind::analysis::sample_variance_std(&filter, analysis.statistics.duration_s)
        / filter.stationary_variance();
    // Against this module's own Eq. 2 with the fitted kappa, so the number also checks that
    // the two implementations of Eq. 2 agree.
    let fitted = DavenportSpectrum { v_mean_m_s: v_mean, kappa: analysis.implied.kappa };
    let design_error_db = analysis
        .spectrum
        .frequency_hz
        .iter()
        .filter(|&&n| n > 0.0)
        .map(|&n| (10.0 * (filter.psd_one_sided_per_hz(n) / fitted.psd(n)).log10()).abs())
        .fold(0.0, f64::max);
    let mut prediction = predict_gust(
        "our Davenport filter, exact spectrum",
        &|n| filter.psd_one_sided_per_hz(n),
        v_mean,
        analysis.statistics.duration_s,
        config.gust_window_s,
        1e3 / config.gust_window_s,
    );
    prediction.kappa = davenport.kappa();
    let grid = log_grid(
        (0.3 * analysis.identifiability.peak_hz).min(0.5 * analysis.identifiability.record_fundamental_hz),
        0.5 * fs,
        40,
    );
    let curves = vec![
        ComparisonCurve::from_psd(
            &format!("our Davenport filter (fmu-wind), κ = {:.3}, exact", davenport.kappa()),
            &grid,
            |n| filter.psd_one_sided_per_hz(n),
        ),
        ComparisonCurve {
            name: format!("generated by it, seed {seed} (band average)"),
            frequency_hz: generated.bands.frequency_hz.clone(),
            psd: generated.bands.psd.clone(),
        },
    ];
    Ok(GeneratorComparison {
        seed,
        davenport,
        filter_order: filter.order(),
        design_error_db,
        generated,
        std_scatter,
        prediction,
        curves,
    })
}

/// The report section comparing the measured record, Eq. 2 and the generator.
pub fn generator_markdown(analysis: &WindAnalysis, comparison: &GeneratorComparison) -> String {
    let s = &analysis.statistics;
    let g = &comparison.generated.statistics;
    let d = &comparison.davenport;
    let eq2 = &analysis.predictions[0];
    let p = &comparison.prediction;
    let mut r = String::new();
    let _ = writeln!(r, "## Generator (fmu-wind) for the fitted parameters\n");
    let _ = writeln!(
        r,
        "The Wind FMU's Davenport shaping filter (`fmu_wind::shaping::ShapingFilter::davenport`, {} states) for v_m = {:.3} m/s, \
         z = {:.2} m and the kappa of the -5/3 level, {:.4} (z0 = {:.3} m): its exact spectrum is within {:.3} dB of Eq. 2 at every Welch bin of the record. \
         A record of the same length and rate ({} samples at {:.3} Hz) was generated with seed {} (`fmu_wind::gust::GustGenerator`, exact discretisation, \
         started in its stationary distribution) and analysed with the same settings as the measured one. Both are drawn in `psd.png`.\n",
        comparison.filter_order,
        d.v_mean,
        d.z,
        d.kappa(),
        d.z0,
        comparison.design_error_db,
        g.samples,
        g.sample_rate_hz,
        comparison.seed
    );
    let gs = &comparison.generated.slope;
    let _ = writeln!(
        r,
        "| quantity | measured | Eq. 2 (kappa from the level), expected | our filter's exact spectrum, expected | generated record |"
    );
    let _ = writeln!(r, "| --- | --- | --- | --- | --- |");
    let _ = writeln!(
        r,
        "| std within the record (m/s) | {:.3} | {:.3} | {:.3} | {:.3} |",
        s.std_m_s, eq2.sigma_m_s, p.sigma_m_s, g.std_m_s
    );
    let _ = writeln!(
        r,
        "| turbulence intensity | {:.3} | {:.3} | {:.3} | {:.3} |",
        s.turbulence_intensity, eq2.turbulence_intensity, p.turbulence_intensity, g.turbulence_intensity
    );
    let _ = writeln!(
        r,
        "| {} s gust (m/s) | {:.2} | {:.2} | {:.2} | {:.2} |",
        analysis.config.gust_window_s, s.gust_m_s, eq2.gust_m_s, p.gust_m_s, g.gust_m_s
    );
    let _ = writeln!(
        r,
        "| gust factor | {:.2} | {:.2} | {:.2} | {:.2} |",
        s.gust_factor, eq2.gust_factor, p.gust_factor, g.gust_factor
    );
    let _ = writeln!(
        r,
        "| slope over {:.3}-{:.3} Hz | {:.3} ± {:.3} | -5/3 asymptote | -5/3 asymptote | {:.3} ± {:.3} |",
        gs.band_hz.0, gs.band_hz.1, analysis.slope.slope, analysis.slope.slope_std_error, gs.slope, gs.slope_std_error
    );
    let _ = writeln!(
        r,
        "| kappa from the -5/3 level | {:.4} | | {:.4} (set) | {:.4} (95 %: {:.4}-{:.4}) |",
        analysis.implied.kappa,
        d.kappa(),
        comparison.generated.implied.kappa,
        comparison.generated.implied.kappa_interval.0,
        comparison.generated.implied.kappa_interval.1
    );
    let _ = writeln!(r, "| skewness | {:.2} | 0 | 0 | {:.2} |\n", s.skewness, g.skewness);
    let _ = writeln!(
        r,
        "One record of {:.0} s from this filter has a sample standard deviation that scatters by {:.0} % (1 sigma) about the filter's {:.3} m/s: \
         Eq. 2 puts most of its variance into eddies of many minutes, of which the record holds few. The generated record is {:+.1} sigma from it, \
         the measured one {:+.1} sigma.\n",
        s.duration_s,
        100.0 * comparison.std_scatter,
        d.sigma(),
        (g.std_m_s / d.sigma() - 1.0) / comparison.std_scatter,
        (s.std_m_s / d.sigma() - 1.0) / comparison.std_scatter
    );
    r
}

/// Log-spaced frequencies from `low` to `high`, `per_decade` per decade.
pub(crate) fn log_grid(low: f64, high: f64, per_decade: usize) -> Vec<f64> {
    let decades = (high / low).log10();
    let count = (decades * per_decade as f64).ceil().max(1.0) as usize;
    (0..=count).map(|i| low * 10f64.powf(decades * i as f64 / count as f64)).collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_records::*;

    use antenna_dsp::standard_normal_quantile;

    #[test]
    fn generator_overlay_uses_the_fitted_kappa_and_its_record_recovers_it() {
        // A Davenport record analysed, then the generator set up for what was fitted: its filter
        // follows Eq. 2 within the design error, and the record it generates has a -5/3 level
        // whose kappa agrees with the one it was given within the generated record's own
        // uncertainty (two-sided, at 1e-3 significance).
        let truth = DavenportSpectrum::from_roughness(10.0, 10.0, 0.05);
        let mut config = WindFitConfig::new(10.0);
        config.fit_band_hz = Some((0.25, 2.5));
        let record = synthetic_record(|n| truth.psd(n), truth.v_mean_m_s, 1800.0, 20.0, 12);
        let analysis = analyse(&record, &config).unwrap();
        let comparison = compare_generator(&record, &analysis, 3).unwrap();
        assert!((comparison.davenport.kappa() / analysis.implied.kappa - 1.0).abs() < 1e-9);
        assert!(comparison.design_error_db < 0.1, "design error {} dB", comparison.design_error_db);
        let generated = &comparison.generated;
        assert_eq!(generated.statistics.samples, record.speed_m_s.len());
        assert_eq!(generated.statistics.sample_rate_hz, record.sample_rate_hz);
        let z = standard_normal_quantile(1.0 - 0.5e-3);
        let deviation = (generated.implied.kappa / comparison.davenport.kappa()).ln();
        assert!(
            deviation.abs() < z * generated.implied.kappa_relative_error,
            "generated kappa {} vs {} (relative error {})",
            generated.implied.kappa,
            comparison.davenport.kappa(),
            generated.implied.kappa_relative_error
        );
        // The overlay curves: the exact spectrum, and the generated record on the measured bands.
        assert_eq!(comparison.curves.len(), 2);
        assert_eq!(comparison.curves[1].frequency_hz, generated.bands.frequency_hz);
        let section = generator_markdown(&analysis, &comparison);
        assert!(section.contains("## Generator (fmu-wind)") && section.contains("generated record"));
    }
}
