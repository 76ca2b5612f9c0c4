//! Pointing commands as the pointing model delivers them: a time-tagged `(t, az, el)` table,
//! interpolated by the master into a position and a rate for each axis.
//!
//! Between table points the command follows a cubic Hermite curve whose slopes are the
//! centred differences of the neighbouring points (Catmull-Rom), so position and rate are
//! continuous while tracking. A repeated time stamp marks a jump (a new source): the table is
//! split there, each side is interpolated on its own, and from that instant on the later point
//! holds. Azimuth must stay inside the cable wrap.

use std::cell::Cell;
use std::path::{Path, PathBuf};

/// Azimuth travel of the cable wrap, deg.
pub const CABLE_WRAP_DEG: (f64, f64) = (-185.0, 275.0);
/// Elevation travel, deg.
pub const ELEVATION_TRAVEL_DEG: (f64, f64) = (15.0, 92.0);

/// One row of a command table.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CommandPoint {
    pub time_s: f64,
    pub azimuth_deg: f64,
    pub elevation_deg: f64,
}

/// The command at one instant: position (deg) and rate (deg/s) of each axis.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Command {
    pub azimuth_deg: f64,
    pub azimuth_rate_deg_per_s: f64,
    pub elevation_deg: f64,
    pub elevation_rate_deg_per_s: f64,
}

/// Why a command table was refused: each message names the row (or file and line) and value.
#[derive(Debug, thiserror::Error)]
pub enum CommandError {
    #[error("the command table is empty")]
    Empty,
    #[error("command row {row}: values must be finite, got {point:?}")]
    NotFinite { row: usize, point: CommandPoint },
    #[error("command row {row}: azimuth {azimuth_deg} deg is outside the cable wrap [{}, {}] deg; choose the wrap side before commanding", CABLE_WRAP_DEG.0, CABLE_WRAP_DEG.1)]
    OutsideCableWrap { row: usize, azimuth_deg: f64 },
    #[error("command row {row}: elevation {elevation_deg} deg is outside the travel [{}, {}] deg", ELEVATION_TRAVEL_DEG.0, ELEVATION_TRAVEL_DEG.1)]
    OutsideTravel { row: usize, elevation_deg: f64 },
    #[error("command row {row}: time {time_s} s goes backwards")]
    TimeGoesBackwards { row: usize, time_s: f64 },
    #[error("{reason}")]
    Read { reason: fmu_runtime::files::FileError },
    #[error("{}", path.display())]
    Csv { path: PathBuf, source: csv::Error },
    #[error("{}:{line}: expected the header `time_s,azimuth_deg,elevation_deg`, found `{found}`", path.display())]
    Header { path: PathBuf, line: u64, found: String },
    #[error("{}:{line}: expected 3 cells, found {cells}", path.display())]
    CellCount { path: PathBuf, line: u64, cells: usize },
    #[error("{}:{line}: {column} `{cell}` is not a number", path.display())]
    NotANumber { path: PathBuf, line: u64, column: &'static str, cell: String },
}

/// The largest command table read, bytes (64 MiB: a day's table at 10 Hz is about 30 MB).
pub const MAX_COMMAND_FILE_BYTES: u64 = 64 << 20;

/// A validated command table, split into continuous segments at jumps.
#[derive(Debug, Clone, PartialEq)]
pub struct CommandTable {
    segments: Vec<Vec<CommandPoint>>,
    /// The interval the last look-up found: a master asks for increasing times, so the next
    /// answer is almost always in it or the next one (no search at 1 kHz).
    hint: Cell<usize>,
    /// The Hermite curves of the interval the last look-up used: at 1 kHz a table interval
    /// serves many steps, and its slopes and knot values need computing only once.
    piece: Cell<Option<Piece>>,
}

/// One interval's cubic Hermite curves, both axes: `[y0, y1, m0, m1]` with the slopes already
/// multiplied by the interval's length, as [`interpolate`] uses them.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Piece {
    segment: usize,
    t0: f64,
    t1: f64,
    azimuth: [f64; 4],
    elevation: [f64; 4],
}

impl CommandTable {
    /// Checks the table: at least one point, finite values, non-decreasing time, azimuth in
    /// the cable wrap, elevation in travel; an error names the row.
    pub fn new(points: Vec<CommandPoint>) -> Result<Self, CommandError> {
        if points.is_empty() {
            return Err(CommandError::Empty);
        }
        for (i, p) in points.iter().enumerate() {
            let row = i + 1;
            if !(p.time_s.is_finite() && p.azimuth_deg.is_finite() && p.elevation_deg.is_finite()) {
                return Err(CommandError::NotFinite { row, point: *p });
            }
            if !(CABLE_WRAP_DEG.0..=CABLE_WRAP_DEG.1).contains(&p.azimuth_deg) {
                return Err(CommandError::OutsideCableWrap { row, azimuth_deg: p.azimuth_deg });
            }
            if !(ELEVATION_TRAVEL_DEG.0..=ELEVATION_TRAVEL_DEG.1).contains(&p.elevation_deg) {
                return Err(CommandError::OutsideTravel { row, elevation_deg: p.elevation_deg });
            }
            if i > 0 && p.time_s < points[i - 1].time_s {
                return Err(CommandError::TimeGoesBackwards { row, time_s: p.time_s });
            }
        }
        let mut segments: Vec<Vec<CommandPoint>> = vec![Vec::new()];
        for p in points {
            let current = segments.last_mut().expect("one segment at least");
            if current.last().is_some_and(|q| q.time_s == p.time_s) {
                segments.push(vec![p]);
            } else {
                current.push(p);
            }
        }
        Ok(CommandTable { segments, hint: Cell::new(0), piece: Cell::new(None) })
    }

    /// Reads a CSV table with columns `time_s,azimuth_deg,elevation_deg` (a header row first;
    /// `#` comment lines and blank lines allowed; cells may be padded with spaces).
    pub fn from_csv(path: &Path) -> Result<Self, CommandError> {
        let text = fmu_runtime::files::read_regular_file(path, MAX_COMMAND_FILE_BYTES, "command table")
            .map_err(|reason| CommandError::Read { reason })?;
        let mut reader = csv::ReaderBuilder::new()
            .has_headers(false)
            .flexible(true)
            .trim(csv::Trim::All)
            .comment(Some(b'#'))
            .from_reader(text.as_bytes());
        let mut points = Vec::new();
        let mut header_seen = false;
        for record in reader.records() {
            let record = record.map_err(|source| CommandError::Csv { path: path.into(), source })?;
            let line = record.position().map_or(0, |p| p.line());
            // An indented comment or a line of spaces: the csv reader only knows comments that
            // start the line and empty lines.
            if record.get(0).is_some_and(|c| c.starts_with('#')) || record.iter().all(str::is_empty) {
                continue;
            }
            if !header_seen {
                if record.iter().collect::<Vec<_>>() != ["time_s", "azimuth_deg", "elevation_deg"] {
                    let found = record.iter().collect::<Vec<_>>().join(",");
                    return Err(CommandError::Header { path: path.into(), line, found });
                }
                header_seen = true;
                continue;
            }
            if record.len() != 3 {
                return Err(CommandError::CellCount { path: path.into(), line, cells: record.len() });
            }
            let parse = |k: usize, column: &'static str| {
                record[k].parse::<f64>().map_err(|_| CommandError::NotANumber {
                    path: path.into(),
                    line,
                    column,
                    cell: record[k].to_string(),
                })
            };
            points.push(CommandPoint {
                time_s: parse(0, "time_s")?,
                azimuth_deg: parse(1, "azimuth_deg")?,
                elevation_deg: parse(2, "elevation_deg")?,
            });
        }
        Self::new(points)
    }

    /// All points in order (a jump shows as two points with the same time).
    pub fn points(&self) -> Vec<CommandPoint> {
        self.segments.iter().flatten().copied().collect()
    }

    /// Writes the table as the CSV that [`CommandTable::from_csv`] reads, with every digit
    /// (`{:e}`: the shortest text that reads back to the same number).
    pub fn to_csv(&self) -> String {
        let mut writer = csv::Writer::from_writer(Vec::new());
        let mut write = || -> Result<(), csv::Error> {
            writer.write_record(["time_s", "azimuth_deg", "elevation_deg"])?;
            for p in self.points() {
                writer.write_record([p.time_s, p.azimuth_deg, p.elevation_deg].map(|x| format!("{x:e}")))?;
            }
            writer.flush()?;
            Ok(())
        };
        write().expect("writing CSV into memory cannot fail");
        String::from_utf8(writer.into_inner().expect("flushed above")).expect("the CSV is ASCII")
    }

    /// The first and last time stamps.
    pub fn time_span(&self) -> (f64, f64) {
        let first = self.segments.first().and_then(|s| s.first()).expect("not empty").time_s;
        let last = self.segments.last().and_then(|s| s.last()).expect("not empty").time_s;
        (first, last)
    }

    /// The times at which the command jumps.
    pub fn jump_times(&self) -> Vec<f64> {
        self.segments.iter().skip(1).map(|s| s[0].time_s).collect()
    }

    /// The interpolated command at `t`. Before the table the first point holds, after it the
    /// last; both with zero rate.
    pub fn at(&self, t: f64) -> Command {
        // The segment in force: the last one that has started.
        let index = self.segments.partition_point(|s| s[0].time_s <= t).saturating_sub(1);
        let segment = &self.segments[index];
        let n = segment.len();
        let inside = n > 1 && t > segment[0].time_s && t < segment[n - 1].time_s;
        let (az, el) = match self.piece.get() {
            // Inside the segment the interval holding t is the one with t0 <= t < t1: the
            // cached curves are the ones `interpolate` would build.
            Some(p) if inside && p.segment == index && p.t0 <= t && t < p.t1 => {
                (hermite(&p.azimuth, p.t0, p.t1, t), hermite(&p.elevation, p.t0, p.t1, t))
            }
            _ => {
                let interval = interval_of(segment, t, self.hint.get());
                self.hint.set(interval);
                if inside {
                    let (t0, t1) = (segment[interval].time_s, segment[interval + 1].time_s);
                    let azimuth = hermite_knots(segment, interval, |p| p.azimuth_deg);
                    let elevation = hermite_knots(segment, interval, |p| p.elevation_deg);
                    self.piece.set(Some(Piece { segment: index, t0, t1, azimuth, elevation }));
                }
                (
                    interpolate(segment, interval, t, |p| p.azimuth_deg),
                    interpolate(segment, interval, t, |p| p.elevation_deg),
                )
            }
        };
        Command { azimuth_deg: az.0, azimuth_rate_deg_per_s: az.1, elevation_deg: el.0, elevation_rate_deg_per_s: el.1 }
    }
}

/// The index `i` of the interval `[t_i, t_{i+1})` holding `t` (clamped to the ends), trying
/// the hinted interval and its successor before searching.
fn interval_of(points: &[CommandPoint], t: f64, hint: usize) -> usize {
    let n = points.len();
    if n < 2 || t <= points[0].time_s {
        return 0;
    }
    if t >= points[n - 1].time_s {
        return n - 2;
    }
    let holds = |i: usize| i + 1 < n && points[i].time_s <= t && t < points[i + 1].time_s;
    if holds(hint) {
        hint
    } else if holds(hint + 1) {
        hint + 1
    } else {
        points.partition_point(|p| p.time_s <= t) - 1
    }
}

/// Catmull-Rom cubic Hermite interpolation of one coordinate on interval `i`: (value,
/// derivative).
fn interpolate(points: &[CommandPoint], i: usize, t: f64, value: impl Fn(&CommandPoint) -> f64) -> (f64, f64) {
    let n = points.len();
    if n == 1 || t <= points[0].time_s {
        return (value(&points[0]), 0.0);
    }
    if t >= points[n - 1].time_s {
        return (value(&points[n - 1]), 0.0);
    }
    hermite(&hermite_knots(points, i, value), points[i].time_s, points[i + 1].time_s, t)
}

/// `[y0, y1, m0, m1]` of interval `i` (inside the segment): the knot values and the
/// Catmull-Rom slopes times the interval's length.
fn hermite_knots(points: &[CommandPoint], i: usize, value: impl Fn(&CommandPoint) -> f64) -> [f64; 4] {
    let n = points.len();
    let slope = |k: usize| -> f64 {
        let (a, b) = (k.saturating_sub(1), (k + 1).min(n - 1));
        (value(&points[b]) - value(&points[a])) / (points[b].time_s - points[a].time_s)
    };
    let h = points[i + 1].time_s - points[i].time_s;
    [value(&points[i]), value(&points[i + 1]), slope(i) * h, slope(i + 1) * h]
}

/// The cubic Hermite curve with knots `[y0, y1, m0, m1]` on `[t0, t1]` at `t`: (value,
/// derivative).
///
/// Written as `y0` plus the change, so that a constant stretch of the table (`y0 == y1`, zero
/// slopes) gives exactly `y0` and a rate of exactly zero: the textbook form
/// `h00 y0 + h01 y1 + ...` leaves rounding noise of about 1e-15 deg there, and a controller that
/// asks whether the command has changed (the anti-limit-cycle hold) would see a moving command.
fn hermite(&[y0, y1, m0, m1]: &[f64; 4], t0: f64, t1: f64, t: f64) -> (f64, f64) {
    let h = t1 - t0;
    let s = (t - t0) / h;
    let s2 = s * s;
    let s3 = s2 * s;
    let change = y1 - y0;
    let position = y0 + (-2.0 * s3 + 3.0 * s2) * change + (s3 - 2.0 * s2 + s) * m0 + (s3 - s2) * m1;
    let rate = ((-6.0 * s2 + 6.0 * s) * change + (3.0 * s2 - 4.0 * s + 1.0) * m0 + (3.0 * s2 - 2.0 * s) * m1) / h;
    (position, rate)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_constant_stretch_of_the_table_is_exactly_constant() {
        let p = |t: f64, az: f64| CommandPoint { time_s: t, azimuth_deg: az, elevation_deg: 45.123456789 };
        let table = CommandTable::new((0..50).map(|k| p(0.1 * k as f64, 30.0 + 1e-7 / 3.0)).collect()).unwrap();
        for k in 0..4900 {
            let c = table.at(1e-3 * k as f64 + 1e-4 / 3.0);
            assert_eq!((c.azimuth_deg, c.elevation_deg), (30.0 + 1e-7 / 3.0, 45.123456789), "at sample {k}");
            assert_eq!((c.azimuth_rate_deg_per_s, c.elevation_rate_deg_per_s), (0.0, 0.0), "at sample {k}");
        }
    }

    fn point(t: f64, az: f64, el: f64) -> CommandPoint {
        CommandPoint { time_s: t, azimuth_deg: az, elevation_deg: el }
    }

    #[test]
    fn a_linear_track_is_interpolated_exactly_with_its_rate() {
        let table = CommandTable::new(
            (0..=100)
                .map(|k| point(0.1 * k as f64, 10.0 + 0.004 * 0.1 * k as f64, 45.0 - 0.002 * 0.1 * k as f64))
                .collect(),
        )
        .unwrap();
        for t in [0.05, 1.234, 5.0, 9.95] {
            let c = table.at(t);
            assert!((c.azimuth_deg - (10.0 + 0.004 * t)).abs() < 1e-12, "t = {t}");
            assert!((c.azimuth_rate_deg_per_s - 0.004).abs() < 1e-10);
            assert!((c.elevation_rate_deg_per_s + 0.002).abs() < 1e-10);
        }
    }

    #[test]
    fn a_repeated_time_stamp_is_a_jump_without_smearing() {
        let table = CommandTable::new(vec![
            point(0.0, 10.0, 45.0),
            point(5.0, 10.0, 45.0),
            point(5.0, 14.0, 45.0),
            point(20.0, 14.0, 45.0),
        ])
        .unwrap();
        assert_eq!(table.at(4.999).azimuth_deg, 10.0);
        assert_eq!(table.at(5.0).azimuth_deg, 14.0);
        assert_eq!(table.at(5.0).azimuth_rate_deg_per_s, 0.0);
        assert_eq!(table.jump_times(), vec![5.0]);
    }

    #[test]
    fn commands_outside_the_cable_wrap_or_travel_are_rejected_naming_the_row() {
        let e = CommandTable::new(vec![point(0.0, 10.0, 45.0), point(1.0, 280.0, 45.0)]).unwrap_err();
        let text = e.to_string();
        assert!(text.contains("row 2") && text.contains("cable wrap"), "{e}");
        let e = CommandTable::new(vec![point(0.0, 10.0, 10.0)]).unwrap_err();
        assert!(e.to_string().contains("travel"), "{e}");
        let e = CommandTable::new(vec![point(1.0, 10.0, 45.0), point(0.5, 10.0, 45.0)]).unwrap_err();
        assert!(e.to_string().contains("backwards"), "{e}");
        assert!(CommandTable::new(vec![]).is_err());
    }

    #[test]
    fn a_table_written_as_csv_reads_back_identically_with_comments_and_padding() {
        let table = CommandTable::new(vec![
            point(0.0, 10.0, 45.0),
            point(5.0, 10.000_000_000_000_002, 45.0),
            point(5.0, 14.0, 45.0),
            point(20.0, 14.0, 45.5),
        ])
        .unwrap();
        let text = format!("# a pointing table\n\n{}", table.to_csv().replace(',', " , "));
        let path = std::env::temp_dir().join(format!("command-table-{}.csv", std::process::id()));
        std::fs::write(&path, text).unwrap();
        let read = CommandTable::from_csv(&path);
        let _ = std::fs::remove_file(&path);
        assert_eq!(read.unwrap().points(), table.points());
    }

    #[test]
    fn a_malformed_csv_table_is_refused_naming_the_line() {
        let path = std::env::temp_dir().join(format!("command-table-bad-{}.csv", std::process::id()));
        let mut errors = Vec::new();
        for text in [
            "time,az,el\n0,10,45\n",
            "time_s,azimuth_deg,elevation_deg\n0,10\n",
            "time_s,azimuth_deg,elevation_deg\n# comment\n0,10,45\n1,x,45\n",
        ] {
            std::fs::write(&path, text).unwrap();
            errors.push(CommandTable::from_csv(&path).unwrap_err().to_string());
        }
        let _ = std::fs::remove_file(&path);
        assert!(
            errors[0].ends_with(":1: expected the header `time_s,azimuth_deg,elevation_deg`, found `time,az,el`"),
            "{}",
            errors[0]
        );
        assert!(errors[1].ends_with(":2: expected 3 cells, found 2"), "{}", errors[1]);
        assert!(errors[2].ends_with(":4: azimuth_deg `x` is not a number"), "{}", errors[2]);
    }
}
