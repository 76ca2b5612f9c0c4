//! Runs the requirement scenarios and writes the requirement report: a table of Req. 1-5 with
//! the measured figure beside each limit (printed, as markdown and as CSV) and plots of the
//! pointing error against time.

use std::fmt::Write as _;
use std::path::Path;

use super::coupled::{AntennaConfig, CoupledAntenna, FmuSet, Trace};
use super::metrics::{settling, worst_window_jitter_arcsec, Settling};
use super::scenario::{Analysis, Requirement, Scenario, JITTER_LIMIT_ARCSEC};
use antenna_plot::{Figure, Panel};

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

/// Runs one scenario on the coupled antenna.
pub fn run_scenario(
    fmus: &FmuSet,
    base: &AntennaConfig,
    scenario: &Scenario,
    progress: &mut dyn FnMut(f64),
) -> Result<Outcome, String> {
    let config = AntennaConfig { wind: scenario.wind.clone(), ..base.clone() };
    let started = std::time::Instant::now();
    let mut antenna =
        CoupledAntenna::new(fmus, &config, &scenario.table).map_err(|e| format!("{}: {e}", scenario.name))?;
    let trace =
        antenna.run(&scenario.table, scenario.end_s, progress).map_err(|e| format!("{}: {e}", scenario.name))?;
    let wall_s = started.elapsed().as_secs_f64();
    let (figure, settling_result, window) = match scenario.analysis {
        Analysis::Jitter { from_s } => {
            let (value, start) =
                worst_window_jitter_arcsec(&trace, from_s).ok_or("run too short for a jitter window")?;
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

/// The requirement table as CSV.
pub fn csv(outcomes: &[Outcome]) -> String {
    let mut out = String::from(
        "requirement,scenario,elevation_deg,wind,wind_mean_m_s,figure,unit,limit,passed,settling_after_command_s,settling_after_braking_s,settling_after_profile_arrival_s,peak_following_error_arcsec,peak_error_after_arrival_arcsec\n",
    );
    for o in outcomes {
        let r = o.scenario.requirement;
        let _ = writeln!(
            out,
            "{},{},{},{},{},{},{},{},{},{},{},{},{},{}",
            r.label(),
            o.scenario.name,
            o.scenario.elevation_deg,
            o.scenario.wind_label,
            o.scenario.wind.mean_speed_m_s,
            o.figure,
            r.unit(),
            r.limit(),
            o.passed,
            o.settling.map_or(f64::NAN, |s| s.after_command_s),
            o.settling.map_or(f64::NAN, |s| s.after_braking_s),
            o.settling.map_or(f64::NAN, |s| s.after_profile_s),
            o.settling.map_or(f64::NAN, |s| s.peak_following_error_arcsec),
            o.settling.map_or(f64::NAN, |s| s.peak_error_after_arrival_arcsec)
        );
    }
    out
}

/// One PNG per requirement: the pointing error of each elevation against time, with the
/// 15 arcsec band.
pub fn plot(outcomes: &[Outcome], directory: &Path) -> Result<Vec<std::path::PathBuf>, String> {
    std::fs::create_dir_all(directory).map_err(|e| e.to_string())?;
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
        let mut panel = Panel::new(&format!("{} pointing error on the sky", requirement.label()))
            .x_label("time (s)")
            .y_label("pointing error (arcsec)")
            .log_y();
        for o in &group {
            // Decimate to 100 Hz for the plot; the figures use every sample.
            let t: Vec<f64> = o.trace.time_s.iter().step_by(10).cloned().collect();
            let e: Vec<f64> = o.trace.pointing_error_arcsec().into_iter().step_by(10).map(|x| x.max(1e-3)).collect();
            panel =
                panel.line(&format!("el {:.0} deg ({} wind)", o.scenario.elevation_deg, o.scenario.wind_label), &t, &e);
        }
        panel = panel.horizontal_line("15 arcsec", JITTER_LIMIT_ARCSEC);
        let name = requirement.label().replace(". ", "").to_lowercase();
        let path = directory.join(format!("pointing-error-{name}.png"));
        Figure::new(1100, 600).panel(panel).save_png(&path).map_err(|e| e.0)?;
        written.push(path);
    }
    Ok(written)
}
