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

use antenna_dsp::{
    self, autocorrelation, digamma, kurtosis_excess, log_band_average, max_moving_average, moving_average, skewness,
    standard_normal_quantile, trigamma, weighted_linear_regression, welch_psd, window_samples, BandSpectrum, DspError,
    Spectrum, WelchConfig,
};
use antenna_dsp as dsp;
use antenna_plot::{Colour, Figure, LegendPosition, Panel, PlotError, Series};
use std::fmt::{self, Write as _};
use std::path::{Path, PathBuf};

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

/// Why a record could not be read or analysed. Messages name the file line and column.
#[derive(Debug, Clone, PartialEq)]
pub enum WindFitError {
    /// The file could not be read.
    Io {
        /// Path of the file.
        path: String,
        /// The operating system's message.
        message: String,
    },
    /// The input has no header line.
    NoHeader,
    /// A requested column is not in the header.
    MissingColumn {
        /// The requested column.
        column: String,
        /// The columns the header has.
        available: Vec<String>,
    },
    /// A data line has a different number of cells from the header.
    RowLength {
        /// 1-based line number in the file.
        line: usize,
        /// Cells in the header.
        expected: usize,
        /// Cells in this line.
        found: usize,
    },
    /// A cell is empty or not a number.
    NonNumeric {
        /// 1-based line number in the file.
        line: usize,
        /// Column name.
        column: String,
        /// The cell's text.
        text: String,
    },
    /// A cell is NaN or infinite.
    NonFinite {
        /// 1-based line number in the file.
        line: usize,
        /// Column name.
        column: String,
        /// The cell's text.
        text: String,
    },
    /// Time does not increase from the previous data line to this one.
    NonIncreasingTime {
        /// 1-based line number in the file.
        line: usize,
        /// Time on the previous data line, s.
        previous_s: f64,
        /// Time on this line, s.
        current_s: f64,
    },
    /// The time step to this line differs from the record's typical step (a gap or a jitter
    /// that spectral estimation cannot handle).
    IrregularSampling {
        /// 1-based line number in the file.
        line: usize,
        /// The step to this line, s.
        step_s: f64,
        /// The record's median step, s.
        expected_s: f64,
    },
    /// The record is too short for the analysis.
    TooShort {
        /// What needs more data.
        reason: String,
    },
    /// A configuration value is out of range.
    InvalidConfig(String),
    /// A signal-processing step failed.
    Analysis(String),
    /// A plot could not be drawn or written.
    Plot(String),
}

impl fmt::Display for WindFitError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            WindFitError::Io { path, message } => write!(f, "cannot read {path}: {message}"),
            WindFitError::NoHeader => write!(f, "no header line: the CSV is empty"),
            WindFitError::MissingColumn { column, available } => {
                write!(f, "column '{column}' not found; the header has: {}", available.join(", "))
            }
            WindFitError::RowLength { line, expected, found } => {
                write!(f, "line {line}: {found} cells, but the header has {expected}")
            }
            WindFitError::NonNumeric { line, column, text } if text.is_empty() => {
                write!(f, "line {line}, column '{column}': empty cell")
            }
            WindFitError::NonNumeric { line, column, text } => {
                write!(f, "line {line}, column '{column}': '{text}' is not a number")
            }
            WindFitError::NonFinite { line, column, text } => {
                write!(f, "line {line}, column '{column}': '{text}' is not a finite number")
            }
            WindFitError::NonIncreasingTime { line, previous_s, current_s } => {
                write!(f, "line {line}, time column: time {current_s} s does not increase from {previous_s} s on the line before")
            }
            WindFitError::IrregularSampling { line, step_s, expected_s } => write!(
                f,
                "line {line}, time column: step of {step_s} s differs from the record's step of {expected_s} s (gap or jitter); spectra need uniform sampling"
            ),
            WindFitError::TooShort { reason } => write!(f, "record too short: {reason}"),
            WindFitError::InvalidConfig(message) => write!(f, "invalid setting: {message}"),
            WindFitError::Analysis(message) => write!(f, "analysis failed: {message}"),
            WindFitError::Plot(message) => write!(f, "{message}"),
        }
    }
}

impl std::error::Error for WindFitError {}

impl From<DspError> for WindFitError {
    fn from(error: DspError) -> Self {
        WindFitError::Analysis(error.to_string())
    }
}

impl From<PlotError> for WindFitError {
    fn from(error: PlotError) -> Self {
        WindFitError::Plot(error.to_string())
    }
}

/// A uniformly sampled wind-speed record.
#[derive(Debug, Clone, PartialEq)]
pub struct WindRecord {
    /// Where it came from (file path or a description).
    pub source: String,
    /// Name of the speed column.
    pub column: String,
    /// Sample times, s.
    pub time_s: Vec<f64>,
    /// Wind speed, m/s.
    pub speed_m_s: Vec<f64>,
    /// 1 / median time step, Hz.
    pub sample_rate_hz: f64,
}

impl WindRecord {
    /// A record from samples at a known rate (e.g. a generated one), times from 0.
    pub fn from_samples(source: &str, speed_m_s: Vec<f64>, sample_rate_hz: f64) -> Self {
        let time_s = (0..speed_m_s.len()).map(|i| i as f64 / sample_rate_hz).collect();
        Self { source: source.to_string(), column: "speed".to_string(), time_s, speed_m_s, sample_rate_hz }
    }

    /// Record length: samples times the sampling interval, s.
    pub fn duration_s(&self) -> f64 {
        self.speed_m_s.len() as f64 / self.sample_rate_hz
    }
}

/// Splits a CSV line into trimmed cells with surrounding double quotes removed. Wind records
/// are plain numeric tables, so quoted commas are not supported.
fn split_cells(line: &str) -> Vec<String> {
    line.split(',').map(|cell| cell.trim().trim_matches('"').trim().to_string()).collect()
}

fn parse_cell(text: &str, line: usize, column: &str) -> Result<f64, WindFitError> {
    let value: f64 = text.parse().map_err(|_| WindFitError::NonNumeric {
        line,
        column: column.to_string(),
        text: text.to_string(),
    })?;
    if value.is_finite() {
        Ok(value)
    } else {
        Err(WindFitError::NonFinite { line, column: column.to_string(), text: text.to_string() })
    }
}

/// Parses a wind record from CSV text with a header line, taking the time from
/// `time_column` (s) and the speed from `speed_column` (m/s).
///
/// Blank lines and lines starting with `#` are skipped; line numbers in errors count every
/// line of the text from 1. Time must increase strictly and uniformly (each step within 1 % of
/// the median step), because spectral estimation needs uniform sampling.
pub fn parse_wind_csv(
    text: &str,
    source: &str,
    time_column: &str,
    speed_column: &str,
) -> Result<WindRecord, WindFitError> {
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let mut lines = text.lines().enumerate().map(|(i, l)| (i + 1, l)).filter(|(_, l)| {
        let trimmed = l.trim();
        !trimmed.is_empty() && !trimmed.starts_with('#')
    });
    let (_, header_line) = lines.next().ok_or(WindFitError::NoHeader)?;
    let header = split_cells(header_line);
    let find = |name: &str| {
        header
            .iter()
            .position(|h| h == name)
            .ok_or_else(|| WindFitError::MissingColumn { column: name.to_string(), available: header.clone() })
    };
    let time_index = find(time_column)?;
    let speed_index = find(speed_column)?;

    let mut time_s = Vec::new();
    let mut speed_m_s = Vec::new();
    let mut line_numbers = Vec::new();
    for (line, content) in lines {
        let cells = split_cells(content);
        if cells.len() != header.len() {
            return Err(WindFitError::RowLength { line, expected: header.len(), found: cells.len() });
        }
        let t = parse_cell(&cells[time_index], line, time_column)?;
        let v = parse_cell(&cells[speed_index], line, speed_column)?;
        if let Some(&previous) = time_s.last() {
            if t <= previous {
                return Err(WindFitError::NonIncreasingTime { line, previous_s: previous, current_s: t });
            }
        }
        time_s.push(t);
        speed_m_s.push(v);
        line_numbers.push(line);
    }
    if time_s.len() < 3 {
        return Err(WindFitError::TooShort {
            reason: format!("{} data lines, at least 3 needed to establish the sampling", time_s.len()),
        });
    }
    let steps: Vec<f64> = time_s.windows(2).map(|w| w[1] - w[0]).collect();
    let mut sorted = steps.clone();
    sorted.sort_by(f64::total_cmp);
    let median_step = sorted[sorted.len() / 2];
    if let Some(i) = steps.iter().position(|s| (s - median_step).abs() > 0.01 * median_step) {
        return Err(WindFitError::IrregularSampling {
            line: line_numbers[i + 1],
            step_s: steps[i],
            expected_s: median_step,
        });
    }
    Ok(WindRecord {
        source: source.to_string(),
        column: speed_column.to_string(),
        time_s,
        speed_m_s,
        sample_rate_hz: 1.0 / median_step,
    })
}

/// Reads a wind record from a CSV file (see [`parse_wind_csv`]).
pub fn read_wind_csv(path: &Path, time_column: &str, speed_column: &str) -> Result<WindRecord, WindFitError> {
    let text = std::fs::read_to_string(path)
        .map_err(|e| WindFitError::Io { path: path.display().to_string(), message: e.to_string() })?;
    parse_wind_csv(&text, &path.display().to_string(), time_column, speed_column)
}

/// The Davenport spectrum of the paper's Eq. 2, one-sided per Hz:
/// S(n) = 4 kappa v_m^2 x^2 / (n (1 + x^2)^(4/3)), x = L n / v_m, L = 1200 m.
///
/// Kept local (a few lines) because the fitting works with kappa directly, where
/// `fmu_wind::davenport::Davenport` is parametrised by z and z0; both implement the same
/// formula, and [`compare_generator`] checks the fmu-wind filter against it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DavenportSpectrum {
    /// Mean wind speed, m/s.
    pub v_mean_m_s: f64,
    /// Surface drag coefficient kappa = 1 / (2.5 ln(z / z0))^2.
    pub kappa: f64,
}

impl DavenportSpectrum {
    /// kappa for height `z_m` and roughness length `z0_m`.
    pub fn kappa_for_roughness(z_m: f64, z0_m: f64) -> f64 {
        1.0 / (2.5 * (z_m / z0_m).ln()).powi(2)
    }

    /// The roughness length z0 that gives `kappa` at height `z_m` (inverse of
    /// [`DavenportSpectrum::kappa_for_roughness`]).
    pub fn roughness_for_kappa(z_m: f64, kappa: f64) -> f64 {
        z_m * (-1.0 / (2.5 * kappa.sqrt())).exp()
    }

    /// The spectrum for mean speed `v_mean_m_s` at height `z_m` over roughness `z0_m`.
    pub fn from_roughness(v_mean_m_s: f64, z_m: f64, z0_m: f64) -> Self {
        Self { v_mean_m_s, kappa: Self::kappa_for_roughness(z_m, z0_m) }
    }

    /// The spectrum whose inertial-subrange asymptote is `level * n^(-5/3)` (see
    /// [`DavenportSpectrum::inertial_level`]).
    pub fn from_inertial_level(v_mean_m_s: f64, level: f64) -> Self {
        let kappa = level * DAVENPORT_LENGTH_M.powf(2.0 / 3.0) / (4.0 * v_mean_m_s.powf(8.0 / 3.0));
        Self { v_mean_m_s, kappa }
    }

    /// One-sided PSD per Hz at frequency `n_hz` ((m/s)^2/Hz).
    pub fn psd(&self, n_hz: f64) -> f64 {
        if n_hz <= 0.0 {
            return 0.0;
        }
        let x = DAVENPORT_LENGTH_M * n_hz / self.v_mean_m_s;
        4.0 * self.kappa * self.v_mean_m_s.powi(2) * x * x / (n_hz * (1.0 + x * x).powf(4.0 / 3.0))
    }

    /// Total variance, the integral of the PSD: 6 kappa v_m^2.
    pub fn variance(&self) -> f64 {
        6.0 * self.kappa * self.v_mean_m_s.powi(2)
    }

    /// Variance below frequency `n_hz`: 6 kappa v_m^2 (1 - (1 + x^2)^(-1/3)).
    pub fn variance_below(&self, n_hz: f64) -> f64 {
        let x = DAVENPORT_LENGTH_M * n_hz.max(0.0) / self.v_mean_m_s;
        self.variance() * (1.0 - (1.0 + x * x).powf(-1.0 / 3.0))
    }

    /// Frequency of the maximum of S(n): dS/dn = 0 at x^2 = 3/5, so n = sqrt(3/5) v_m / L.
    pub fn peak_frequency_hz(&self) -> f64 {
        (3.0f64 / 5.0).sqrt() * self.v_mean_m_s / DAVENPORT_LENGTH_M
    }

    /// Frequency of the maximum of n S(n), the peak on a log-frequency axis (where most
    /// variance lives per decade): x^2 = 3, n = sqrt(3) v_m / L.
    pub fn premultiplied_peak_frequency_hz(&self) -> f64 {
        3.0f64.sqrt() * self.v_mean_m_s / DAVENPORT_LENGTH_M
    }

    /// Coefficient A of the high-frequency asymptote S(n) ~ A n^(-5/3) (x >> 1):
    /// A = 4 kappa v_m^(8/3) / L^(2/3).
    pub fn inertial_level(&self) -> f64 {
        4.0 * self.kappa * self.v_mean_m_s.powf(8.0 / 3.0) / DAVENPORT_LENGTH_M.powf(2.0 / 3.0)
    }
}

/// Settings of the analysis.
#[derive(Debug, Clone, PartialEq)]
pub struct WindFitConfig {
    /// Instrument height above ground, m.
    pub height_m: f64,
    /// Zero-plane displacement (about 2/3 of a canopy's height), m; Eq. 2 as printed uses
    /// z itself (displacement 0), over a canopy z - d is the usual effective height.
    pub displacement_m: f64,
    /// Roughness length of the reference curve (the paper's 0.4 m by default), m.
    pub reference_z0_m: f64,
    /// Welch segment length, s (at most a third of the record is used, see
    /// [`WindFitConfig::segment_samples`]).
    pub segment_s: f64,
    /// Log-frequency bands per decade for plotting and fitting.
    pub bands_per_decade: f64,
    /// Inertial-subrange fit range, Hz; `None` chooses it from the record (see
    /// [`WindFitConfig::fit_band`]).
    pub fit_band_hz: Option<(f64, f64)>,
    /// Gust averaging time, s (3 s for the 3-second gust).
    pub gust_window_s: f64,
    /// Confidence level of intervals (0.95).
    pub confidence: f64,
    /// Averaging periods for the turbulence-intensity and gust-factor summary, s.
    pub averaging_periods_s: Vec<f64>,
}

impl WindFitConfig {
    /// Defaults for an instrument at `height_m`: no displacement, the paper's z0 = 0.4 m as
    /// reference, 600-s Welch segments, 10 bands per decade, automatic fit range, 3-s gusts,
    /// 95 % confidence, summary over 1, 5, 10 and 30 min.
    pub fn new(height_m: f64) -> Self {
        Self {
            height_m,
            displacement_m: 0.0,
            reference_z0_m: PAPER_Z0_M,
            segment_s: 600.0,
            bands_per_decade: 10.0,
            fit_band_hz: None,
            gust_window_s: 3.0,
            confidence: 0.95,
            averaging_periods_s: vec![60.0, 300.0, 600.0, 1800.0],
        }
    }

    /// Height used in kappa = 1 / (2.5 ln((z - d) / z0))^2.
    pub fn effective_height_m(&self) -> f64 {
        self.height_m - self.displacement_m
    }

    /// Welch segment length in samples: `segment_s`, but at most a third of the record so that
    /// at least five half-overlapping segments are averaged.
    pub fn segment_samples(&self, record_len: usize, sample_rate_hz: f64) -> usize {
        window_samples(self.segment_s, sample_rate_hz).min(record_len / 3)
    }

    /// The inertial-subrange fit range: the configured one, or from `v_mean / (z - d)` (where
    /// the inertial subrange of the longitudinal spectrum starts, n (z - d) / v_m near 1 in
    /// Kaimal et al. 1972) up to an eighth of the sample rate (aliasing of a -5/3 tail adds
    /// less than 4 % there, 7^(-5/3); sonic path averaging also starts to act near the top).
    pub fn fit_band(&self, v_mean_m_s: f64, sample_rate_hz: f64) -> (f64, f64) {
        self.fit_band_hz.unwrap_or((v_mean_m_s / self.effective_height_m(), sample_rate_hz / 8.0))
    }

    fn validate(&self) -> Result<(), WindFitError> {
        let positive = |name: &str, value: f64| {
            if value > 0.0 && value.is_finite() {
                Ok(())
            } else {
                Err(WindFitError::InvalidConfig(format!("{name} must be positive, got {value}")))
            }
        };
        positive("height", self.height_m)?;
        positive("effective height (height - displacement)", self.effective_height_m())?;
        positive("reference z0", self.reference_z0_m)?;
        positive("segment length", self.segment_s)?;
        positive("bands per decade", self.bands_per_decade)?;
        positive("gust window", self.gust_window_s)?;
        if self.reference_z0_m >= self.effective_height_m() {
            return Err(WindFitError::InvalidConfig(format!(
                "reference z0 {} m must be below the effective height {} m",
                self.reference_z0_m,
                self.effective_height_m()
            )));
        }
        if !(self.confidence > 0.0 && self.confidence < 1.0) {
            return Err(WindFitError::InvalidConfig(format!(
                "confidence must lie between 0 and 1, got {}",
                self.confidence
            )));
        }
        if let Some((low, high)) = self.fit_band_hz {
            if !(low > 0.0 && high > low) {
                return Err(WindFitError::InvalidConfig(format!(
                    "fit band {low}..{high} Hz must be positive and increasing"
                )));
            }
        }
        Ok(())
    }
}

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
/// This is the same formulation as fmu_wind::davenport::expected_gust, so a generator's PSD
/// passed here is comparable with the measured row.
pub fn predict_gust(
    label: &str,
    psd: &dyn Fn(f64) -> f64,
    v_mean_m_s: f64,
    period_s: f64,
    gust_window_s: f64,
    upper_hz: f64,
) -> GustPrediction {
    let sinc2 = |a: f64| {
        if a.abs() < 1e-8 {
            1.0
        } else {
            (a.sin() / a).powi(2)
        }
    };
    let pi = std::f64::consts::PI;
    // Composite Simpson in u = ln n, from far below the record's high-pass corner to the upper
    // limit, fine enough to follow the sinc^2 oscillations.
    let (u_low, u_high) = ((1e-4 / period_s).ln(), upper_hz.ln());
    let intervals = 40_000usize;
    let du = (u_high - u_low) / intervals as f64;
    let (mut m_record, mut m0, mut m2) = (0.0, 0.0, 0.0);
    for k in 0..=intervals {
        let n = (u_low + k as f64 * du).exp();
        let simpson = if k == 0 || k == intervals {
            1.0
        } else if k % 2 == 1 {
            4.0
        } else {
            2.0
        };
        let in_record = psd(n) * (1.0 - sinc2(pi * n * period_s)) * n;
        let averaged = in_record * sinc2(pi * n * gust_window_s);
        m_record += simpson * in_record;
        m0 += simpson * averaged;
        m2 += simpson * averaged * n * n;
    }
    let scale = du / 3.0;
    let (m_record, m0, m2) = (m_record * scale, m0 * scale, m2 * scale);
    let crossing_rate_hz = (m2 / m0).sqrt();
    let a = (2.0 * (crossing_rate_hz * period_s).max(std::f64::consts::E).ln()).sqrt();
    let peak_factor = a + 0.5772 / a;
    let gust_window_sigma_m_s = m0.sqrt();
    let gust_m_s = v_mean_m_s + peak_factor * gust_window_sigma_m_s;
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
fn davenport_record_variance_per_kappa(v_mean_m_s: f64, period_s: f64, gust_window_s: f64) -> f64 {
    let unit = DavenportSpectrum { v_mean_m_s, kappa: 1.0 };
    let prediction = predict_gust("", &|n| unit.psd(n), v_mean_m_s, period_s, gust_window_s, 1e3 / gust_window_s);
    prediction.sigma_m_s.powi(2)
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

fn fit_slope(bands: &BandSpectrum, band_hz: (f64, f64), confidence: f64) -> Result<SlopeFit, WindFitError> {
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

fn fit_level(bands: &BandSpectrum, band_hz: (f64, f64)) -> LevelFit {
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

fn local_slopes(bands: &BandSpectrum) -> Vec<LocalSlope> {
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

fn record_statistics(record: &WindRecord, config: &WindFitConfig) -> Result<RecordStatistics, WindFitError> {
    let speed = &record.speed_m_s;
    let fs = record.sample_rate_hz;
    let mean = dsp::mean(speed);
    if mean.is_nan() || mean <= 0.0 {
        return Err(WindFitError::Analysis(format!(
            "mean speed {mean} m/s is not positive, so turbulence intensity and gust factor are undefined"
        )));
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
fn interpolate_log_log<'a>(frequency_hz: &'a [f64], psd: &'a [f64]) -> impl Fn(f64) -> f64 + 'a {
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

fn identifiability(statistics: &RecordStatistics, spectrum: &Spectrum) -> Identifiability {
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

fn period_summaries(
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
    let davenport = Davenport::new(v_mean, config.effective_height_m(), analysis.implied.z0_m)
        .map_err(|e| WindFitError::InvalidConfig(format!("generator: {e}")))?;
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
fn log_grid(low: f64, high: f64, per_decade: usize) -> Vec<f64> {
    let decades = (high / low).log10();
    let count = (decades * per_decade as f64).ceil().max(1.0) as usize;
    (0..=count).map(|i| low * 10f64.powf(decades * i as f64 / count as f64)).collect()
}

/// Draws the measured PSD (raw Welch bins, band averages with their confidence band), Eq. 2
/// for the fitted kappa and for the reference z0, the fitted slope and the -5/3 line, with
/// `overlays` on top; below it the premultiplied spectrum n S(n), which shows where the
/// variance lies relative to the Davenport peak.
pub fn spectrum_figure(analysis: &WindAnalysis, overlays: &[ComparisonCurve]) -> Result<Figure, WindFitError> {
    let statistics = &analysis.statistics;
    let v = statistics.mean_m_s;
    let (lower, upper) = analysis.bands.confidence_band(analysis.config.confidence)?;
    let nyquist = 0.5 * statistics.sample_rate_hz;
    let identifiability = &analysis.identifiability;
    let grid = log_grid(
        (0.3 * identifiability.peak_hz).min(0.5 * analysis.identifiability.record_fundamental_hz),
        nyquist,
        40,
    );
    let fitted = DavenportSpectrum { v_mean_m_s: v, kappa: analysis.implied.kappa };
    let reference = DavenportSpectrum { v_mean_m_s: v, kappa: analysis.kappa_reference };
    let variance_matched = DavenportSpectrum { v_mean_m_s: v, kappa: analysis.kappa_from_variance };
    let evaluate = |model: &DavenportSpectrum| grid.iter().map(|&n| model.psd(n)).collect::<Vec<f64>>();
    let (fit_low, fit_high) = analysis.slope.band_hz;
    let fit_x = log_grid(fit_low, fit_high, 20);
    let fit_line: Vec<f64> = fit_x
        .iter()
        .map(|&n| analysis.slope.psd_at_pivot * (n / analysis.slope.pivot_hz).powf(analysis.slope.slope))
        .collect();
    let kolmogorov_x = log_grid(fit_low / 3.0, (fit_high * 3.0).min(nyquist), 20);
    let kolmogorov_line: Vec<f64> =
        kolmogorov_x.iter().map(|&n| analysis.level.level * n.powf(KOLMOGOROV_SLOPE)).collect();
    let height = analysis.config.effective_height_m();
    let percent = (100.0 * analysis.config.confidence).round();

    let raw: Vec<(f64, f64)> =
        analysis.spectrum.frequency_hz.iter().copied().zip(analysis.spectrum.psd.iter().copied()).skip(1).collect();
    let (raw_f, raw_p): (Vec<f64>, Vec<f64>) = raw.into_iter().unzip();
    let mut psd_panel = Panel::new(&format!(
        "{} PSD, {} (mean {:.2} m/s, {:.0} s)",
        analysis.column,
        file_name(&analysis.source),
        v,
        statistics.duration_s
    ))
    .x_label("Frequency (Hz)")
    .y_label("PSD ((m/s)²/Hz)")
    .log_x()
    .log_y()
    .series(Series::new("Welch bins", &raw_f, &raw_p).colour(Colour::rgb(200, 200, 200)).width(1))
    .line_with_band(
        "measured (band average)",
        &analysis.bands.frequency_hz,
        &analysis.bands.psd,
        &lower,
        &upper,
        &format!("{percent:.0} % confidence"),
    )
    .series(
        Series::new(&format!("Eq. 2, κ = {:.3} (from -5/3 level)", fitted.kappa), &grid, &evaluate(&fitted)).dashed(),
    )
    .series(
        Series::new(
            &format!("Eq. 2, κ = {:.3} (matches variance)", variance_matched.kappa),
            &grid,
            &evaluate(&variance_matched),
        )
        .dashed(),
    )
    .series(
        Series::new(
            &format!(
                "Eq. 2, z0 = {} m at {:.2} m (κ = {:.4})",
                analysis.config.reference_z0_m, height, reference.kappa
            ),
            &grid,
            &evaluate(&reference),
        )
        .dotted(),
    )
    .series(
        Series::new("-5/3 at fitted level", &kolmogorov_x, &kolmogorov_line)
            .colour(Colour::rgb(0, 0, 0))
            .dashed()
            .width(1),
    )
    .series(
        Series::new(
            &format!("fit: slope {:.2} ± {:.2}", analysis.slope.slope, analysis.slope.slope_std_error),
            &fit_x,
            &fit_line,
        )
        .colour(Colour::rgb(0, 0, 0))
        .width(3),
    )
    .vertical_line(&format!("Davenport peak {:.2} mHz", 1e3 * identifiability.peak_hz), identifiability.peak_hz)
    .vertical_line("1 / record length", identifiability.record_fundamental_hz);
    let mut premultiplied = Panel::new("Premultiplied spectrum: variance per log-frequency interval")
        .x_label("Frequency (Hz)")
        .y_label("n·S(n) ((m/s)²)")
        .log_x()
        .legend(LegendPosition::UpperRight);
    let times_n = |f: &[f64], p: &[f64]| f.iter().zip(p).map(|(a, b)| a * b).collect::<Vec<f64>>();
    premultiplied = premultiplied
        .series(
            Series::new(
                "measured",
                &analysis.bands.frequency_hz,
                &times_n(&analysis.bands.frequency_hz, &analysis.bands.psd),
            )
            .with_markers(),
        )
        .series(Series::new("Eq. 2, κ from -5/3 level", &grid, &times_n(&grid, &evaluate(&fitted))).dashed())
        .series(
            Series::new("Eq. 2, κ matching variance", &grid, &times_n(&grid, &evaluate(&variance_matched))).dashed(),
        )
        .series(Series::new("Eq. 2, reference z0", &grid, &times_n(&grid, &evaluate(&reference))).dotted());
    for overlay in overlays {
        psd_panel = psd_panel.line(&overlay.name, &overlay.frequency_hz, &overlay.psd);
        premultiplied =
            premultiplied.line(&overlay.name, &overlay.frequency_hz, &times_n(&overlay.frequency_hz, &overlay.psd));
    }
    premultiplied = premultiplied
        .vertical_line("Davenport n·S(n) peak", identifiability.premultiplied_peak_hz)
        .vertical_line("1 / record length", identifiability.record_fundamental_hz);
    Ok(Figure::new(1100, 1200).panel(psd_panel).panel(premultiplied))
}

/// The record over time with its gust-window moving average and block means.
pub fn time_series_figure(record: &WindRecord, analysis: &WindAnalysis) -> Figure {
    let fs = record.sample_rate_hz;
    let t0 = record.time_s[0];
    let time: Vec<f64> = record.time_s.iter().map(|t| t - t0).collect();
    let window = window_samples(analysis.config.gust_window_s, fs).max(1);
    let averaged = moving_average(&record.speed_m_s, window);
    // The average over samples i..i+w is plotted at the window's centre.
    let centre: Vec<f64> = (0..averaged.len()).map(|i| time[i] + 0.5 * (window - 1) as f64 / fs).collect();
    let mut panel = Panel::new(&format!("{} from {}", record.column, file_name(&record.source)))
        .x_label("Time from start (s)")
        .y_label("Speed (m/s)")
        .series(Series::new("measured", &time, &record.speed_m_s).colour(Colour::rgb(170, 190, 215)).width(1))
        .series(
            Series::new(&format!("{} s moving average", analysis.config.gust_window_s), &centre, &averaged).width(2),
        );
    if let Some(minute) = analysis.periods.iter().find(|p| (p.period_s - 60.0).abs() < 1e-9) {
        let (x, y): (Vec<f64>, Vec<f64>) = minute.blocks.iter().map(|b| (b.start_s + 30.0, b.mean_m_s)).unzip();
        panel = panel.series(Series::new("1-min means", &x, &y).markers_only());
    }
    let gust_label = format!("{} s gust {:.2} m/s", analysis.config.gust_window_s, analysis.statistics.gust_m_s);
    panel = panel
        .horizontal_line(&format!("mean {:.2} m/s", analysis.statistics.mean_m_s), analysis.statistics.mean_m_s)
        .vertical_line(&gust_label, analysis.statistics.gust_time_s + 0.5 * analysis.config.gust_window_s);
    Figure::new(1400, 500).panel(panel)
}

fn file_name(source: &str) -> String {
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

/// The report as Markdown. `files` lists the files written beside it (may be empty).
pub fn report_markdown(analysis: &WindAnalysis, overlays: &[ComparisonCurve], files: &[PathBuf]) -> String {
    let s = &analysis.statistics;
    let c = &analysis.config;
    let slope = &analysis.slope;
    let level = &analysis.level;
    let implied = &analysis.implied;
    let id = &analysis.identifiability;
    let percent = 100.0 * c.confidence;
    let height = c.effective_height_m();
    let mut r = String::new();
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

/// Command-line options of the `windfit` tool.
#[derive(Debug, Clone, PartialEq)]
pub struct CliOptions {
    /// The measured record.
    pub input: PathBuf,
    /// Speed column.
    pub column: String,
    /// Time column.
    pub time_column: String,
    /// Analysis settings.
    pub config: WindFitConfig,
    /// Where the report, PNGs and CSV go.
    pub out_dir: PathBuf,
    /// A generated record (same CSV layout) to overlay.
    pub generated: Option<PathBuf>,
    /// Speed column of the generated record.
    pub generated_column: String,
    /// Seed of the fmu-wind generator overlay; `None` leaves the generator out.
    pub generator_seed: Option<u64>,
}

/// Usage text of the `windfit` tool.
pub const USAGE: &str = "\
usage: windfit RECORD.csv --height-m Z [options]

Analyses a measured wind-speed record: mean, standard deviation, turbulence intensity,
3-s gust and gust factor; Welch PSD with confidence band; the inertial-subrange slope and
level with uncertainties; the Davenport (Eq. 2) kappa and z0 the level implies; why the
spectral peak is (not) identifiable; gust statistics against Eq. 2. Writes report.md,
psd.png, timeseries.png and gust-summary.csv to the output directory and prints the report.

options:
  --height-m Z            instrument height above ground, m (required)
  --displacement-m D      zero-plane displacement, m; Eq. 2 then uses z - d (default 0)
  --column NAME           speed column (default horizontal_speed_m_s)
  --time-column NAME      time column in s (default time_s)
  --reference-z0-m Z0     roughness of the reference Eq. 2 curve (default 0.4, the paper's)
  --segment-s S           Welch segment length, s (default 600)
  --bands-per-decade B    log-frequency bands per decade (default 10)
  --fit-band LOW:HIGH     inertial-subrange fit range, Hz (default v_m/(z-d) to fs/8)
  --gust-window-s T       gust averaging time, s (default 3)
  --generated PATH        overlay a generated record (same CSV layout) on the spectrum
  --generated-column NAME speed column of the generated record (default: --column)
  --generator-seed N      seed of the fmu-wind generator overlay: our Davenport filter for the
                          fitted kappa, exact and as a generated record of the same length and
                          rate (default 1)
  --no-generator          leave the fmu-wind generator overlay out
  --out-dir DIR           output directory (default out/windfit)
  -h, --help              this text

example (from the repository root):
  cargo run --release -p antenna-cli --bin windfit -- \\
      ../shared/data/sonic-anemometer-20hz/wind_20hz.csv --height-m 7.11
";

/// Parses the command-line arguments (without the program name). `Ok(None)` means help was
/// asked for.
pub fn parse_cli_args(args: &[String]) -> Result<Option<CliOptions>, WindFitError> {
    let mut input = None;
    let mut height = None;
    let mut column = DEFAULT_SPEED_COLUMN.to_string();
    let mut time_column = DEFAULT_TIME_COLUMN.to_string();
    let mut generated_column = None;
    let mut generated = None;
    let mut generator_seed = Some(1);
    let mut out_dir = PathBuf::from("out/windfit");
    let mut config = WindFitConfig::new(f64::NAN);
    let mut iter = args.iter();
    let number = |flag: &str, value: Option<&String>| -> Result<f64, WindFitError> {
        let text = value.ok_or_else(|| WindFitError::InvalidConfig(format!("{flag} needs a value")))?;
        text.parse::<f64>().map_err(|_| WindFitError::InvalidConfig(format!("{flag}: '{text}' is not a number")))
    };
    let text = |flag: &str, value: Option<&String>| -> Result<String, WindFitError> {
        value.cloned().ok_or_else(|| WindFitError::InvalidConfig(format!("{flag} needs a value")))
    };
    while let Some(arg) = iter.next() {
        match arg.as_str() {
            "-h" | "--help" => return Ok(None),
            "--height-m" => height = Some(number(arg, iter.next())?),
            "--displacement-m" => config.displacement_m = number(arg, iter.next())?,
            "--column" => column = text(arg, iter.next())?,
            "--time-column" => time_column = text(arg, iter.next())?,
            "--reference-z0-m" => config.reference_z0_m = number(arg, iter.next())?,
            "--segment-s" => config.segment_s = number(arg, iter.next())?,
            "--bands-per-decade" => config.bands_per_decade = number(arg, iter.next())?,
            "--gust-window-s" => config.gust_window_s = number(arg, iter.next())?,
            "--fit-band" => {
                let value = text(arg, iter.next())?;
                let (low, high) = value
                    .split_once(':')
                    .and_then(|(a, b)| Some((a.parse::<f64>().ok()?, b.parse::<f64>().ok()?)))
                    .ok_or_else(|| {
                        WindFitError::InvalidConfig(format!("--fit-band: '{value}' is not LOW:HIGH in Hz"))
                    })?;
                config.fit_band_hz = Some((low, high));
            }
            "--generated" => generated = Some(PathBuf::from(text(arg, iter.next())?)),
            "--generated-column" => generated_column = Some(text(arg, iter.next())?),
            "--generator-seed" => {
                let value = text(arg, iter.next())?;
                generator_seed = Some(value.parse::<u64>().map_err(|_| {
                    WindFitError::InvalidConfig(format!("--generator-seed: '{value}' is not a non-negative integer"))
                })?);
            }
            "--no-generator" => generator_seed = None,
            "--out-dir" => out_dir = PathBuf::from(text(arg, iter.next())?),
            flag if flag.starts_with('-') => return Err(WindFitError::InvalidConfig(format!("unknown option {flag}"))),
            path => {
                if input.replace(PathBuf::from(path)).is_some() {
                    return Err(WindFitError::InvalidConfig("more than one input record given".into()));
                }
            }
        }
    }
    let input = input.ok_or_else(|| WindFitError::InvalidConfig("no input record given".into()))?;
    config.height_m = height.ok_or_else(|| {
        WindFitError::InvalidConfig("--height-m is required: kappa and z0 depend on the instrument height (7.11 m for the sonic-anemometer record)".into())
    })?;
    config.validate()?;
    Ok(Some(CliOptions {
        input,
        generated_column: generated_column.unwrap_or_else(|| column.clone()),
        column,
        time_column,
        config,
        out_dir,
        generated,
        generator_seed,
    }))
}

/// Runs the tool: reads, analyses, writes the report, plots and summary into the output
/// directory, and returns the report text.
pub fn run_cli(options: &CliOptions) -> Result<String, WindFitError> {
    let record = read_wind_csv(&options.input, &options.time_column, &options.column)?;
    let analysis = analyse(&record, &options.config)?;
    let mut overlays = Vec::new();
    if let Some(path) = &options.generated {
        let generated = read_wind_csv(path, &options.time_column, &options.generated_column)?;
        overlays.push(ComparisonCurve::from_record(
            &format!("generated ({})", file_name(&path.display().to_string())),
            &generated.speed_m_s,
            generated.sample_rate_hz,
            &options.config,
        )?);
    }
    let generator = match options.generator_seed {
        Some(seed) => Some(compare_generator(&record, &analysis, seed)?),
        None => None,
    };
    if let Some(comparison) = &generator {
        overlays.extend(comparison.curves.iter().cloned());
    }
    std::fs::create_dir_all(&options.out_dir)
        .map_err(|e| WindFitError::Io { path: options.out_dir.display().to_string(), message: e.to_string() })?;
    let psd_path = options.out_dir.join("psd.png");
    let series_path = options.out_dir.join("timeseries.png");
    let summary_path = options.out_dir.join("gust-summary.csv");
    let report_path = options.out_dir.join("report.md");
    spectrum_figure(&analysis, &overlays)?.save_png(&psd_path)?;
    time_series_figure(&record, &analysis).save_png(&series_path)?;
    let write = |path: &Path, text: &str| {
        std::fs::write(path, text)
            .map_err(|e| WindFitError::Io { path: path.display().to_string(), message: e.to_string() })
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
    use antenna_dsp::test_signals::process_with_psd;

    /// A record of a stationary Gaussian process with one-sided PSD `psd` plus `v_mean`: the
    /// middle quarter of a circularly synthesised record four times as long, so it behaves like
    /// a piece of an endless process rather than one period of a periodic one.
    fn synthetic_record(
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
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data/sonic-anemometer-20hz/wind_20hz.csv");
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

    const GOOD_CSV: &str =
        "time_s,u_x_m_s,horizontal_speed_m_s\n0.00,1.0,2.0\n0.05,1.1,2.1\n0.10,1.2,2.2\n0.15,1.3,2.3\n";

    #[test]
    fn well_formed_csv_with_comments_bom_quotes_and_crlf_is_read() {
        let text = "\u{feff}# a comment\r\n\"time_s\", \"u_x_m_s\" ,horizontal_speed_m_s\r\n\r\n0.00,1.0,2.0\r\n0.05,1.1,2.1\r\n0.10,1.2,2.2\r\n";
        let record = parse_wind_csv(text, "test", DEFAULT_TIME_COLUMN, DEFAULT_SPEED_COLUMN).unwrap();
        assert_eq!(record.speed_m_s, vec![2.0, 2.1, 2.2]);
        assert!((record.sample_rate_hz - 20.0).abs() < 1e-9);
        let other = parse_wind_csv(GOOD_CSV, "test", DEFAULT_TIME_COLUMN, "u_x_m_s").unwrap();
        assert_eq!(other.speed_m_s[3], 1.3);
        assert!((other.duration_s() - 0.2).abs() < 1e-12);
    }

    fn parse(text: &str) -> WindFitError {
        parse_wind_csv(text, "test", DEFAULT_TIME_COLUMN, DEFAULT_SPEED_COLUMN).unwrap_err()
    }

    #[test]
    fn missing_column_error_lists_the_header() {
        let error = parse("time_s,speed\n0,1\n1,2\n2,3\n");
        assert_eq!(
            error,
            WindFitError::MissingColumn {
                column: DEFAULT_SPEED_COLUMN.into(),
                available: vec!["time_s".into(), "speed".into()]
            }
        );
        assert!(error.to_string().contains("horizontal_speed_m_s") && error.to_string().contains("time_s, speed"));
    }

    #[test]
    fn non_numeric_cell_error_names_line_and_column() {
        let error = parse(&GOOD_CSV.replace("0.10,1.2,2.2", "0.10,1.2,fast"));
        assert_eq!(
            error,
            WindFitError::NonNumeric { line: 4, column: DEFAULT_SPEED_COLUMN.into(), text: "fast".into() }
        );
        assert_eq!(error.to_string(), "line 4, column 'horizontal_speed_m_s': 'fast' is not a number");
        let empty = parse(&GOOD_CSV.replace("0.05,1.1,2.1", "0.05,1.1,"));
        assert_eq!(empty.to_string(), "line 3, column 'horizontal_speed_m_s': empty cell");
    }

    #[test]
    fn nan_and_infinite_cells_are_rejected_with_their_line() {
        let error = parse(&GOOD_CSV.replace("0.10,1.2,2.2", "0.10,1.2,NaN"));
        assert_eq!(error, WindFitError::NonFinite { line: 4, column: DEFAULT_SPEED_COLUMN.into(), text: "NaN".into() });
        let time = parse(&GOOD_CSV.replace("0.15,1.3,2.3", "inf,1.3,2.3"));
        assert!(matches!(time, WindFitError::NonFinite { line: 5, ref column, .. } if column == "time_s"));
    }

    #[test]
    fn non_increasing_time_names_the_line() {
        let error = parse(&GOOD_CSV.replace("0.10,1.2,2.2", "0.05,1.2,2.2"));
        assert_eq!(error, WindFitError::NonIncreasingTime { line: 4, previous_s: 0.05, current_s: 0.05 });
        assert!(error.to_string().starts_with("line 4, time column"));
    }

    #[test]
    fn a_gap_in_time_is_irregular_sampling_at_its_line() {
        let error = parse(&GOOD_CSV.replace("0.15,1.3,2.3", "0.25,1.3,2.3"));
        assert!(matches!(error, WindFitError::IrregularSampling { line: 5, .. }), "{error:?}");
    }

    #[test]
    fn short_rows_empty_files_and_headers_alone_are_errors() {
        assert_eq!(
            parse(&GOOD_CSV.replace("0.05,1.1,2.1", "0.05,1.1")),
            WindFitError::RowLength { line: 3, expected: 3, found: 2 }
        );
        assert_eq!(parse(""), WindFitError::NoHeader);
        assert_eq!(parse("\n# only a comment\n"), WindFitError::NoHeader);
        assert!(matches!(parse("time_s,horizontal_speed_m_s\n"), WindFitError::TooShort { .. }));
    }

    #[test]
    fn missing_file_is_an_io_error_naming_the_path() {
        let error =
            read_wind_csv(Path::new("/nonexistent/wind.csv"), DEFAULT_TIME_COLUMN, DEFAULT_SPEED_COLUMN).unwrap_err();
        assert!(matches!(&error, WindFitError::Io { path, .. } if path == "/nonexistent/wind.csv"));
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

    fn args(list: &[&str]) -> Vec<String> {
        list.iter().map(|s| s.to_string()).collect()
    }

    #[test]
    fn command_line_requires_a_record_and_a_height_and_rejects_unknown_options() {
        assert_eq!(parse_cli_args(&args(&["--help"])).unwrap(), None);
        let missing_height = parse_cli_args(&args(&["wind.csv"])).unwrap_err();
        assert!(missing_height.to_string().contains("--height-m is required"));
        assert!(parse_cli_args(&args(&["--height-m", "7"])).unwrap_err().to_string().contains("no input record"));
        assert!(parse_cli_args(&args(&["wind.csv", "--height-m", "7", "--frobnicate"]))
            .unwrap_err()
            .to_string()
            .contains("unknown option --frobnicate"));
        assert!(parse_cli_args(&args(&["wind.csv", "--height-m", "seven"]))
            .unwrap_err()
            .to_string()
            .contains("'seven' is not a number"));
        assert!(parse_cli_args(&args(&["wind.csv", "--height-m", "7", "--fit-band", "0.3-3"])).is_err());
        let options = parse_cli_args(&args(&[
            "wind.csv",
            "--height-m",
            "7.11",
            "--fit-band",
            "0.3:3",
            "--column",
            "u_x_m_s",
            "--displacement-m",
            "3",
        ]))
        .unwrap()
        .unwrap();
        assert_eq!(options.config.fit_band_hz, Some((0.3, 3.0)));
        assert_eq!(options.column, "u_x_m_s");
        assert_eq!(options.generated_column, "u_x_m_s");
        assert!((options.config.effective_height_m() - 4.11).abs() < 1e-12);
        assert_eq!(options.generator_seed, Some(1));
        let seeded = |extra: &[&str]| {
            let mut all = vec!["wind.csv", "--height-m", "7"];
            all.extend_from_slice(extra);
            parse_cli_args(&args(&all))
        };
        assert_eq!(seeded(&["--generator-seed", "42"]).unwrap().unwrap().generator_seed, Some(42));
        assert_eq!(seeded(&["--no-generator"]).unwrap().unwrap().generator_seed, None);
        assert!(seeded(&["--generator-seed", "-3"])
            .unwrap_err()
            .to_string()
            .contains("'-3' is not a non-negative integer"));
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
        let options = parse_cli_args(&args(&[
            input.to_str().unwrap(),
            "--height-m",
            "10",
            "--out-dir",
            out.to_str().unwrap(),
            "--generated",
            input.to_str().unwrap(),
        ]))
        .unwrap()
        .unwrap();
        let report = run_cli(&options).unwrap();
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
