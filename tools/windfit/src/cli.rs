//! The `windfit` command line: its options (clap) and the run that reads, analyses and writes
//! the report, figures and gust summary.

use crate::analysis::analyse;
use crate::config::WindFitConfig;
use crate::error::WindFitError;
use crate::figures::{spectrum_figure, time_series_figure};
use crate::generator::{compare_generator, generator_markdown, ComparisonCurve};
use crate::record::read_wind_csv;
use crate::record::{DEFAULT_SPEED_COLUMN, DEFAULT_TIME_COLUMN};
use crate::report::{file_name, gust_summary_csv, report_markdown};
use clap::Parser;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// Analyses a measured wind-speed record against the Davenport spectrum (Eq. 2).
///
/// Mean, standard deviation, turbulence intensity, 3-s gust and gust factor; Welch PSD with
/// confidence band; the inertial-subrange slope and level with uncertainties; the Davenport
/// kappa and z0 the level implies; why the spectral peak is (not) identifiable; gust
/// statistics against Eq. 2. Writes report.md, psd.png, timeseries.png and gust-summary.csv to
/// the output directory and prints the report.
#[derive(Debug, Clone, PartialEq, Parser)]
#[command(
    name = "windfit",
    version,
    about,
    long_about = None,
    // A negative number is a value to check, not an unknown flag: `--segment-s -5` is an
    // invalid setting with its reason, as the analysis states it.
    allow_negative_numbers = true,
    after_help = "example (from the repository root):\n  cargo run --release -p antenna-cli --bin windfit -- \\\n      tests/data/measured/sonic-anemometer-20hz/wind_20hz.csv --height-m 7.11"
)]
pub struct WindfitArgs {
    /// The measured record: CSV with a header line, a time column in s and a speed column.
    #[arg(value_name = "RECORD.csv")]
    pub record: PathBuf,
    /// Instrument height above ground, m (kappa and z0 depend on it: 7.11 m for the
    /// sonic-anemometer record).
    #[arg(long = "height-m", value_name = "Z")]
    pub height_m: f64,
    /// Zero-plane displacement, m; Eq. 2 then uses z - d [default: 0].
    #[arg(long = "displacement-m", value_name = "D")]
    pub displacement_m: Option<f64>,
    /// Speed column.
    #[arg(long, value_name = "NAME", default_value = DEFAULT_SPEED_COLUMN)]
    pub column: String,
    /// Time column, in s.
    #[arg(long = "time-column", value_name = "NAME", default_value = DEFAULT_TIME_COLUMN)]
    pub time_column: String,
    /// Roughness of the reference Eq. 2 curve, m [default: 0.4, the paper's].
    #[arg(long = "reference-z0-m", value_name = "Z0")]
    pub reference_z0_m: Option<f64>,
    /// Welch segment length, s [default: 600].
    #[arg(long = "segment-s", value_name = "S")]
    pub segment_s: Option<f64>,
    /// Log-frequency bands per decade [default: 10].
    #[arg(long = "bands-per-decade", value_name = "B")]
    pub bands_per_decade: Option<f64>,
    /// Inertial-subrange fit range, Hz [default: v_m/(z-d) to fs/8].
    #[arg(long = "fit-band", value_name = "LOW:HIGH", value_parser = parse_fit_band)]
    pub fit_band: Option<FitBand>,
    /// Gust averaging time, s [default: 3].
    #[arg(long = "gust-window-s", value_name = "T")]
    pub gust_window_s: Option<f64>,
    /// Overlay a generated record (same CSV layout) on the spectrum.
    #[arg(long, value_name = "PATH")]
    pub generated: Option<PathBuf>,
    /// Speed column of the generated record [default: --column].
    #[arg(long = "generated-column", value_name = "NAME")]
    pub generated_column: Option<String>,
    /// Seed of the fmu-wind generator overlay: our Davenport filter for the fitted kappa, exact
    /// and as a generated record of the same length and rate.
    #[arg(long = "generator-seed", value_name = "N", default_value_t = 1)]
    pub generator_seed: u64,
    /// Leave the fmu-wind generator overlay out.
    #[arg(long = "no-generator")]
    pub no_generator: bool,
    /// Output directory.
    #[arg(long = "out-dir", value_name = "DIR", default_value = "out/windfit")]
    pub out_dir: PathBuf,
}

/// An inertial-subrange fit range given on the command line.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FitBand {
    /// Lower end, Hz.
    pub low_hz: f64,
    /// Upper end, Hz.
    pub high_hz: f64,
}

/// Parses `LOW:HIGH` in Hz.
fn parse_fit_band(text: &str) -> Result<FitBand, String> {
    text.split_once(':')
        .and_then(|(low, high)| Some(FitBand { low_hz: low.parse().ok()?, high_hz: high.parse().ok()? }))
        .ok_or_else(|| format!("'{text}' is not LOW:HIGH in Hz"))
}

impl WindfitArgs {
    /// The analysis settings the options ask for, checked.
    pub fn config(&self) -> Result<WindFitConfig, WindFitError> {
        let mut config = WindFitConfig::new(self.height_m);
        let settings = [
            (self.displacement_m, &mut config.displacement_m),
            (self.reference_z0_m, &mut config.reference_z0_m),
            (self.segment_s, &mut config.segment_s),
            (self.bands_per_decade, &mut config.bands_per_decade),
            (self.gust_window_s, &mut config.gust_window_s),
        ];
        for (given, setting) in settings {
            if let Some(value) = given {
                *setting = value;
            }
        }
        config.fit_band_hz = self.fit_band.map(|band| (band.low_hz, band.high_hz));
        config.validate()?;
        Ok(config)
    }

    /// The seed of the generator overlay, `None` when it is left out.
    pub fn generator_seed(&self) -> Option<u64> {
        (!self.no_generator).then_some(self.generator_seed)
    }
}

/// Runs the tool: reads, analyses, writes the report, plots and summary into the output
/// directory, and returns the report text.
pub fn run(options: &WindfitArgs) -> Result<String, WindFitError> {
    let config = options.config()?;
    let record = read_wind_csv(&options.record, &options.time_column, &options.column)?;
    let analysis = analyse(&record, &config)?;
    let mut overlays = Vec::new();
    if let Some(path) = &options.generated {
        let column = options.generated_column.as_deref().unwrap_or(&options.column);
        let generated = read_wind_csv(path, &options.time_column, column)?;
        overlays.push(ComparisonCurve::from_record(
            &format!("generated ({})", file_name(&path.display().to_string())),
            &generated.speed_m_s,
            generated.sample_rate_hz,
            &config,
        )?);
    }
    let generator = match options.generator_seed() {
        Some(seed) => Some(compare_generator(&record, &analysis, seed)?),
        None => None,
    };
    if let Some(comparison) = &generator {
        overlays.extend(comparison.curves.iter().cloned());
    }
    std::fs::create_dir_all(&options.out_dir)
        .map_err(|e| WindFitError::Write { path: options.out_dir.display().to_string(), message: e.to_string() })?;
    let psd_path = options.out_dir.join("psd.png");
    let series_path = options.out_dir.join("timeseries.png");
    let summary_path = options.out_dir.join("gust-summary.csv");
    let report_path = options.out_dir.join("report.md");
    spectrum_figure(&analysis, &overlays)?.save_png(&psd_path)?;
    time_series_figure(&record, &analysis).save_png(&series_path)?;
    let write = |path: &Path, text: &str| {
        std::fs::write(path, text)
            .map_err(|e| WindFitError::Write { path: path.display().to_string(), message: e.to_string() })
    };
    write(&summary_path, &gust_summary_csv(&analysis))?;
    // The generator's section goes before the list of files, which ends the report.
    let mut report = report_markdown(&analysis, &overlays, &[]);
    if let Some(comparison) = &generator {
        report.push('\n');
        report.push_str(&generator_markdown(&analysis, comparison));
    }
    let _ = writeln!(report, "\n## Files\n");
    for file in [&report_path, &psd_path, &series_path, &summary_path] {
        let _ = writeln!(report, "- `{}`", file.display());
    }
    write(&report_path, &report)?;
    Ok(report)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::spectrum_fit::KOLMOGOROV_SLOPE;
    use crate::test_records::synthetic_record;

    fn parse(list: &[&str]) -> Result<WindfitArgs, clap::Error> {
        WindfitArgs::try_parse_from(std::iter::once("windfit").chain(list.iter().copied()))
    }

    #[test]
    fn command_line_requires_a_record_and_a_height_and_rejects_unknown_options() {
        use clap::error::ErrorKind;
        assert_eq!(parse(&["--help"]).unwrap_err().kind(), ErrorKind::DisplayHelp);
        assert_eq!(parse(&["--version"]).unwrap_err().kind(), ErrorKind::DisplayVersion);
        let missing_height = parse(&["wind.csv"]).unwrap_err();
        assert_eq!(missing_height.kind(), ErrorKind::MissingRequiredArgument);
        assert!(missing_height.to_string().contains("--height-m"));
        assert_eq!(parse(&["--height-m", "7"]).unwrap_err().kind(), ErrorKind::MissingRequiredArgument);
        assert_eq!(
            parse(&["wind.csv", "--height-m", "7", "--frobnicate"]).unwrap_err().kind(),
            ErrorKind::UnknownArgument
        );
        assert_eq!(parse(&["wind.csv", "--height-m", "seven"]).unwrap_err().kind(), ErrorKind::ValueValidation);
        let band = parse(&["wind.csv", "--height-m", "7", "--fit-band", "0.3-3"]).unwrap_err();
        assert!(band.to_string().contains("'0.3-3' is not LOW:HIGH in Hz"), "{band}");
        assert_eq!(parse(&["a.csv", "b.csv", "--height-m", "7"]).unwrap_err().kind(), ErrorKind::UnknownArgument);
        // Exit code 2 for every usage error, as the tools agree.
        assert_eq!(missing_height.exit_code(), 2);
        let options = parse(&[
            "wind.csv",
            "--height-m",
            "7.11",
            "--fit-band",
            "0.3:3",
            "--column",
            "u_x_m_s",
            "--displacement-m",
            "3",
        ])
        .unwrap();
        let config = options.config().unwrap();
        assert_eq!(config.fit_band_hz, Some((0.3, 3.0)));
        assert_eq!(options.column, "u_x_m_s");
        assert_eq!(options.generated_column, None, "the generated record's column defaults to --column");
        assert!((config.effective_height_m() - 4.11).abs() < 1e-12);
        assert_eq!(options.generator_seed(), Some(1));
        let seeded = |extra: &[&str]| {
            let mut all = vec!["wind.csv", "--height-m", "7"];
            all.extend_from_slice(extra);
            parse(&all)
        };
        assert_eq!(seeded(&["--generator-seed", "42"]).unwrap().generator_seed(), Some(42));
        assert_eq!(seeded(&["--no-generator"]).unwrap().generator_seed(), None);
        assert!(seeded(&["--generator-seed", "-3"]).is_err());
        // Settings clap accepts but the analysis cannot use are invalid settings, negative
        // numbers included.
        let bad = seeded(&["--reference-z0-m", "20"]).unwrap().config().unwrap_err();
        assert!(matches!(bad, WindFitError::RoughnessAboveHeight { z0_m: 20.0, .. }), "{bad:?}");
        let negative = seeded(&["--segment-s", "-5"]).unwrap().config().unwrap_err();
        assert!(matches!(negative, WindFitError::NotPositive { setting: "segment length", .. }), "{negative:?}");
    }

    #[test]
    fn command_line_run_writes_report_plots_and_summary() {
        let dir = std::env::temp_dir().join(format!("antenna-tools-windfit-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let record = synthetic_record(|f| 0.02 * f.powf(KOLMOGOROV_SLOPE), 5.0, 900.0, 20.0, 4);
        let mut csv = String::from("time_s,horizontal_speed_m_s\n");
        for (t, v) in record.time_s.iter().zip(&record.speed_m_s) {
            csv.push_str(&format!("{t:.3},{v:.5}\n"));
        }
        let input = dir.join("record.csv");
        std::fs::write(&input, &csv).unwrap();
        let out = dir.join("out");
        let options = parse(&[
            input.to_str().unwrap(),
            "--height-m",
            "10",
            "--out-dir",
            out.to_str().unwrap(),
            "--generated",
            input.to_str().unwrap(),
        ])
        .unwrap();
        let report = run(&options).unwrap();
        assert!(report.contains("## Inertial subrange") && report.contains("generated (record.csv)"));
        // The fmu-wind generator is overlaid by default, before the list of files.
        let generator = report.find("## Generator (fmu-wind)").expect("no generator section");
        assert!(generator < report.find("## Files").unwrap());
        for name in ["report.md", "psd.png", "timeseries.png", "gust-summary.csv"] {
            assert!(out.join(name).exists(), "{name} not written");
        }
        let png = std::fs::read(out.join("psd.png")).unwrap();
        assert_eq!(&png[..8], b"\x89PNG\r\n\x1a\n");
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
