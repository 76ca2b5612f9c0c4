//! Reading a wind record: a CSV table with a header line, a time column and a speed column,
//! checked for uniform sampling, with errors that name the line and column at fault.

use crate::error::WindFitError;
use std::path::Path;

/// Column read by default: the horizontal wind speed.
pub const DEFAULT_SPEED_COLUMN: &str = "horizontal_speed_m_s";

/// Time column read by default, in seconds.
pub const DEFAULT_TIME_COLUMN: &str = "time_s";

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

/// A cell as the record means it: surrounding blanks and double quotes removed, so a header
/// written `"time_s", "speed"` names the columns `time_s` and `speed`.
fn clean_cell(cell: &str) -> String {
    cell.trim().trim_matches('"').trim().to_string()
}

/// True for a row that holds no data: blank, or a comment whose `#` follows blanks (the CSV
/// reader skips a `#` only at the very start of a line).
fn is_blank_or_comment(row: &csv::StringRecord) -> bool {
    match row.get(0) {
        None => true,
        Some(first) => (row.len() == 1 && first.trim().is_empty()) || first.trim_start().starts_with('#'),
    }
}

/// The rows of `text` that hold data, each with its 1-based line number in the text.
fn data_rows(text: &str) -> Result<Vec<(usize, Vec<String>)>, WindFitError> {
    let mut reader =
        csv::ReaderBuilder::new().has_headers(false).flexible(true).comment(Some(b'#')).from_reader(text.as_bytes());
    let mut rows = Vec::new();
    for row in reader.records() {
        let row = row.map_err(|error| WindFitError::Malformed {
            line: error.position().map_or(0, |p| p.line() as usize),
            message: error.to_string(),
        })?;
        if is_blank_or_comment(&row) {
            continue;
        }
        let line = row.position().map_or(0, |p| p.line() as usize);
        rows.push((line, row.iter().map(clean_cell).collect()));
    }
    Ok(rows)
}

/// A cell as a finite number, or the error that names its line and column.
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
    let mut rows = data_rows(text)?.into_iter();
    let (_, header) = rows.next().ok_or(WindFitError::NoHeader)?;
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
    for (line, cells) in rows {
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

/// The largest wind record read, bytes (256 MiB: a day at 20 Hz with five columns is about
/// 150 MB).
pub const MAX_WIND_RECORD_BYTES: u64 = 256 << 20;

/// Reads a wind record from a CSV file (see [`parse_wind_csv`]).
pub fn read_wind_csv(path: &Path, time_column: &str, speed_column: &str) -> Result<WindRecord, WindFitError> {
    let text = fmu_runtime::files::read_regular_file(path, MAX_WIND_RECORD_BYTES, "wind record")
        .map_err(|e| WindFitError::Io { path: path.display().to_string(), message: e.to_string() })?;
    parse_wind_csv(&text, &path.display().to_string(), time_column, speed_column)
}

#[cfg(test)]
mod tests {
    use super::*;

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

    #[test]
    fn quoted_commas_and_indented_comments_do_not_break_the_columns() {
        let text =
            "time_s,note,horizontal_speed_m_s\n  # indented comment\n0.0,\"calm, dry\",2.0\n0.5,x,2.1\n1.0,y,2.2\n";
        let record = parse_wind_csv(text, "test", DEFAULT_TIME_COLUMN, DEFAULT_SPEED_COLUMN).unwrap();
        assert_eq!(record.speed_m_s, vec![2.0, 2.1, 2.2]);
        let error = parse_wind_csv(&text.replace("0.5,x", "0.5,z"), "t", DEFAULT_TIME_COLUMN, "nope").unwrap_err();
        assert!(matches!(error, WindFitError::MissingColumn { .. }));
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
}
