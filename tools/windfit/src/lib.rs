//! Measured-wind analysis: reads a wind-speed record from CSV, estimates its spectrum, fits what
//! the record can identify of the Davenport model (the paper's Eq. 2), and reports the gust
//! statistics, with a PNG of the measured spectrum against the model.
//!
//! What a record identifies depends on its length and the mean speed. The Davenport spectrum
//! (fixed length scale L = 1200 m) has one free parameter, kappa, given the mean speed v_m; its
//! shape puts the spectral peak at n = sqrt(3/5) v_m / L, which at light wind is a period of
//! many minutes. A 30-min record at 1.8 m/s holds about two such periods, far too few to
//! locate the peak, so this module fits only:
//! - the inertial-subrange slope (log-log regression over a range the record resolves well),
//!   compared with -5/3;
//! - the level of that subrange, which fixes kappa through Eq. 2's high-frequency asymptote
//!   S(n) -> 4 kappa v_m^(8/3) L^(-2/3) n^(-5/3), and from kappa the roughness length z0;
//! - the variance and gust statistics of the record, compared with what Eq. 2 predicts for a
//!   record of the same length (the record's own mean removes the slow eddies).
//!
//! The report states the Davenport peak frequency and why it is not identifiable.
//! [`compare_generator`] puts the project's gust generator (fmu-wind) beside the record: the
//! exact spectrum of the Davenport shaping filter for the fitted kappa, and a record it
//! generates with the same length and sample rate, analysed like the measured one.
//! [`ComparisonCurve`] and [`predict_gust`] take any other generated record or model PSD.
//!
//! Modules, by concern: [`record`] reads a record, [`config`] holds the settings,
//! [`statistics`] the record's moments and gusts with their Eq. 2 expectations,
//! [`spectrum_fit`] the inertial-subrange fits and what the spectrum identifies, [`analysis`]
//! runs them in order, [`generator`] sets fmu-wind's generator beside the record, [`figures`]
//! draws, [`report`] writes the Markdown report and the gust CSV, and [`cli`] is the `windfit`
//! command line.

pub mod analysis;
pub mod cli;
pub mod config;
pub mod davenport;
pub mod error;
pub mod figures;
pub mod generator;
pub mod record;
pub mod report;
pub mod spectrum_fit;
pub mod statistics;

pub use analysis::{analyse, WindAnalysis};
pub use cli::{run, WindfitArgs};
pub use config::WindFitConfig;
pub use davenport::DavenportSpectrum;
pub use error::WindFitError;
pub use figures::{spectrum_figure, time_series_figure};
pub use generator::{compare_generator, generator_markdown, ComparisonCurve, GeneratorComparison};
pub use record::{parse_wind_csv, read_wind_csv, WindRecord};
pub use report::{gust_summary_csv, report_markdown};
pub use spectrum_fit::{Identifiability, ImpliedDavenport, LevelFit, LocalSlope, SlopeFit};
pub use statistics::{predict_gust, BlockStatistics, GustPrediction, PeriodSummary, RecordStatistics};

/// Column read by default: the horizontal wind speed.
pub const DEFAULT_SPEED_COLUMN: &str = "horizontal_speed_m_s";

/// Time column read by default, in seconds.
pub const DEFAULT_TIME_COLUMN: &str = "time_s";

/// Davenport's length scale in Eq. 2 (x = L n / v_m), m.
pub const DAVENPORT_LENGTH_M: f64 = 1200.0;

/// The seed paper's roughness length for the MeerKAT site (sparse shrubs), m.
pub const PAPER_Z0_M: f64 = 0.4;

/// The Kolmogorov inertial-subrange slope of a velocity spectrum.
pub const KOLMOGOROV_SLOPE: f64 = -5.0 / 3.0;

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::figures::log_grid;
    use antenna_dsp::test_signals::process_with_psd;
    use antenna_dsp::{self as dsp, moving_average, standard_normal_quantile};
    use std::path::{Path, PathBuf};

    /// A record of a stationary Gaussian process with one-sided PSD `psd` plus `v_mean`: the
    /// middle quarter of a circularly synthesised record four times as long, so it behaves like
    /// a piece of an endless process rather than one period of a periodic one.
    pub(crate) fn synthetic_record(
        psd: impl Fn(f64) -> f64,
        v_mean: f64,
        seconds: f64,
        sample_rate_hz: f64,
        seed: u64,
    ) -> WindRecord {
        let len = (seconds * sample_rate_hz).round() as usize;
        let long = process_with_psd(4 * len, sample_rate_hz, seed, psd);
        let speed = long[len + len / 2..2 * len + len / 2].iter().map(|v| v + v_mean).collect();
        WindRecord::from_samples(&format!("synthetic seed {seed}"), speed, sample_rate_hz)
    }

    fn shared_wind_record() -> Option<PathBuf> {
        let path =
            Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data/sonic-anemometer-20hz/wind_20hz.csv");
        if path.exists() {
            Some(path)
        } else {
            eprintln!(
                "SKIPPED: measured wind record not found at {} (the shared/ data directory sits beside the repository)",
                path.display()
            );
            None
        }
    }

    #[test]
    fn measured_record_matches_its_readme_and_the_report_states_the_slope_verdict_it_computed() {
        let Some(path) = shared_wind_record() else {
            return;
        };
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

    #[test]
    fn davenport_closed_forms_match_numerical_integration_and_maxima() {
        let model = DavenportSpectrum::from_roughness(3.0, 10.0, 0.4);
        // PHYSICS-NOTES item 4: kappa = 0.01544 and sigma = 0.304 v_m for z = 10 m, z0 = 0.4 m.
        assert!((model.kappa - 0.01544).abs() < 5e-6, "kappa {}", model.kappa);
        assert!(((model.variance().sqrt() / 3.0) - 0.304).abs() < 5e-4);
        // Integral of the PSD over a log grid (trapezoid in ln n).
        let grid = log_grid(1e-7, 1e5, 2000);
        let integral = |upper: f64| -> f64 {
            grid.windows(2)
                .filter(|w| w[1] <= upper)
                .map(|w| 0.5 * (model.psd(w[0]) * w[0] + model.psd(w[1]) * w[1]) * (w[1] / w[0]).ln())
                .sum()
        };
        assert!((integral(1e5) / model.variance() - 1.0).abs() < 1e-3);
        let n = grid.iter().copied().find(|n| *n >= 0.01).unwrap();
        assert!((integral(n) / model.variance_below(n) - 1.0).abs() < 2e-3);
        // The stated peaks are the maxima of S(n) and n S(n) on a dense grid.
        let argmax = |f: &dyn Fn(f64) -> f64| grid.iter().copied().max_by(|a, b| f(*a).total_cmp(&f(*b))).unwrap();
        let peak = argmax(&|n| model.psd(n));
        let premultiplied = argmax(&|n| n * model.psd(n));
        assert!((peak / model.peak_frequency_hz() - 1.0).abs() < 0.01);
        assert!((premultiplied / model.premultiplied_peak_frequency_hz() - 1.0).abs() < 0.01);
        // The inertial asymptote and its inverse.
        let far = 100.0;
        assert!((model.psd(far) * far.powf(5.0 / 3.0) / model.inertial_level() - 1.0).abs() < 1e-4);
        let back = DavenportSpectrum::from_inertial_level(3.0, model.inertial_level());
        assert!((back.kappa / model.kappa - 1.0).abs() < 1e-12);
        assert!((DavenportSpectrum::roughness_for_kappa(10.0, model.kappa) - 0.4).abs() < 1e-12);
    }

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

    #[test]
    fn records_that_cannot_be_analysed_are_errors_not_panics() {
        let config = WindFitConfig::new(10.0);
        let constant = WindRecord::from_samples("constant", vec![3.0; 20_000], 20.0);
        assert!(matches!(analyse(&constant, &config), Err(WindFitError::Analysis(_))));
        let calm = WindRecord::from_samples("calm", vec![0.0; 20_000], 20.0);
        assert!(matches!(analyse(&calm, &config), Err(WindFitError::Analysis(_))));
        let short = synthetic_record(|f| 0.02 * f.powf(KOLMOGOROV_SLOPE), 4.0, 2.0, 20.0, 1);
        assert!(matches!(analyse(&short, &config), Err(WindFitError::TooShort { .. })));
        let mut bad = config.clone();
        bad.reference_z0_m = 20.0;
        let record = synthetic_record(|f| 0.02 * f.powf(KOLMOGOROV_SLOPE), 4.0, 600.0, 20.0, 2);
        assert!(matches!(analyse(&record, &bad), Err(WindFitError::InvalidConfig(_))));
    }
}
