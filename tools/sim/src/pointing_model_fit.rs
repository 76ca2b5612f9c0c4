//! Deriving a pointing-model table ([`PointingModel`]) from the coupled model itself, the way an
//! observatory fits one from pointing scans, and never from the runs it is judged on:
//!
//! * the **encoder** term from calm scans: azimuth scanned at a constant rate over the grid at
//!   one elevation, elevation scanned at one azimuth, each in both directions (the servo's lag,
//!   which changes sign with the direction, cancels in the mean); the error is averaged over
//!   +-0.5 deg about each grid angle (about ninety periods of the encoders' interpolation error,
//!   which no table can follow) and the azimuth error scaled with `cos(el)` onto the sky;
//! * the **flexure** term from holds in a **steady** wind (no gust: the wind unit's spectrum
//!   off) at each grid point of mean speed, relative direction and elevation: the mean error over
//!   the hold's last second, less the same hold's in calm air (which carries the encoder's error
//!   at that position and is in the encoder term already).
//!
//! Both use only the runs' pointing error (target minus beam), as a telescope measures offsets
//! on sources; gust seeds play no part, so a run with gusts it is tested on is held out.

use std::path::Path;

use antenna_plot::{Figure, Panel, PlotError, Series, PALETTE};
use rayon::prelude::*;

use super::command::{CommandPoint, CommandTable, CABLE_WRAP_DEG, ELEVATION_TRAVEL_DEG};
use super::coupled::{AntennaConfig, CoupledAntenna, CouplingError, FmuSet, ParameterValue, Trace, WindCondition};
use super::pointing_model::{Grid, PointingModel};
use super::scenario::wind_direction_deg;

/// Where and how the model is sampled.
#[derive(Debug, Clone, PartialEq)]
pub struct DerivationGrid {
    /// Encoder grid: commanded azimuths, deg.
    pub azimuth_deg: Vec<f64>,
    /// Elevations of both grids, deg.
    pub elevation_deg: Vec<f64>,
    /// Flexure grid: mean wind speeds at 10 m, m/s; the first must be 0 (calm: no correction).
    pub wind_speed_m_s: Vec<f64>,
    /// Flexure grid: where the wind comes from relative to the dish, deg, from 0 to 360.
    pub wind_direction_relative_deg: Vec<f64>,
    /// The elevation the azimuth scan runs at, and the azimuth of the elevation scan and of the
    /// flexure holds, deg.
    pub scan_elevation_deg: f64,
    pub scan_azimuth_deg: f64,
    /// Scan rate, deg/s: well below the slew speeds the profiler allows (2 deg/s in azimuth,
    /// 1 deg/s in elevation), so that the axes follow the scan at constant speed.
    pub scan_rate_deg_per_s: f64,
    /// Length of a flexure hold, s; its last second is averaged.
    pub hold_s: f64,
}

impl DerivationGrid {
    /// The table `antenna pointing-model` writes: azimuth -180 to 270 deg and elevation 15 to 90
    /// deg every 5 deg, scanned at 0.5 deg/s (half the elevation drive's slew speed); mean wind 0 to 20 m/s every 5 m/s (interpolated in
    /// the square, as the loads go) from every 15 deg, and elevation every 15 deg for the
    /// flexure (it changes slowly with elevation): 576 steady holds of 4 s and four scans, some
    /// 4,500 s of simulated time.
    pub fn standard() -> Self {
        DerivationGrid {
            azimuth_deg: (0..=90).map(|k| -180.0 + 5.0 * k as f64).collect(),
            elevation_deg: (0..=15).map(|k| 15.0 + 5.0 * k as f64).collect(),
            wind_speed_m_s: (0..=4).map(|k| 5.0 * k as f64).collect(),
            wind_direction_relative_deg: (0..=24).map(|k| 15.0 * k as f64).collect(),
            scan_elevation_deg: 45.0,
            scan_azimuth_deg: 30.0,
            scan_rate_deg_per_s: 0.5,
            hold_s: 4.0,
        }
    }

    /// Whether the grid can be derived on: the wind speeds start at calm, the directions run
    /// round the full circle, and every axis is strictly increasing (the table interpolates
    /// along each).
    pub fn check(&self) -> Result<(), FitError> {
        let directions = &self.wind_direction_relative_deg;
        if self.wind_speed_m_s.first() != Some(&0.0) {
            return Err(FitError::GridWithoutCalm);
        }
        if directions.first() != Some(&0.0) || directions.last() != Some(&360.0) {
            return Err(FitError::GridDirectionsNotFullCircle);
        }
        let axes = [
            ("azimuths", &self.azimuth_deg),
            ("elevations", &self.elevation_deg),
            ("wind speeds", &self.wind_speed_m_s),
            ("wind directions", directions),
        ];
        for (axis, values) in axes {
            if values.windows(2).any(|w| w[1] <= w[0]) {
                return Err(FitError::GridNotIncreasing { axis });
            }
        }
        Ok(())
    }

    /// The flexure's elevations: every third of the encoder grid's (every 15 deg in the
    /// standard grid) and its last.
    fn flexure_elevations(&self) -> Vec<f64> {
        let mut els: Vec<f64> = self.elevation_deg.iter().copied().step_by(3).collect();
        if els.last() != self.elevation_deg.last() {
            els.extend(self.elevation_deg.last());
        }
        els
    }
}

/// Why a table could not be derived.
#[derive(Debug, thiserror::Error)]
pub enum FitError {
    #[error("{run}")]
    Simulation { run: String, source: CouplingError },
    #[error("{run}: no samples within 0.5 deg of the grid angle {angle_deg} deg")]
    NoSamples { run: String, angle_deg: f64 },
    #[error("the derivation grid is not usable: the wind speeds must start at 0 (calm)")]
    GridWithoutCalm,
    #[error("the derivation grid is not usable: the wind directions must run from 0 to 360 deg")]
    GridDirectionsNotFullCircle,
    #[error("the derivation grid is not usable: its {axis} are not strictly increasing")]
    GridNotIncreasing { axis: &'static str },
}

/// How long the antenna holds before a scan starts and after it ends, s.
const SCAN_SETTLE_S: f64 = 5.0;
/// How long after the scan starts and before it ends its samples are left out, s: the axis
/// accelerates and brakes there, and lags the command.
const SCAN_RAMP_S: f64 = 2.0;
/// Half the width of the bin of a scan averaged about a grid angle, deg.
const SCAN_BIN_DEG: f64 = 0.5;

/// One coupled run of `table` until its end plus `tail_s`.
fn run(
    fmus: &FmuSet,
    config: &AntennaConfig,
    table: &CommandTable,
    tail_s: f64,
    name: &str,
) -> Result<Trace, FitError> {
    let simulation = |source| FitError::Simulation { run: name.to_string(), source };
    let mut antenna = CoupledAntenna::new(fmus, config, table).map_err(simulation)?;
    antenna.run(table, table.time_span().1 + tail_s, &mut |_| {}).map_err(|e| simulation(e.into()))
}

/// A table that holds `from`, scans to `to` at `rate` (one row a second) and holds `to`.
fn scan_table(from: (f64, f64), to: (f64, f64), rate: f64) -> CommandTable {
    let length = (to.0 - from.0).hypot(to.1 - from.1);
    let seconds = (length / rate).ceil().max(1.0) as usize;
    let mut points = vec![CommandPoint { time_s: 0.0, azimuth_deg: from.0, elevation_deg: from.1 }];
    for k in 0..=seconds {
        let f = k as f64 / seconds as f64;
        points.push(CommandPoint {
            time_s: SCAN_SETTLE_S + k as f64 * length / rate / seconds as f64,
            azimuth_deg: from.0 + f * (to.0 - from.0),
            elevation_deg: from.1 + f * (to.1 - from.1),
        });
    }
    CommandTable::new(points).expect("scans stay inside the travel")
}

/// The mean on-sky error (cross-elevation, elevation) of a scan's samples whose commanded
/// angle on `axis` (0 azimuth, 1 elevation) lies within [`SCAN_BIN_DEG`] of each of `angles`,
/// from the samples in `windows` (start, end; s).
fn binned(
    trace: &Trace,
    axis: usize,
    angles: &[f64],
    windows: &[(f64, f64)],
    run: &str,
) -> Result<Vec<[f64; 2]>, FitError> {
    let error = trace.pointing_error_sky_arcsec();
    let angle = if axis == 0 { &trace.command_azimuth_deg } else { &trace.command_elevation_deg };
    angles
        .iter()
        .map(|&a| {
            let (mut sum, mut n) = ([0.0; 2], 0usize);
            for k in 0..trace.time_s.len() {
                let t = trace.time_s[k];
                let inside = windows.iter().any(|&(start, end)| t > start && t < end);
                if inside && (angle[k] - a).abs() <= SCAN_BIN_DEG {
                    sum = [sum[0] + error[k][0], sum[1] + error[k][1]];
                    n += 1;
                }
            }
            if n == 0 {
                return Err(FitError::NoSamples { run: run.to_string(), angle_deg: a });
            }
            Ok([sum[0] / n as f64, sum[1] / n as f64])
        })
        .collect()
}

/// A grid's axis clamped into a travel with a margin for the scan to reach speed.
fn scan_span(axis: &[f64], travel: (f64, f64)) -> (f64, f64) {
    let margin = 2.0;
    ((axis[0] - margin).max(travel.0), (axis[axis.len() - 1] + margin).min(travel.1))
}

/// The encoder term: the azimuth axis's error against azimuth and the elevation axis's against
/// elevation, from calm scans both ways, on the grid.
fn encoder_term(fmus: &FmuSet, config: &AntennaConfig, grid: &DerivationGrid) -> Result<Grid, FitError> {
    let calm = AntennaConfig { wind: WindCondition::CALM, pointing_model: None, ..config.clone() };
    let (az0, az1) = scan_span(&grid.azimuth_deg, CABLE_WRAP_DEG);
    let (el0, el1) = scan_span(&grid.elevation_deg, ELEVATION_TRAVEL_DEG);
    let (az_el, el_az) = (grid.scan_elevation_deg, grid.scan_azimuth_deg);
    let rate = grid.scan_rate_deg_per_s;
    let scans = [
        (0, (az0, az_el), (az1, az_el)),
        (0, (az1, az_el), (az0, az_el)),
        (1, (el_az, el0), (el_az, el1)),
        (1, (el_az, el1), (el_az, el0)),
    ];
    let means = scans
        .par_iter()
        .map(|&(axis, from, to)| {
            let table = scan_table(from, to, rate);
            let name = format!("calm scan from {from:?} to {to:?}");
            let trace = run(fmus, &calm, &table, SCAN_SETTLE_S, &name)?;
            // The scan at speed, and the settled holds before and after it: where a grid's edge
            // is the end of the travel, the scan cannot pass it at speed, and the hold there
            // gives the edge's figure.
            let end = table.time_span().1;
            let windows = [
                (SCAN_SETTLE_S - 1.0, SCAN_SETTLE_S),
                (SCAN_SETTLE_S + SCAN_RAMP_S, end - SCAN_RAMP_S),
                (end + SCAN_SETTLE_S - 1.0, end + SCAN_SETTLE_S),
            ];
            let angles = if axis == 0 { &grid.azimuth_deg } else { &grid.elevation_deg };
            binned(&trace, axis, angles, &windows, &name)
        })
        .collect::<Result<Vec<_>, FitError>>()?;
    // The two directions' mean; the azimuth error per unit cos(el) of the scan's elevation.
    let cos_scan = grid.scan_elevation_deg.to_radians().cos();
    let azimuth_error: Vec<f64> = means[0].iter().zip(&means[1]).map(|(a, b)| 0.5 * (a[0] + b[0]) / cos_scan).collect();
    let elevation_error: Vec<f64> = means[2].iter().zip(&means[3]).map(|(a, b)| 0.5 * (a[1] + b[1])).collect();
    let mut values = Vec::with_capacity(grid.azimuth_deg.len() * grid.elevation_deg.len());
    for a in &azimuth_error {
        for (el, e) in grid.elevation_deg.iter().zip(&elevation_error) {
            values.push([a * el.to_radians().cos(), *e]);
        }
    }
    Ok(Grid { axes: vec![grid.azimuth_deg.clone(), grid.elevation_deg.clone()], values, quadratic: vec![false; 2] })
}

/// The mean on-sky error over the last second of a hold at (`azimuth`, `elevation`) in `wind`
/// (steady: the gust switched off), arcsec.
fn hold_mean(
    fmus: &FmuSet,
    config: &AntennaConfig,
    at: (f64, f64),
    wind: WindCondition,
    hold_s: f64,
) -> Result<[f64; 2], FitError> {
    let mut steady = AntennaConfig { wind: wind.clone(), pointing_model: None, ..config.clone() };
    steady.wind_unit.push(("spectrum".into(), ParameterValue::Integer(3)));
    let point = |t: f64| CommandPoint { time_s: t, azimuth_deg: at.0, elevation_deg: at.1 };
    let table = CommandTable::new(vec![point(0.0), point(hold_s)]).expect("grid points are inside the travel");
    let name = format!("steady hold at {at:?} in {wind:?}");
    let trace = run(fmus, &steady, &table, 0.0, &name)?;
    let error = trace.pointing_error_sky_arcsec();
    let first = trace.time_s.partition_point(|&t| t < hold_s - 1.0);
    let tail = &error[first..];
    let n = tail.len().max(1) as f64;
    Ok([tail.iter().map(|e| e[0]).sum::<f64>() / n, tail.iter().map(|e| e[1]).sum::<f64>() / n])
}

/// The flexure term: each steady hold's mean error less the calm hold's at the same elevation.
fn flexure_term(fmus: &FmuSet, config: &AntennaConfig, grid: &DerivationGrid) -> Result<Grid, FitError> {
    let elevations = grid.flexure_elevations();
    let az = grid.scan_azimuth_deg;
    // Calm air: the wind unit still needs a positive speed, but the master zeroes its loads.
    let wind = |speed: f64, direction: f64| WindCondition {
        mean_speed_m_s: speed,
        roughness_length_m: 0.0105,
        direction_deg: wind_direction_deg(az, direction),
        seed: 1,
    };
    let calm: Vec<[f64; 2]> = elevations
        .par_iter()
        .map(|&el| hold_mean(fmus, config, (az, el), WindCondition::CALM, grid.hold_s))
        .collect::<Result<_, _>>()?;
    // Every windy grid point but the 360 deg column, which repeats the 0 deg one.
    let directions = &grid.wind_direction_relative_deg;
    let mut points = Vec::new();
    for (i, &speed) in grid.wind_speed_m_s.iter().enumerate().filter(|(_, &s)| s > 0.0) {
        for (j, &direction) in directions.iter().enumerate().filter(|(_, &d)| d < 360.0) {
            for k in 0..elevations.len() {
                points.push((i, j, k, speed, direction));
            }
        }
    }
    let measured = points
        .par_iter()
        .map(|&(_, _, k, speed, direction)| {
            let mean = hold_mean(fmus, config, (az, elevations[k]), wind(speed, direction), grid.hold_s)?;
            Ok([mean[0] - calm[k][0], mean[1] - calm[k][1]])
        })
        .collect::<Result<Vec<[f64; 2]>, FitError>>()?;
    let (nd, ne) = (directions.len(), elevations.len());
    let mut values = vec![[0.0; 2]; grid.wind_speed_m_s.len() * nd * ne];
    for (&(i, j, k, _, _), value) in points.iter().zip(&measured) {
        values[(i * nd + j) * ne + k] = *value;
        if j == 0 {
            values[(i * nd + nd - 1) * ne + k] = *value;
        }
    }
    Ok(Grid {
        axes: vec![grid.wind_speed_m_s.clone(), directions.clone(), elevations],
        values,
        quadratic: vec![true, false, false],
    })
}

/// Derives the pointing-model table of the antenna `config` (its wind and pointing model are
/// ignored) on `grid`, running the coupled model on all cores.
pub fn derive(fmus: &FmuSet, config: &AntennaConfig, grid: &DerivationGrid) -> Result<PointingModel, FitError> {
    grid.check()?;
    let encoder = encoder_term(fmus, config, grid)?;
    let flexure = flexure_term(fmus, config, grid)?;
    Ok(PointingModel { encoder, flexure })
}

/// What a derived table's header says: what it holds, how it was derived, how it is applied.
pub fn table_comment(grid: &DerivationGrid) -> String {
    format!(
        "Pointing-model table of the MeerKAT antenna model (antenna pointing-model; docs/requirement-report.md, \"Pointing model\").
Each row: the pointing error the model predicts, target minus beam, on the sky in arcsec (cross-elevation, elevation).
encoder rows, over commanded azimuth and elevation: the encoders' repeatable errors, from calm scans at {} deg/s both ways.
flexure rows, over mean wind speed at 10 m, wind direction relative to the dish (where it comes from minus azimuth) and elevation:
the static deflection of the beam in a steady wind (no gust), with what the servo leaves of it, less the calm hold.
The master (antenna --pointing-model FILE) adds the sum of both terms, interpolated linearly in every coordinate,
to the commanded azimuth (divided by cos el) and elevation, using the scenario's mean wind, never the gust.",
        grid.scan_rate_deg_per_s
    )
}

/// A PNG of the table: the encoder term against azimuth and elevation, and the flexure term at
/// the grid's highest speed at or below 12 m/s against the relative wind direction, one curve
/// per elevation and component.
pub fn plot(model: &PointingModel, path: &Path) -> Result<(), PlotError> {
    let encoder = &model.encoder;
    let (azimuths, elevations) = (&encoder.axes[0], &encoder.axes[1]);
    let at_el = elevations.iter().position(|&e| e >= 45.0).unwrap_or(0);
    let cross: Vec<f64> = (0..azimuths.len()).map(|i| encoder.values[i * elevations.len() + at_el][0]).collect();
    let elevation_error: Vec<f64> = (0..elevations.len()).map(|j| encoder.values[j][1]).collect();
    let encoder_panel = Panel::new(&format!(
        "encoder term: cross-elevation against azimuth (at {} deg elevation), elevation against elevation",
        elevations[at_el]
    ))
    .x_label("commanded angle (deg)")
    .y_label("predicted error (arcsec on the sky)")
    .series(Series::new("cross-elevation vs azimuth", azimuths, &cross).colour(PALETTE[0]))
    .series(Series::new("elevation vs elevation", elevations, &elevation_error).colour(PALETTE[1]).with_markers());
    let flexure = &model.flexure;
    let (speeds, directions, els) = (&flexure.axes[0], &flexure.axes[1], &flexure.axes[2]);
    let speed_index = speeds.iter().rposition(|&v| v <= 12.0).unwrap_or(speeds.len() - 1);
    let mut flexure_panel = Panel::new(&format!(
        "static flexure term at {} m/s mean wind against the wind's direction relative to the dish",
        speeds[speed_index]
    ))
    .x_label("wind direction relative to the dish (deg; 0: into the face)")
    .y_label("predicted error (arcsec on the sky)");
    for (k, el) in els.iter().enumerate() {
        let component = |c: usize| -> Vec<f64> {
            (0..directions.len())
                .map(|j| flexure.values[(speed_index * directions.len() + j) * els.len() + k][c])
                .collect()
        };
        let colour = PALETTE[k % PALETTE.len()];
        flexure_panel = flexure_panel
            .series(Series::new(&format!("cross-el, el {el} deg"), directions, &component(0)).colour(colour))
            .series(Series::new(&format!("elevation, el {el} deg"), directions, &component(1)).colour(colour).dashed());
    }
    Figure::new(1100, 1000).panel(encoder_panel).panel(flexure_panel).save_png(path)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_grid_without_calm_a_full_circle_or_increasing_axes_is_refused_by_name() {
        assert!(DerivationGrid::standard().check().is_ok());
        let mut windy = DerivationGrid::standard();
        windy.wind_speed_m_s.remove(0);
        assert!(matches!(windy.check(), Err(FitError::GridWithoutCalm)));
        let mut half = DerivationGrid::standard();
        half.wind_direction_relative_deg.retain(|&d| d <= 180.0);
        assert!(matches!(half.check(), Err(FitError::GridDirectionsNotFullCircle)));
        let mut repeated = DerivationGrid::standard();
        repeated.elevation_deg.insert(1, repeated.elevation_deg[0]);
        let refused = repeated.check().unwrap_err();
        assert!(matches!(refused, FitError::GridNotIncreasing { axis: "elevations" }), "{refused:?}");
        assert!(refused.to_string().contains("elevations are not strictly increasing"), "{refused}");
    }
}
