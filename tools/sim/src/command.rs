//! Pointing commands as the pointing model delivers them: a time-tagged `(t, az, el)` table,
//! interpolated by the master into a position and a rate for each axis.
//!
//! Between table points the command follows a cubic Hermite curve whose slopes are the
//! centred differences of the neighbouring points (Catmull-Rom), so position and rate are
//! continuous while tracking. A repeated time stamp marks a jump (a new source): the table is
//! split there, each side is interpolated on its own, and from that instant on the later point
//! holds. Azimuth must stay inside the cable wrap.

use std::cell::Cell;
use std::fmt;
use std::path::Path;

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

#[derive(Debug, Clone, PartialEq)]
pub struct CommandError(pub String);

impl fmt::Display for CommandError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for CommandError {}

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
            return Err(CommandError("the command table is empty".into()));
        }
        for (i, p) in points.iter().enumerate() {
            let row = i + 1;
            if !(p.time_s.is_finite() && p.azimuth_deg.is_finite() && p.elevation_deg.is_finite()) {
                return Err(CommandError(format!("command row {row}: values must be finite, got {p:?}")));
            }
            if !(CABLE_WRAP_DEG.0..=CABLE_WRAP_DEG.1).contains(&p.azimuth_deg) {
                return Err(CommandError(format!(
                    "command row {row}: azimuth {} deg is outside the cable wrap [{}, {}] deg; choose the wrap side before commanding",
                    p.azimuth_deg, CABLE_WRAP_DEG.0, CABLE_WRAP_DEG.1
                )));
            }
            if !(ELEVATION_TRAVEL_DEG.0..=ELEVATION_TRAVEL_DEG.1).contains(&p.elevation_deg) {
                return Err(CommandError(format!(
                    "command row {row}: elevation {} deg is outside the travel [{}, {}] deg",
                    p.elevation_deg, ELEVATION_TRAVEL_DEG.0, ELEVATION_TRAVEL_DEG.1
                )));
            }
            if i > 0 && p.time_s < points[i - 1].time_s {
                return Err(CommandError(format!("command row {row}: time {} s goes backwards", p.time_s)));
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
    /// `#` comment lines allowed).
    pub fn from_csv(path: &Path) -> Result<Self, CommandError> {
        let text = std::fs::read_to_string(path).map_err(|e| CommandError(format!("{}: {e}", path.display())))?;
        let mut points = Vec::new();
        let mut header_seen = false;
        for (i, line) in text.lines().enumerate() {
            let line = line.trim();
            if line.is_empty() || line.starts_with('#') {
                continue;
            }
            if !header_seen {
                let columns: Vec<&str> = line.split(',').map(str::trim).collect();
                if columns != ["time_s", "azimuth_deg", "elevation_deg"] {
                    return Err(CommandError(format!(
                        "{}:{}: expected the header `time_s,azimuth_deg,elevation_deg`, found `{line}`",
                        path.display(),
                        i + 1
                    )));
                }
                header_seen = true;
                continue;
            }
            let cells: Vec<&str> = line.split(',').map(str::trim).collect();
            if cells.len() != 3 {
                return Err(CommandError(format!(
                    "{}:{}: expected 3 cells, found {}",
                    path.display(),
                    i + 1,
                    cells.len()
                )));
            }
            let parse = |k: usize, name: &str| {
                cells[k].parse::<f64>().map_err(|_| {
                    CommandError(format!("{}:{}: {name} `{}` is not a number", path.display(), i + 1, cells[k]))
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

    /// Writes the table as the CSV that [`CommandTable::from_csv`] reads, with every digit.
    pub fn to_csv(&self) -> String {
        let mut out = String::from("time_s,azimuth_deg,elevation_deg\n");
        for p in self.points() {
            out.push_str(&format!("{:e},{:e},{:e}\n", p.time_s, p.azimuth_deg, p.elevation_deg));
        }
        out
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
fn hermite(&[y0, y1, m0, m1]: &[f64; 4], t0: f64, t1: f64, t: f64) -> (f64, f64) {
    let h = t1 - t0;
    let s = (t - t0) / h;
    let s2 = s * s;
    let s3 = s2 * s;
    let position =
        (2.0 * s3 - 3.0 * s2 + 1.0) * y0 + (s3 - 2.0 * s2 + s) * m0 + (-2.0 * s3 + 3.0 * s2) * y1 + (s3 - s2) * m1;
    let rate = ((6.0 * s2 - 6.0 * s) * y0
        + (3.0 * s2 - 4.0 * s + 1.0) * m0
        + (-6.0 * s2 + 6.0 * s) * y1
        + (3.0 * s2 - 2.0 * s) * m1)
        / h;
    (position, rate)
}

#[cfg(test)]
mod tests {
    use super::*;

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
        assert!(e.0.contains("row 2") && e.0.contains("cable wrap"), "{e}");
        let e = CommandTable::new(vec![point(0.0, 10.0, 10.0)]).unwrap_err();
        assert!(e.0.contains("travel"), "{e}");
        let e = CommandTable::new(vec![point(1.0, 10.0, 45.0), point(0.5, 10.0, 45.0)]).unwrap_err();
        assert!(e.0.contains("backwards"), "{e}");
        assert!(CommandTable::new(vec![]).is_err());
    }
}
