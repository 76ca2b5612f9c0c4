//! The one error type of the wind-record analysis. Messages name the file, line, column or
//! setting at fault; signal-processing, wind-model and plotting failures are carried as their
//! own typed errors, all comparable in tests.

use antenna_dsp::DspError;
use antenna_plot::PlotError;
use fmu_wind::error::WindError;

/// Why a record could not be read or analysed. Messages name the file line and column.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum WindFitError {
    /// The file could not be read.
    #[error("cannot read {path}: {message}")]
    Io {
        /// Path of the file.
        path: String,
        /// The operating system's message.
        message: String,
    },
    /// The input has no header line.
    #[error("no header line: the CSV is empty")]
    NoHeader,
    /// A requested column is not in the header.
    #[error("column '{column}' not found; the header has: {}", .available.join(", "))]
    MissingColumn {
        /// The requested column.
        column: String,
        /// The columns the header has.
        available: Vec<String>,
    },
    /// The CSV reader could not read a line (for instance an unterminated quote).
    #[error("line {line}: {message}")]
    Malformed {
        /// 1-based line number in the file.
        line: usize,
        /// The reader's message.
        message: String,
    },
    /// A data line has a different number of cells from the header.
    #[error("line {line}: {found} cells, but the header has {expected}")]
    RowLength {
        /// 1-based line number in the file.
        line: usize,
        /// Cells in the header.
        expected: usize,
        /// Cells in this line.
        found: usize,
    },
    /// A cell is empty or not a number.
    #[error("line {line}, column '{column}': {}", describe_non_numeric(.text))]
    NonNumeric {
        /// 1-based line number in the file.
        line: usize,
        /// Column name.
        column: String,
        /// The cell's text.
        text: String,
    },
    /// A cell is NaN or infinite.
    #[error("line {line}, column '{column}': '{text}' is not a finite number")]
    NonFinite {
        /// 1-based line number in the file.
        line: usize,
        /// Column name.
        column: String,
        /// The cell's text.
        text: String,
    },
    /// Time does not increase from the previous data line to this one.
    #[error("line {line}, time column: time {current_s} s does not increase from {previous_s} s on the line before")]
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
    #[error(
        "line {line}, time column: step of {step_s} s differs from the record's step of {expected_s} s (gap or jitter); spectra need uniform sampling"
    )]
    IrregularSampling {
        /// 1-based line number in the file.
        line: usize,
        /// The step to this line, s.
        step_s: f64,
        /// The record's median step, s.
        expected_s: f64,
    },
    /// The record is too short for the analysis.
    #[error("record too short: {reason}")]
    TooShort {
        /// What needs more data.
        reason: String,
    },
    /// A setting that must be a positive, finite number is not.
    #[error("invalid setting: {setting} must be positive, got {value}")]
    NotPositive {
        /// The setting's name.
        setting: &'static str,
        /// The value given.
        value: f64,
    },
    /// The reference roughness length is not below the height it is judged at.
    #[error("invalid setting: reference z0 {z0_m} m must be below the effective height {effective_height_m} m")]
    RoughnessAboveHeight {
        /// The reference roughness length, m.
        z0_m: f64,
        /// The instrument's height less the displacement, m.
        effective_height_m: f64,
    },
    /// The confidence level is not within (0, 1).
    #[error("invalid setting: confidence must lie between 0 and 1, got {0}")]
    Confidence(f64),
    /// The fit band is not positive and increasing.
    #[error("invalid setting: fit band {low_hz}..{high_hz} Hz must be positive and increasing")]
    FitBand {
        /// Its lower edge, Hz.
        low_hz: f64,
        /// Its upper edge, Hz.
        high_hz: f64,
    },
    /// The record's mean speed is not positive, so turbulence intensity and gust factor are
    /// undefined.
    #[error(
        "analysis failed: mean speed {0} m/s is not positive, so turbulence intensity and gust factor are undefined"
    )]
    MeanSpeedNotPositive(f64),
    /// A signal-processing step failed.
    #[error("analysis failed: {0}")]
    Dsp(#[from] DspError),
    /// The wind model refused the record's fitted values as a generator's parameters.
    #[error("generator: {0}")]
    Generator(#[from] WindError),
    /// An output file or folder could not be written.
    #[error("cannot write {path}: {message}")]
    Write {
        /// Path of the file or folder.
        path: String,
        /// The operating system's message.
        message: String,
    },
    /// A plot could not be drawn or written.
    #[error(transparent)]
    Plot(#[from] PlotError),
}

/// The reason of a [`WindFitError::NonNumeric`]: an empty cell says so rather than quoting it.
fn describe_non_numeric(text: &str) -> String {
    if text.is_empty() {
        "empty cell".to_string()
    } else {
        format!("'{text}' is not a number")
    }
}
