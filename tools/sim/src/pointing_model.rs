//! A pointing-model correction table, as the antenna control unit of a real telescope applies
//! one: the pointing error the model predicts from what the telescope knows (the commanded
//! azimuth and elevation, and the mean wind a weather station reports), added to the command so
//! that the beam lands on the target.
//!
//! The table holds the repeatable parts of the error budget (`budget.rs`), each on its own grid:
//!
//! * `encoder` rows, over commanded azimuth and elevation: the encoders' graduation and
//!   eccentricity errors (and whatever else a calm day repeats at a position);
//! * `flexure` rows, over the mean wind speed, the wind's direction relative to the dish (where
//!   the wind comes from minus the azimuth, 0-360 deg) and the elevation: the beam's static
//!   deflection under a steady wind, with what the servo leaves of it.
//!
//! The prediction is the sum of the two, each interpolated linearly in every grid coordinate
//! (bilinear over the encoder grid, trilinear over the flexure grid), held at the grid's edge
//! outside it; the wind direction wraps. Over the wind speed the interpolation is linear in the
//! speed's square, as the wind's loads are (`fmu-wind`'s `v |v|`): between grid speeds a plain
//! linear one would overstate the flexure at 2.9 m/s by a third on a 5 m/s grid. The CSV (written by `antenna pointing-model`, read by
//! `antenna --pointing-model`) has one row per grid point:
//!
//! ```text
//! term,azimuth_deg,elevation_deg,wind_speed_m_s,wind_direction_relative_deg,cross_elevation_error_arcsec,elevation_error_arcsec
//! encoder,-185,15,,,1.234,-0.456
//! flexure,,15,9,135,-3.210,4.321
//! ```
//!
//! The errors are on the sky, as astronomers read pointing offsets: target minus beam, arcsec,
//! cross-elevation (along the azimuth direction, already times cos el) and elevation. The
//! corrected command is `azimuth + cross / (3600 cos el)`, `elevation + elevation_error / 3600`
//! (deg). A grid must be complete and strictly increasing in each coordinate; the direction grid
//! must run from 0 to 360 deg, both ends included.

use std::path::Path;

use super::command::Command;

/// The columns of the table, in order.
pub const COLUMNS: [&str; 7] = [
    "term",
    "azimuth_deg",
    "elevation_deg",
    "wind_speed_m_s",
    "wind_direction_relative_deg",
    "cross_elevation_error_arcsec",
    "elevation_error_arcsec",
];

/// The largest table read, bytes.
pub const MAX_POINTING_MODEL_BYTES: u64 = 16 << 20;

/// Why a pointing-model table was refused; each message names the file and what is wrong.
#[derive(Debug, thiserror::Error)]
pub enum PointingModelError {
    #[error(transparent)]
    Read(#[from] fmu_runtime::files::FileError),
    #[error("{origin}: {source}")]
    Csv { origin: String, source: csv::Error },
    #[error("{origin}: missing column `{column}` (the columns are {})", COLUMNS.join(","))]
    MissingColumn { origin: String, column: &'static str },
    #[error("{origin}:{line}: {column} `{cell}` is not a finite number")]
    NotANumber { origin: String, line: u64, column: &'static str, cell: String },
    #[error("{origin}:{line}: term `{term}` is neither `encoder` nor `flexure`")]
    UnknownTerm { origin: String, line: u64, term: String },
    #[error("{origin}: the {term} grid has no rows")]
    NoRows { origin: String, term: &'static str },
    #[error("{origin}: the {term} grid's {column} values {values:?} are not strictly increasing")]
    NotMonotonic { origin: String, term: &'static str, column: &'static str, values: Vec<f64> },
    #[error(
        "{origin}: the {term} grid is not complete: {rows} rows for {expected} grid points, or a point given twice"
    )]
    Incomplete { origin: String, term: &'static str, rows: usize, expected: usize },
    #[error("{origin}: the flexure grid's wind speeds must not be negative, got {speed} m/s")]
    NegativeSpeed { origin: String, speed: f64 },
    #[error("{origin}: the flexure grid's wind directions must run from 0 to 360 deg (both included), got {first} to {last}")]
    DirectionSpan { origin: String, first: f64, last: f64 },
}

/// Values on a rectangular grid of any dimension, row-major (the last coordinate fastest).
#[derive(Debug, Clone, PartialEq)]
pub struct Grid {
    /// The grid's coordinates, each strictly increasing.
    pub axes: Vec<Vec<f64>>,
    /// The error at each grid point, arcsec on the sky (cross-elevation, elevation).
    pub values: Vec<[f64; 2]>,
    /// For each coordinate, whether the interpolation is linear in its square (the wind speed,
    /// whose square the loads follow; its values are not negative) rather than in itself.
    pub quadratic: Vec<bool>,
}

impl Grid {
    /// The flat index of a grid point.
    fn index(&self, point: &[usize]) -> usize {
        point.iter().zip(&self.axes).fold(0, |flat, (&i, axis)| flat * axis.len() + i)
    }

    /// Linear interpolation in every coordinate, each clamped to its axis.
    pub fn interpolate(&self, at: &[f64]) -> [f64; 2] {
        // For each coordinate: the lower grid index and the weight of the upper one.
        let cells: Vec<(usize, f64)> = self
            .axes
            .iter()
            .zip(at)
            .zip(&self.quadratic)
            .map(|((axis, &x), &quadratic)| bracket(axis, x, quadratic))
            .collect();
        let mut sum = [0.0; 2];
        for corner in 0..(1usize << cells.len()) {
            let mut weight = 1.0;
            let mut point = Vec::with_capacity(cells.len());
            for (d, &(i, w)) in cells.iter().enumerate() {
                let upper = (corner >> d) & 1 == 1;
                weight *= if upper { w } else { 1.0 - w };
                point.push(if upper { (i + 1).min(self.axes[d].len() - 1) } else { i });
            }
            if weight != 0.0 {
                let value = self.values[self.index(&point)];
                sum = [sum[0] + weight * value[0], sum[1] + weight * value[1]];
            }
        }
        sum
    }
}

/// The interval of `axis` holding `x` and the weight of its upper end, `x` clamped to the axis;
/// `quadratic`: the weight linear in the squares (of values not negative).
fn bracket(axis: &[f64], x: f64, quadratic: bool) -> (usize, f64) {
    let n = axis.len();
    if n < 2 || x <= axis[0] {
        return (0, 0.0);
    }
    if x >= axis[n - 1] {
        return (n - 2, 1.0);
    }
    let i = axis.partition_point(|&a| a <= x) - 1;
    let (a, b) = (axis[i], axis[i + 1]);
    let weight = if quadratic { (x * x - a * a) / (b * b - a * a) } else { (x - a) / (b - a) };
    (i, weight)
}

/// The pointing-model table: the encoder term over (azimuth, elevation) and the flexure term
/// over (wind speed, relative wind direction, elevation).
#[derive(Debug, Clone, PartialEq)]
pub struct PointingModel {
    pub encoder: Grid,
    pub flexure: Grid,
}

/// The wind's direction relative to the dish, deg in [0, 360): where it comes from minus the
/// azimuth (the wind unit's yaw, wrapped to a whole turn).
pub fn relative_wind_direction_deg(wind_direction_deg: f64, azimuth_deg: f64) -> f64 {
    (wind_direction_deg - azimuth_deg).rem_euclid(360.0)
}

impl PointingModel {
    /// The pointing error the table predicts (target minus beam, arcsec on the sky:
    /// cross-elevation, elevation) for a command at `azimuth_deg`, `elevation_deg` in a mean wind
    /// of `wind_speed_m_s` from `wind_direction_deg` (deg from north).
    pub fn predicted_error_arcsec(
        &self,
        azimuth_deg: f64,
        elevation_deg: f64,
        wind_speed_m_s: f64,
        wind_direction_deg: f64,
    ) -> [f64; 2] {
        let encoder = self.encoder.interpolate(&[azimuth_deg, elevation_deg]);
        let direction = relative_wind_direction_deg(wind_direction_deg, azimuth_deg);
        let flexure = self.flexure.interpolate(&[wind_speed_m_s, direction, elevation_deg]);
        [encoder[0] + flexure[0], encoder[1] + flexure[1]]
    }

    /// The command corrected by the predicted error: the positions moved by it, the rates kept
    /// (the correction changes by a fraction of an arcsec over a track: its rate is far below
    /// what the feedforward needs).
    pub fn correct(&self, command: Command, wind_speed_m_s: f64, wind_direction_deg: f64) -> Command {
        let [cross, elevation] =
            self.predicted_error_arcsec(command.azimuth_deg, command.elevation_deg, wind_speed_m_s, wind_direction_deg);
        let cos_el = command.elevation_deg.to_radians().cos().max(1e-3);
        Command {
            azimuth_deg: command.azimuth_deg + cross / 3600.0 / cos_el,
            elevation_deg: command.elevation_deg + elevation / 3600.0,
            ..command
        }
    }

    /// Reads a table ([module documentation](self)) through the project's bounded reader: a
    /// regular file of at most [`MAX_POINTING_MODEL_BYTES`].
    pub fn from_csv(path: &Path) -> Result<Self, PointingModelError> {
        let text = fmu_runtime::files::read_regular_file(path, MAX_POINTING_MODEL_BYTES, "pointing-model table")
            .map_err(PointingModelError::Read)?;
        Self::from_csv_text(&text, &path.display().to_string())
    }

    /// Reads a table from its text; `origin` names it in errors.
    pub fn from_csv_text(text: &str, origin: &str) -> Result<Self, PointingModelError> {
        let mut reader = csv::ReaderBuilder::new()
            .trim(csv::Trim::All)
            .comment(Some(b'#'))
            .flexible(false)
            .from_reader(text.as_bytes());
        let csv_error = |source| PointingModelError::Csv { origin: origin.to_string(), source };
        let headers = reader.headers().map_err(csv_error)?.clone();
        let mut position = [0usize; COLUMNS.len()];
        for (slot, column) in position.iter_mut().zip(COLUMNS) {
            *slot = headers
                .iter()
                .position(|h| h == column)
                .ok_or(PointingModelError::MissingColumn { origin: origin.to_string(), column })?;
        }
        let mut encoder_rows = Vec::new();
        let mut flexure_rows = Vec::new();
        for record in reader.records() {
            let record = record.map_err(csv_error)?;
            let line = record.position().map_or(0, |p| p.line());
            let number = |k: usize| -> Result<f64, PointingModelError> {
                let cell = &record[position[k]];
                cell.parse::<f64>().ok().filter(|x| x.is_finite()).ok_or_else(|| PointingModelError::NotANumber {
                    origin: origin.to_string(),
                    line,
                    column: COLUMNS[k],
                    cell: cell.to_string(),
                })
            };
            let value = [number(5)?, number(6)?];
            match &record[position[0]] {
                "encoder" => encoder_rows.push((vec![number(1)?, number(2)?], value)),
                "flexure" => flexure_rows.push((vec![number(3)?, number(4)?, number(2)?], value)),
                term => return Err(PointingModelError::UnknownTerm { origin: origin.into(), line, term: term.into() }),
            }
        }
        let encoder = grid_of(origin, "encoder", &["azimuth_deg", "elevation_deg"], encoder_rows)?;
        let mut flexure = grid_of(
            origin,
            "flexure",
            &["wind_speed_m_s", "wind_direction_relative_deg", "elevation_deg"],
            flexure_rows,
        )?;
        if let Some(&speed) = flexure.axes[0].iter().find(|&&v| v < 0.0) {
            return Err(PointingModelError::NegativeSpeed { origin: origin.into(), speed });
        }
        flexure.quadratic = vec![true, false, false];
        let directions = &flexure.axes[1];
        let (first, last) = (directions[0], directions[directions.len() - 1]);
        if first != 0.0 || last != 360.0 {
            return Err(PointingModelError::DirectionSpan { origin: origin.into(), first, last });
        }
        Ok(PointingModel { encoder, flexure })
    }

    /// The table as the CSV that [`PointingModel::from_csv`] reads, with a comment header that
    /// says what it holds.
    pub fn to_csv(&self, comment: &str) -> String {
        let mut text: String = comment.lines().map(|l| format!("# {l}\n")).collect();
        text.push_str(&COLUMNS.join(","));
        text.push('\n');
        let cell = |x: f64| format!("{x}");
        let value = |v: [f64; 2]| format!("{:.4},{:.4}", v[0], v[1]);
        for (i, az) in self.encoder.axes[0].iter().enumerate() {
            for (j, el) in self.encoder.axes[1].iter().enumerate() {
                let v = self.encoder.values[self.encoder.index(&[i, j])];
                text.push_str(&format!("encoder,{},{},,,{}\n", cell(*az), cell(*el), value(v)));
            }
        }
        let axes = &self.flexure.axes;
        for (i, speed) in axes[0].iter().enumerate() {
            for (j, direction) in axes[1].iter().enumerate() {
                for (k, el) in axes[2].iter().enumerate() {
                    let v = self.flexure.values[self.flexure.index(&[i, j, k])];
                    text.push_str(&format!(
                        "flexure,,{},{},{},{}\n",
                        cell(*el),
                        cell(*speed),
                        cell(*direction),
                        value(v)
                    ));
                }
            }
        }
        text
    }
}

/// Builds a complete grid from rows of (coordinates, value), checking that each coordinate's
/// values are strictly increasing and every grid point is given exactly once.
fn grid_of(
    origin: &str,
    term: &'static str,
    columns: &[&'static str],
    rows: Vec<(Vec<f64>, [f64; 2])>,
) -> Result<Grid, PointingModelError> {
    if rows.is_empty() {
        return Err(PointingModelError::NoRows { origin: origin.into(), term });
    }
    let mut axes = Vec::with_capacity(columns.len());
    for (d, &column) in columns.iter().enumerate() {
        // The grid's values in the order they first appear: a table lists them increasing.
        let mut values: Vec<f64> = Vec::new();
        for (coordinates, _) in &rows {
            if !values.contains(&coordinates[d]) {
                values.push(coordinates[d]);
            }
        }
        if values.windows(2).any(|w| w[1] <= w[0]) {
            return Err(PointingModelError::NotMonotonic { origin: origin.into(), term, column, values });
        }
        axes.push(values);
    }
    let expected: usize = axes.iter().map(Vec::len).product();
    let quadratic = vec![false; axes.len()];
    let mut grid = Grid { axes, values: vec![[f64::NAN; 2]; expected], quadratic };
    let incomplete = || PointingModelError::Incomplete { origin: origin.into(), term, rows: rows.len(), expected };
    if rows.len() != expected {
        return Err(incomplete());
    }
    for (coordinates, value) in &rows {
        let point: Vec<usize> = coordinates
            .iter()
            .zip(&grid.axes)
            .map(|(x, axis)| axis.iter().position(|a| a == x).expect("collected above"))
            .collect();
        let index = grid.index(&point);
        if !grid.values[index][0].is_nan() {
            return Err(incomplete());
        }
        grid.values[index] = *value;
    }
    Ok(grid)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn small_model() -> PointingModel {
        // Encoder: cross = azimuth / 10 arcsec, elevation = elevation / 100 arcsec (linear, so the
        // interpolation is exact). Flexure: proportional to the speed's square, zero in calm.
        let encoder_axes = vec![vec![0.0, 90.0, 180.0], vec![15.0, 90.0]];
        let mut encoder = Vec::new();
        for az in &encoder_axes[0] {
            for el in &encoder_axes[1] {
                encoder.push([az / 10.0, el / 100.0]);
            }
        }
        let flexure_axes = vec![vec![0.0, 10.0], vec![0.0, 180.0, 360.0], vec![15.0, 90.0]];
        let mut flexure = Vec::new();
        for speed in &flexure_axes[0] {
            for direction in &flexure_axes[1] {
                for _ in &flexure_axes[2] {
                    let sign = if *direction == 180.0 { -1.0 } else { 1.0 };
                    flexure.push([sign * speed * speed * 0.05, speed * speed * 0.02]);
                }
            }
        }
        PointingModel {
            encoder: Grid { axes: encoder_axes, values: encoder, quadratic: vec![false; 2] },
            flexure: Grid { axes: flexure_axes, values: flexure, quadratic: vec![true, false, false] },
        }
    }

    #[test]
    fn the_prediction_interpolates_each_grid_linearly_and_wraps_the_wind_direction() {
        let model = small_model();
        // Encoder at (45, 52.5): 4.5 and 0.525; flexure at 5 m/s from 90 deg relative: halfway
        // between 0 and 180 deg, cross (1.25 - 1.25) / 2 = 0, elevation 0.02 * 25 = 0.5, exact
        // for a load that goes with the speed's square (linear in the speed would give 1.0).
        let [cross, elevation] = model.predicted_error_arcsec(45.0, 52.5, 5.0, 135.0);
        assert!((cross - 4.5).abs() < 1e-12 && (elevation - 1.025).abs() < 1e-12, "{cross} {elevation}");
        // A wind from 350 deg relative lies between 180 and 360 deg: nearly the 0 deg value.
        let [cross, _] = model.predicted_error_arcsec(0.0, 15.0, 10.0, 350.0);
        assert!((cross - (5.0 - 10.0 * 10.0 / 180.0)).abs() < 1e-9, "{cross}");
        // Halfway between the 0 and 10 m/s rows in the square: 7.07 m/s.
        let [_, elevation] = model.predicted_error_arcsec(0.0, 15.0, 50f64.sqrt(), 0.0);
        assert!((elevation - 0.15 - 1.0).abs() < 1e-9, "{elevation}");
        // Outside the grid the edge holds.
        assert_eq!(model.predicted_error_arcsec(300.0, 95.0, 0.0, 0.0), [18.0, 0.9]);
    }

    #[test]
    fn the_correction_moves_the_command_by_the_predicted_error_on_the_sky() {
        let model = small_model();
        let command =
            Command { azimuth_deg: 90.0, azimuth_rate_deg_per_s: 0.01, elevation_deg: 60.0, ..Default::default() };
        let corrected = model.correct(command, 0.0, 0.0);
        // 9 arcsec cross-elevation at 60 deg is 18 arcsec of azimuth; 0.6 arcsec of elevation.
        assert!(((corrected.azimuth_deg - 90.0) * 3600.0 - 18.0).abs() < 1e-9);
        assert!(((corrected.elevation_deg - 60.0) * 3600.0 - 0.6).abs() < 1e-9);
        assert_eq!(corrected.azimuth_rate_deg_per_s, 0.01);
    }

    #[test]
    fn a_table_written_reads_back_to_the_same_model() {
        let model = small_model();
        let text = model.to_csv("a test table\nunits in the column names");
        let read = PointingModel::from_csv_text(&text, "test").unwrap();
        assert_eq!(read, model);
    }

    #[test]
    fn bad_tables_are_refused_with_what_is_wrong() {
        let good = small_model().to_csv("");
        let error = |text: &str| PointingModel::from_csv_text(text, "t.csv").unwrap_err().to_string();
        let missing = good.replace("arcsec,elevation_error_arcsec", "arcsec,elevation_arcsec");
        assert!(error(&missing).contains("missing column `elevation_error_arcsec`"), "{}", error(&missing));
        let nan = good.replacen("encoder,0,15,,,0.0000", "encoder,0,15,,,NaN", 1);
        assert!(error(&nan).contains("is not a finite number"), "{}", error(&nan));
        // Swap the first two encoder rows' azimuths: 90 before 0.
        let lines: Vec<&str> = good.lines().collect();
        let mut shuffled = lines.clone();
        let (a, b) = (
            lines.iter().position(|l| l.starts_with("encoder,0,")).unwrap(),
            lines.iter().position(|l| l.starts_with("encoder,90,15")).unwrap(),
        );
        shuffled.swap(a, b);
        assert!(error(&shuffled.join("\n")).contains("not strictly increasing"), "{}", error(&shuffled.join("\n")));
        let dropped: Vec<&str> = lines.iter().copied().filter(|l| !l.starts_with("flexure,,90,10,180")).collect();
        assert!(error(&dropped.join("\n")).contains("not complete"), "{}", error(&dropped.join("\n")));
        let span = good.replace(",360,", ",350,");
        assert!(error(&span).contains("from 0 to 360"), "{}", error(&span));
        assert!(error(&good.replace("flexure,", "gravity,")).contains("neither `encoder` nor `flexure`"));
    }

    #[test]
    fn a_path_that_is_not_a_regular_file_is_refused() {
        let error = PointingModel::from_csv(&std::env::temp_dir()).unwrap_err().to_string();
        assert!(error.contains("regular file") || error.contains("not a file"), "{error}");
    }
}
