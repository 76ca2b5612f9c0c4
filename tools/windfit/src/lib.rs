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
pub use config::{WindFitConfig, PAPER_Z0_M};
pub use davenport::{DavenportSpectrum, DAVENPORT_LENGTH_M};
pub use error::WindFitError;
pub use figures::{spectrum_figure, time_series_figure};
pub use generator::{compare_generator, generator_markdown, ComparisonCurve, GeneratorComparison};
pub use record::{parse_wind_csv, read_wind_csv, WindRecord, DEFAULT_SPEED_COLUMN, DEFAULT_TIME_COLUMN};
pub use report::{gust_summary_csv, report_markdown};
pub use spectrum_fit::{Identifiability, ImpliedDavenport, LevelFit, LocalSlope, SlopeFit, KOLMOGOROV_SLOPE};
pub use statistics::{predict_gust, BlockStatistics, GustPrediction, PeriodSummary, RecordStatistics};

#[cfg(test)]
pub(crate) mod test_records {
    //! Records for the tests of every module: synthetic ones with a known spectrum, and the
    //! measured one the repository ships (tests/data/measured/).
    use crate::record::WindRecord;
    use antenna_dsp::test_signals::process_with_psd;
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

    /// The measured 20 Hz sonic anemometer record shipped with the repository.
    pub(crate) fn measured_wind_record() -> PathBuf {
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/data/measured/sonic-anemometer-20hz/wind_20hz.csv")
    }
}
