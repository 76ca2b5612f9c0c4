//! Runs the requirement scenarios and writes the requirement report: a table of Req. 1-5 with
//! the measured figure beside each limit (printed, as markdown and as CSV) and plots of the
//! pointing error against time.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use super::coupled::{AntennaConfig, CoupledAntenna, FmuSet, Trace};
use super::metrics::{settling, worst_window_jitter_arcsec, Settling};
use super::scenario::{Analysis, Requirement, Scenario, JITTER_LIMIT_ARCSEC, JITTER_WINDOW_S};
use antenna_plot::{Colour, Figure, Panel, PlotError, Series, PALETTE};
use fmu_import::ImportError;

/// How the figures are defined and what the model leaves out, printed under the table and
/// written into the report (one paragraph a line).
pub const DEFINITIONS: &str = "Jitter = worst RMS of the on-sky pointing error sqrt((d_az cos el)^2 + d_el^2) (command minus true axis position) over sliding 10 s windows.
Settling = until the pointing error stays within 15 arcsec for the next 10 s. Judged from the command for Req. 3 and 4 (the step must return and settle within the limit) and from the end of the slew at maximum speed (the last instant the profiled reference moves at 99 % of its top speed) for Req. 2. The issue's own figure, from the moment the profiled command reaches the target, is the column 'after profile arrival': it is near zero whenever the loops follow the profile within the band, which the peak following error shows.
What the figures leave out: the model is rigid beyond the drive's two-mass compliance (no dish or yoke modes), has no encoder errors besides quantisation and no structural deformation under wind, so the jitter margins are those of the servo, not of the beam.";

/// The judged figure of one scenario.
#[derive(Debug, Clone)]
pub struct Outcome {
    pub scenario: Scenario,
    /// The figure compared with the limit (arcsec RMS or s); NaN if the run never settled.
    pub figure: f64,
    pub passed: bool,
    pub settling: Option<Settling>,
    /// When the worst jitter window starts, s.
    pub worst_window_start_s: Option<f64>,
    pub trace: Trace,
    /// Wall-clock time of the run, s.
    pub wall_s: f64,
}

/// Why a scenario could not be run or its report not written.
#[derive(Debug, thiserror::Error)]
pub enum ReportError {
    #[error("scenario {scenario}")]
    Simulation { scenario: String, source: ImportError },
    #[error("{scenario}: run too short for a {JITTER_WINDOW_S} s jitter window")]
    TooShortForJitter { scenario: String },
    #[error("cannot create {}", path.display())]
    CreateFolder { path: PathBuf, source: std::io::Error },
    #[error(transparent)]
    Plot(#[from] PlotError),
}

/// Runs one scenario on the coupled antenna.
pub fn run_scenario(
    fmus: &FmuSet,
    base: &AntennaConfig,
    scenario: &Scenario,
    progress: &mut dyn FnMut(f64),
) -> Result<Outcome, ReportError> {
    let config = AntennaConfig { wind: scenario.wind.clone(), ..base.clone() };
    let started = std::time::Instant::now();
    let simulation = |source| ReportError::Simulation { scenario: scenario.name.clone(), source };
    let mut antenna = CoupledAntenna::new(fmus, &config, &scenario.table).map_err(simulation)?;
    let trace = antenna.run(&scenario.table, scenario.end_s, progress).map_err(simulation)?;
    let wall_s = started.elapsed().as_secs_f64();
    let (figure, settling_result, window) = match scenario.analysis {
        Analysis::Jitter { from_s } => {
            let (value, start) = worst_window_jitter_arcsec(&trace, from_s)
                .ok_or_else(|| ReportError::TooShortForJitter { scenario: scenario.name.clone() })?;
            (value, None, Some(start))
        }
        Analysis::Settling { jump_s, target } => {
            let s = settling(&trace, jump_s, target);
            (s.map_or(f64::NAN, |s| scenario.requirement.judged_settling(&s).0), s, None)
        }
    };
    let passed = figure.is_finite() && figure < scenario.requirement.limit();
    Ok(Outcome {
        scenario: scenario.clone(),
        figure,
        passed,
        settling: settling_result,
        worst_window_start_s: window,
        trace,
        wall_s,
    })
}

fn figure_text(o: &Outcome) -> String {
    if o.figure.is_finite() {
        match o.scenario.requirement.unit() {
            "s" => format!("{:.2}", o.figure),
            _ => format!("{:.3}", o.figure),
        }
    } else {
        "not settled".to_string()
    }
}

/// The requirement table as markdown.
pub fn markdown(outcomes: &[Outcome]) -> String {
    let mut out = String::new();
    out.push_str("| Req. | scenario | elevation (deg) | wind | measured | limit | margin | after profile arrival (s) | peak following error (arcsec) | result |\n");
    out.push_str("|---|---|---|---|---|---|---|---|---|---|\n");
    for o in outcomes {
        let r = o.scenario.requirement;
        let margin =
            if o.figure.is_finite() { format!("{:.0} %", 100.0 * (1.0 - o.figure / r.limit())) } else { "-".into() };
        let measured = match o.settling {
            Some(s) => format!("{} s {}", figure_text(o), r.judged_settling(&s).1),
            None => format!("{} {}", figure_text(o), r.unit()),
        };
        let after_profile = o.settling.map_or("-".to_string(), |s| format!("{:.2}", s.after_profile_s));
        let following = o.settling.map_or("-".to_string(), |s| format!("{:.1}", s.peak_following_error_arcsec));
        let _ = writeln!(
            out,
            "| {} | {} | {:.0} | {} | {} | < {} {} | {} | {} | {} | {} |",
            r.label(),
            o.scenario.name,
            o.scenario.elevation_deg,
            o.scenario.wind_label,
            measured,
            r.limit(),
            r.unit(),
            margin,
            after_profile,
            following,
            if o.passed { "pass" } else { "FAIL" }
        );
    }
    out
}

/// `value` rounded to `digits` significant digits, as text; NaN (a run that never settled, or
/// a figure a requirement does not have) stays `NaN`.
fn significant(value: f64, digits: i32) -> String {
    if !value.is_finite() || value == 0.0 {
        return format!("{value}");
    }
    let decimals = (digits - 1 - value.abs().log10().floor() as i32).max(0) as usize;
    format!("{value:.decimals$}")
}

/// A time of the trace, s, to the millisecond: the communication step, the resolution every
/// settling instant is found with.
fn milliseconds(value: f64) -> String {
    if value.is_finite() {
        format!("{value:.3}")
    } else {
        format!("{value}")
    }
}

/// The figure in the unit of its requirement: settling times to the millisecond, jitter to
/// three significant digits.
fn figure_csv(o: &Outcome) -> String {
    match o.scenario.requirement.unit() {
        "s" => milliseconds(o.figure),
        _ => significant(o.figure, 3),
    }
}

/// The requirement table as CSV, each figure rounded to its meaningful digits: times to the
/// millisecond (the communication step), pointing errors to three significant digits (the
/// report's markdown shows the same figures with fewer).
pub fn csv(outcomes: &[Outcome]) -> String {
    const HEADER: [&str; 14] = [
        "requirement",
        "scenario",
        "elevation_deg",
        "wind",
        "wind_mean_m_s",
        "figure",
        "unit",
        "limit",
        "passed",
        "settling_after_command_s",
        "settling_after_braking_s",
        "settling_after_profile_arrival_s",
        "peak_following_error_arcsec",
        "peak_error_after_arrival_arcsec",
    ];
    let mut writer = csv::Writer::from_writer(Vec::new());
    let mut write = || -> Result<(), csv::Error> {
        writer.write_record(HEADER)?;
        for o in outcomes {
            let r = o.scenario.requirement;
            let settling = |f: fn(&Settling) -> f64| o.settling.as_ref().map_or(f64::NAN, f);
            writer.write_record([
                r.label().to_string(),
                o.scenario.name.clone(),
                o.scenario.elevation_deg.to_string(),
                o.scenario.wind_label.to_string(),
                o.scenario.wind.mean_speed_m_s.to_string(),
                figure_csv(o),
                r.unit().to_string(),
                r.limit().to_string(),
                o.passed.to_string(),
                milliseconds(settling(|s| s.after_command_s)),
                milliseconds(settling(|s| s.after_braking_s)),
                milliseconds(settling(|s| s.after_profile_s)),
                significant(settling(|s| s.peak_following_error_arcsec), 3),
                significant(settling(|s| s.peak_error_after_arrival_arcsec), 3),
            ])?;
        }
        writer.flush()?;
        Ok(())
    };
    write().expect("writing CSV into memory cannot fail");
    String::from_utf8(writer.into_inner().expect("flushed above")).expect("the CSV is UTF-8")
}

/// The legend entry of a scenario's curve: its elevation, and what the axis does where the
/// figure holds several motions at one elevation (Req. 5: holding, sidereal, 0.04 deg/s).
fn curve_label(o: &Outcome) -> String {
    let elevation = format!("el {:.0} deg", o.scenario.elevation_deg);
    if o.scenario.requirement != Requirement::TrackingNormalWind {
        return format!("{elevation} ({} wind)", o.scenario.wind_label);
    }
    let (start, end) = o.scenario.table.time_span();
    let rate = o.scenario.table.at(0.5 * (start + end)).azimuth_rate_deg_per_s.abs();
    let motion = if rate == 0.0 {
        "holding still".to_string()
    } else if (rate - crate::scenario::SIDEREAL_RATE_DEG_PER_S).abs() < 1e-9 {
        format!("sidereal tracking ({} deg/s)", significant(rate, 1))
    } else {
        format!("tracking at {} deg/s", significant(rate, 1))
    };
    format!("{elevation}, {motion}")
}

/// One PNG per requirement: the pointing error of each scenario against time, with the
/// 15 arcsec band and, for the settling requirements, a marker at each settling instant.
pub fn plot(outcomes: &[Outcome], directory: &Path) -> Result<Vec<PathBuf>, ReportError> {
    std::fs::create_dir_all(directory)
        .map_err(|source| ReportError::CreateFolder { path: directory.to_path_buf(), source })?;
    let mut written = Vec::new();
    for requirement in [
        Requirement::TrackingJitter,
        Requirement::SlewSettling,
        Requirement::LargeStepSettling,
        Requirement::SmallStepSettling,
        Requirement::TrackingNormalWind,
    ] {
        let group: Vec<&Outcome> = outcomes.iter().filter(|o| o.scenario.requirement == requirement).collect();
        if group.is_empty() {
            continue;
        }
        let panel = requirement_panel(requirement, &group);
        let name = requirement.label().replace(". ", "").to_lowercase();
        let path = directory.join(format!("pointing-error-{name}.png"));
        Figure::new(1100, 600).panel(panel).save_png(&path)?;
        written.push(path);
    }
    Ok(written)
}

/// The pointing error of every scenario of one requirement, each in its own colour, with the
/// settling instants (if any) marked in the colour of their curve.
fn requirement_panel(requirement: Requirement, group: &[&Outcome]) -> Panel {
    let title = match requirement {
        Requirement::TrackingNormalWind => format!("{} pointing error on the sky (normal wind)", requirement.label()),
        _ => format!("{} pointing error on the sky", requirement.label()),
    };
    let mut panel = Panel::new(&title).x_label("time (s)").y_label("pointing error (arcsec)").log_y();
    for (i, o) in group.iter().enumerate() {
        // Decimate to 100 Hz for the plot; the figures use every sample.
        let t: Vec<f64> = o.trace.time_s.iter().step_by(10).cloned().collect();
        let e: Vec<f64> = o.trace.pointing_error_arcsec().into_iter().step_by(10).map(|x| x.max(1e-3)).collect();
        panel = panel.series(Series::new(&curve_label(o), &t, &e).colour(PALETTE[i % PALETTE.len()]));
    }
    for (label, instant, colour) in settling_markers(requirement, group) {
        panel = panel.vertical_line_coloured(&label, instant, colour);
    }
    panel.horizontal_line_coloured("15 arcsec", JITTER_LIMIT_ARCSEC, LIMIT_COLOUR)
}

/// The settling markers: one per curve, except that instants closer than half a percent of the
/// time axis (a few pixels, where the lines would hide each other) share one marker, labelled
/// with each elevation's own figures and drawn in black instead of its curve's colour.
fn settling_markers(requirement: Requirement, group: &[&Outcome]) -> Vec<(String, f64, Colour)> {
    /// The curves one marker stands for.
    struct Marker<'a> {
        elevations: Vec<String>,
        instants: Vec<f64>,
        figures: Vec<String>,
        colour: Colour,
        from: &'a str,
    }
    let span = group.iter().map(|o| o.scenario.end_s).fold(0.0, f64::max);
    let mut markers: Vec<Marker> = Vec::new();
    for (i, o) in group.iter().enumerate() {
        let Some(s) = &o.settling else { continue };
        let (_, from) = requirement.judged_settling(s);
        let elevation = format!("{:.0}", o.scenario.elevation_deg);
        match markers.iter_mut().find(|m| (m.instants[0] - s.settled_at_s).abs() < 0.005 * span && m.from == from) {
            Some(marker) => {
                marker.elevations.push(elevation);
                marker.instants.push(s.settled_at_s);
                marker.figures.push(figure_text(o));
            }
            None => markers.push(Marker {
                elevations: vec![elevation],
                instants: vec![s.settled_at_s],
                figures: vec![figure_text(o)],
                colour: PALETTE[i % PALETTE.len()],
                from,
            }),
        }
    }
    markers
        .into_iter()
        .map(|m| {
            let at: Vec<String> = m.instants.iter().map(|t| format!("{t:.2}")).collect();
            let label = format!(
                "el {} deg settled at {} s ({} s {})",
                m.elevations.join("/"),
                at.join("/"),
                m.figures.join("/"),
                m.from
            );
            let colour = if m.elevations.len() > 1 { SHARED_MARKER_COLOUR } else { m.colour };
            (label, m.instants[0], colour)
        })
        .collect()
}

/// A settling marker that stands for several curves.
const SHARED_MARKER_COLOUR: Colour = Colour::rgb(0x20, 0x20, 0x20);

/// The limit line's colour: a dark red, apart from every curve's and from the shared markers.
const LIMIT_COLOUR: Colour = Colour::rgb(0xa0, 0x00, 0x00);

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn csv_figures_keep_their_meaningful_digits_only() {
        assert_eq!(significant(0.028478252287997895, 3), "0.0285");
        assert_eq!(significant(7.0477008016109, 3), "7.05");
        assert_eq!(significant(123.456, 3), "123");
        assert_eq!(significant(f64::NAN, 3), "NaN");
        assert_eq!(milliseconds(2.9139999999999944), "2.914");
        assert_eq!(milliseconds(f64::NAN), "NaN");
    }
}
