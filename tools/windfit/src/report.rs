//! The written results: the Markdown report, one section per question the record answers, and
//! the gust summary CSV.

use crate::analysis::WindAnalysis;
use crate::davenport::DavenportSpectrum;
use crate::davenport::DAVENPORT_LENGTH_M;
use crate::generator::ComparisonCurve;
use crate::spectrum_fit::KOLMOGOROV_SLOPE;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

pub(crate) fn file_name(source: &str) -> String {
    Path::new(source).file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_else(|| source.to_string())
}

/// The turbulence-intensity and gust-factor summary as CSV: one line per block.
pub fn gust_summary_csv(analysis: &WindAnalysis) -> String {
    let mut csv = String::from("period_s,block,start_s,mean_m_s,std_m_s,turbulence_intensity,gust_m_s,gust_factor\n");
    for period in &analysis.periods {
        for (i, block) in period.blocks.iter().enumerate() {
            let _ = writeln!(
                csv,
                "{},{},{:.2},{:.4},{:.4},{:.4},{:.4},{:.4}",
                period.period_s,
                i,
                block.start_s,
                block.mean_m_s,
                block.std_m_s,
                block.turbulence_intensity(),
                block.gust_m_s,
                block.gust_factor()
            );
        }
    }
    csv
}

/// The report as Markdown, one section per question the record answers. `files` lists the
/// files written beside it (may be empty).
pub fn report_markdown(analysis: &WindAnalysis, overlays: &[ComparisonCurve], files: &[PathBuf]) -> String {
    let mut r = String::new();
    title_section(&mut r, analysis);
    record_statistics_section(&mut r, analysis);
    spectrum_section(&mut r, analysis);
    inertial_subrange_section(&mut r, analysis);
    implied_davenport_section(&mut r, analysis);
    identifiability_section(&mut r, analysis);
    gust_statistics_section(&mut r, analysis);
    averaging_periods_section(&mut r, analysis);
    if !overlays.is_empty() {
        let _ = writeln!(r, "\n## Overlays\n");
        for overlay in overlays {
            let _ = writeln!(r, "- {} ({} points)", overlay.name, overlay.frequency_hz.len());
        }
    }
    if !files.is_empty() {
        let _ = writeln!(r, "\n## Files\n");
        for file in files {
            let _ = writeln!(r, "- `{}`", file.display());
        }
    }
    r
}

/// The title and where the record comes from.
fn title_section(r: &mut String, analysis: &WindAnalysis) {
    let c = &analysis.config;
    let height = c.effective_height_m();
    let _ = writeln!(r, "# Measured wind: {} ({})\n", file_name(&analysis.source), analysis.column);
    let _ = writeln!(
        r,
        "Source: `{}`. Instrument height {} m{}; reference roughness z0 = {} m.\n",
        analysis.source,
        c.height_m,
        if c.displacement_m != 0.0 {
            format!(", displacement {} m (effective height {height:.2} m)", c.displacement_m)
        } else {
            String::new()
        },
        c.reference_z0_m
    );
}

/// The record's moments, gust and peak factor.
fn record_statistics_section(r: &mut String, analysis: &WindAnalysis) {
    let s = &analysis.statistics;
    let c = &analysis.config;
    let _ = writeln!(r, "## Record statistics\n");
    let _ = writeln!(r, "| quantity | value |\n| --- | --- |");
    let _ =
        writeln!(r, "| samples, rate, length | {} at {:.3} Hz, {:.1} s |", s.samples, s.sample_rate_hz, s.duration_s);
    let _ = writeln!(
        r,
        "| mean speed | {:.3} m/s (standard error {:.3} m/s from an integral time scale of {:.1} s) |",
        s.mean_m_s, s.mean_std_error_m_s, s.integral_time_scale_s
    );
    let _ = writeln!(r, "| standard deviation | {:.3} m/s |", s.std_m_s);
    let _ = writeln!(r, "| turbulence intensity | {:.3} |", s.turbulence_intensity);
    let _ = writeln!(
        r,
        "| {} s gust (largest {} s moving average) | {:.3} m/s at t = {:.1} s |",
        c.gust_window_s, c.gust_window_s, s.gust_m_s, s.gust_time_s
    );
    let _ = writeln!(r, "| gust factor (gust / record mean) | {:.3} |", s.gust_factor);
    let _ = writeln!(
        r,
        "| std of the {} s average; observed peak factor (gust - mean) / std | {:.3} m/s; {:.2} |",
        c.gust_window_s, s.gust_window_std_m_s, s.observed_peak_factor
    );
    let _ = writeln!(r, "| skewness, excess kurtosis | {:.2}, {:.2} |\n", s.skewness, s.kurtosis_excess);
}

/// How the spectrum was estimated and what one bin and one band are worth.
fn spectrum_section(r: &mut String, analysis: &WindAnalysis) {
    let s = &analysis.statistics;
    let c = &analysis.config;
    let spectrum = &analysis.spectrum;
    let _ = writeln!(r, "## Spectrum\n");
    let _ = writeln!(
        r,
        "Welch PSD, one-sided per Hz: {} segments of {} samples ({:.0} s), {} window, 50 % overlap, mean removed per segment; \
         resolution {:.4} Hz, {:.1} equivalent degrees of freedom per bin (95 % factors {:.2} to {:.2}). \
         Averaged into {} bands per decade; a wide band of M bins has about M/{:.2} times the dof of one bin, because neighbouring {} bins are correlated.\n",
        spectrum.segments,
        spectrum.segment_len,
        spectrum.segment_len as f64 / s.sample_rate_hz,
        spectrum.window.name(),
        spectrum.resolution_hz(),
        spectrum.dof,
        spectrum.confidence_interval(0.95).map(|i| i.lower).unwrap_or(f64::NAN),
        spectrum.confidence_interval(0.95).map(|i| i.upper).unwrap_or(f64::NAN),
        c.bands_per_decade,
        1.0 + 2.0 * spectrum.bin_correlation.iter().skip(1).sum::<f64>(),
        spectrum.window.name()
    );
}

/// The slope and level of the inertial subrange and the verdict on -5/3.
fn inertial_subrange_section(r: &mut String, analysis: &WindAnalysis) {
    let c = &analysis.config;
    let slope = &analysis.slope;
    let level = &analysis.level;
    let percent = 100.0 * analysis.config.confidence;
    let _ = writeln!(r, "## Inertial subrange\n");
    let automatic = if c.fit_band_hz.is_none() {
        " (automatic: from v_m / (z - d), where the inertial subrange starts, to fs/8, below aliasing)"
    } else {
        " (as configured)"
    };
    let _ = writeln!(
        r,
        "Fit range {:.3} to {:.3} Hz{automatic}: {} bands, {} Welch bins, weighted by their chi-squared statistics.\n",
        slope.band_hz.0, slope.band_hz.1, slope.bands, slope.raw_bins
    );
    let _ = writeln!(
        r,
        "- Slope: **{:.3} ± {:.3}** (1 sigma; reduced chi-squared {:.2}{}).",
        slope.slope,
        slope.slope_std_error,
        slope.reduced_chi_squared,
        if slope.reduced_chi_squared > 1.0 { ", uncertainty scaled up by its square root" } else { "" }
    );
    let verdict = if slope.consistent_with_kolmogorov {
        format!(
            "consistent with -5/3 at {percent:.0} % confidence ({:+.1} sigma)",
            slope.deviation_from_kolmogorov_sigmas
        )
    } else {
        let direction = if slope.slope > KOLMOGOROV_SLOPE { "shallower" } else { "steeper" };
        format!(
            "**not consistent with -5/3** at {percent:.0} % confidence: {direction} by {:.3} ({:+.1} sigma)",
            (slope.slope - KOLMOGOROV_SLOPE).abs(),
            slope.deviation_from_kolmogorov_sigmas
        )
    };
    let _ = writeln!(r, "- Compared with Kolmogorov's -5/3 = -1.667: {verdict}.");
    let _ = writeln!(r, "- Level with the slope fixed at -5/3: S(n) = A n^(-5/3), A = **{:.4e} (m/s)² Hz^(2/3)** ± {:.1} % (reduced chi-squared {:.2}); S(1 Hz) = {:.4e} (m/s)²/Hz.\n",
        level.level, 100.0 * level.level_relative_error, level.reduced_chi_squared, level.level);
    if !slope.consistent_with_kolmogorov {
        let _ = writeln!(r, "The record does not show a clean -5/3 subrange over this range. Candidates, not tested here: the horizontal speed is the magnitude of \
            two components, not the longitudinal component; light convective wind just above a canopy (roughness sublayer) departs from surface-layer similarity; \
            aliasing and sonic path averaging act near the top of the range. The level and kappa below assume -5/3 regardless.\n");
    }
    let _ = writeln!(r, "Local slopes per half decade (weighted fits over the bands in each):\n");
    let _ = writeln!(r, "| range (Hz) | slope | ± |\n| --- | --- | --- |");
    for local in &analysis.local_slopes {
        let _ = writeln!(
            r,
            "| {:.4} - {:.4} | {:.2} | {:.2} |",
            local.band_hz.0, local.band_hz.1, local.slope, local.std_error
        );
    }
}

/// The kappa and z0 that the level implies, and whether Eq. 2's shape fits the variance.
fn implied_davenport_section(r: &mut String, analysis: &WindAnalysis) {
    let s = &analysis.statistics;
    let c = &analysis.config;
    let slope = &analysis.slope;
    let implied = &analysis.implied;
    let percent = 100.0 * analysis.config.confidence;
    let height = analysis.config.effective_height_m();
    let _ = writeln!(r, "\n## What the high-frequency level implies for Eq. 2\n");
    let _ = writeln!(r, "Eq. 2 tends to S(n) = 4 kappa v_m^(8/3) L^(-2/3) n^(-5/3) (L = 1200 m) for x = L n / v_m >> 1 (x > {:.0} over the fit range), so the level fixes kappa given v_m:\n",
        DAVENPORT_LENGTH_M * slope.band_hz.0 / s.mean_m_s);
    let _ = writeln!(r, "- kappa = **{:.4}**, {:.0} % interval {:.4} to {:.4} (relative error {:.1} %: {:.1} % from the level, {:.1} % from the mean speed through kappa ~ v_m^(-8/3)).",
        implied.kappa, percent, implied.kappa_interval.0, implied.kappa_interval.1, 100.0 * implied.kappa_relative_error, 100.0 * implied.kappa_relative_error_from_level, 100.0 * implied.kappa_relative_error_from_mean);
    let _ = writeln!(
        r,
        "- z0 at z = {height:.2} m: **{:.3} m** ({:.3} to {:.3} m).",
        implied.z0_m, implied.z0_interval_m.0, implied.z0_interval_m.1
    );
    let _ = writeln!(r, "- For comparison: kappa matching the record's variance under Eq. 2's shape = {:.4} (z0 = {:.3} m); the reference z0 = {} m gives kappa = {:.4}.",
        analysis.kappa_from_variance, DavenportSpectrum::roughness_for_kappa(height, analysis.kappa_from_variance), c.reference_z0_m, analysis.kappa_reference);
    let ratio = implied.kappa / analysis.kappa_from_variance;
    let _ = writeln!(
        r,
        "- The two kappas differ by a factor {ratio:.2}: {}\n",
        if (ratio.ln()).abs() > 2.0 * implied.kappa_relative_error {
            "Eq. 2's shape, with its fixed 1200 m length scale, does not fit this record's split of variance between the slow eddies and the inertial subrange; \
         a second parameter (the length scale, i.e. the peak position) would be needed, and that is what the record cannot identify (next section)."
        } else {
            "within the uncertainty, so Eq. 2's shape is consistent with the record's split of variance."
        }
    );
}

/// Why the Davenport peak is (or is not) identifiable from this record.
fn identifiability_section(r: &mut String, analysis: &WindAnalysis) {
    let s = &analysis.statistics;
    let id = &analysis.identifiability;
    let _ = writeln!(r, "## What the record cannot identify\n");
    let _ = writeln!(r, "- Davenport peak of S(n): x² = 3/5, n = sqrt(3/5) v_m / L = **{:.3} mHz** (period {:.0} s). Peak of n S(n) (per log frequency): x² = 3, n = sqrt(3) v_m / L = {:.3} mHz (period {:.0} s).",
        1e3 * id.peak_hz, 1.0 / id.peak_hz, 1e3 * id.premultiplied_peak_hz, 1.0 / id.premultiplied_peak_hz);
    let _ = writeln!(
        r,
        "- The formula v_m / (1200 sqrt 2) = {:.3} mHz (x² = 1/2) is the maximum of neither S(n) nor n S(n).",
        1e3 * id.quoted_formula_hz
    );
    let _ = writeln!(r, "- The record lasts {:.0} s = {:.1} periods of the S(n) peak; 1 / length = {:.3} mHz. The lowest Welch bin is {:.3} mHz with {:.1} dof; \
        {:.0} % of Eq. 2's variance lies below it (for any kappa).",
        s.duration_s, id.peak_periods_in_record, 1e3 * id.record_fundamental_hz, 1e3 * id.lowest_welch_hz, id.lowest_welch_dof, 100.0 * id.variance_fraction_below_lowest_welch);
    let _ = writeln!(
        r,
        "- {}",
        if id.peak_identifiable {
            "The Welch estimate reaches below the peak with at least three bins, so the peak region is resolved."
                .to_string()
        } else {
            format!("**The spectral peak is not identifiable from this record**, so neither is a full Davenport fit (kappa together with the length scale that places the peak): \
            resolving the peak with three Welch bins below it and ten averaged segments would take about {:.1} h of stationary wind at this mean speed. \
            What the record does identify is the inertial-subrange slope and level (above) and the gust statistics (below).", id.record_needed_s / 3600.0)
        }
    );
}

/// The measured gust statistics against each spectrum's expectation.
fn gust_statistics_section(r: &mut String, analysis: &WindAnalysis) {
    let s = &analysis.statistics;
    let c = &analysis.config;
    let _ = writeln!(r, "\n## Gust statistics against Eq. 2\n");
    let _ = writeln!(r, "Expected statistics of a {:.0} s Gaussian record with the same mean ({:.3} m/s), from each spectrum: the record's own mean removes eddies slower than the record, \
        the {} s average filters the rest, and the expected largest average is v_m + g sigma with Davenport's peak factor g.\n", s.duration_s, s.mean_m_s, c.gust_window_s);
    let _ = writeln!(r, "| spectrum | kappa | std in record (m/s) | TI | std of {} s mean (m/s) | crossing rate (Hz) | g | {} s gust (m/s) | gust factor |", c.gust_window_s, c.gust_window_s);
    let _ = writeln!(r, "| --- | --- | --- | --- | --- | --- | --- | --- | --- |");
    let _ = writeln!(
        r,
        "| **measured record** | | {:.3} | {:.3} | {:.3} | | {:.2} | {:.3} | {:.3} |",
        s.std_m_s, s.turbulence_intensity, s.gust_window_std_m_s, s.observed_peak_factor, s.gust_m_s, s.gust_factor
    );
    for p in &analysis.predictions {
        let kappa = if p.kappa.is_nan() { String::new() } else { format!("{:.4}", p.kappa) };
        let _ = writeln!(
            r,
            "| {} | {kappa} | {:.3} | {:.3} | {:.3} | {:.3} | {:.2} | {:.3} | {:.3} |",
            p.label,
            p.sigma_m_s,
            p.turbulence_intensity,
            p.gust_window_sigma_m_s,
            p.crossing_rate_hz,
            p.peak_factor,
            p.gust_m_s,
            p.gust_factor
        );
    }
    let _ = writeln!(r, "\nA single record's largest gust scatters about its expectation (the peak factor's standard deviation is about pi / sqrt(6) / sqrt(2 ln(nu T)), {:.2} here), \
        and a skewed record (skewness {:.2}) has larger upward gusts than the Gaussian theory allows.\n",
        analysis.predictions.last().map(|p| std::f64::consts::PI / 6f64.sqrt() / (2.0 * (p.crossing_rate_hz * s.duration_s).max(std::f64::consts::E).ln()).sqrt()).unwrap_or(f64::NAN), s.skewness);
}

/// Turbulence intensity and gust factor per averaging period.
fn averaging_periods_section(r: &mut String, analysis: &WindAnalysis) {
    let c = &analysis.config;
    let _ = writeln!(r, "## Turbulence intensity and gust factor by averaging period\n");
    let _ = writeln!(r, "Non-overlapping blocks; the gust is the largest {} s average within a block, the gust factor is gust / block mean. \
        Expected gust factors use the record's overall mean speed.\n", c.gust_window_s);
    let _ = writeln!(r, "| period (s) | blocks | block means (m/s) | mean TI | mean gust factor | max gust factor | expected, Eq. 2 (kappa from level) | expected, measured spectrum |");
    let _ = writeln!(r, "| --- | --- | --- | --- | --- | --- | --- | --- |");
    for p in &analysis.periods {
        let means: Vec<f64> = p.blocks.iter().map(|b| b.mean_m_s).collect();
        let (low, high) = means.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &m| (a.min(m), b.max(m)));
        let _ = writeln!(
            r,
            "| {:.0} | {} | {:.2} - {:.2} | {:.3} | {:.3} | {:.3} | {:.3} | {:.3} |",
            p.period_s,
            p.blocks.len(),
            low,
            high,
            p.mean_turbulence_intensity(),
            p.mean_gust_factor(),
            p.max_gust_factor(),
            p.predicted_gust_factor_fitted,
            p.predicted_gust_factor_measured
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_records::*;
    use crate::*;
    use antenna_dsp::standard_normal_quantile;

    #[test]
    fn measured_record_matches_its_readme_and_the_report_states_the_slope_verdict_it_computed() {
        let path = measured_wind_record();
        let record = read_wind_csv(&path, DEFAULT_TIME_COLUMN, DEFAULT_SPEED_COLUMN).unwrap();
        assert_eq!(record.speed_m_s.len(), 36_000);
        assert!((record.sample_rate_hz - 20.0).abs() < 1e-9);
        let analysis = analyse(&record, &WindFitConfig::new(7.11)).unwrap();
        let s = &analysis.statistics;
        // The data README: "mean horizontal speed 1.80 m/s, standard deviation 0.93 m/s".
        assert_eq!(format!("{:.2}", s.mean_m_s), "1.80");
        assert_eq!(format!("{:.2}", s.std_m_s), "0.93");

        let slope = &analysis.slope;
        assert!(slope.slope_std_error > 0.0 && slope.slope_std_error < 0.2, "{slope:?}");
        let z = standard_normal_quantile(0.975);
        assert_eq!(
            slope.consistent_with_kolmogorov,
            (slope.slope - KOLMOGOROV_SLOPE).abs() <= z * slope.slope_std_error
        );
        let report = report_markdown(&analysis, &[], &[]);
        if slope.consistent_with_kolmogorov {
            assert!(report.contains("consistent with -5/3") && !report.contains("not consistent"));
        } else {
            assert!(report.contains("**not consistent with -5/3**"), "an inconsistent slope must be reported as such");
        }
        // Davenport's peak (1.16 mHz at 1.8 m/s) lies below three Welch bins of 600 s: the
        // report must say the peak, and so a full Davenport fit, is not identifiable.
        assert!(!analysis.identifiability.peak_identifiable);
        assert!(report.contains("The spectral peak is not identifiable"));
        // The high-frequency level gives a kappa whose z0 lies below the instrument.
        assert!(analysis.implied.z0_m > 0.0 && analysis.implied.z0_m < 7.11);
    }
}
