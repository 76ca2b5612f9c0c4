//! Report of a validation run: a markdown summary (effects found, fitted parameters with
//! uncertainty, error before and after on the output error and the equation error, residual
//! statistics, the output-error confirmations, the detection limits of what was not found, the
//! frequency response, the search steps) and PNG figures: the output error (measured and
//! simulated motion, residuals, before and after), the equation-error residuals and fit, the
//! residual spectra, and the measured and model frequency responses.

use super::candidates::Kind;
use super::equation_error::Structure;
use super::frequency::FrequencyResponse;
use super::output_error::ChannelKind;
use super::selection::{DetectionLimit, LimitSetBy};
use super::twist::TwistAnalysis;
use super::{ChannelStats, OutputReport, Validation};
use antenna_plot::{Figure, Panel};
use rayon::prelude::*;
use std::fmt::Write as _;
use std::path::Path;

fn stats_rows(out: &mut String, label: &str, stats: &[ChannelStats]) {
    for s in stats {
        let worst = s.cross_correlation.iter().fold(("", 0.0f64, 0.0f64), |w, (n, v, l)| {
            if v.abs() > w.1.abs() {
                (n.as_str(), *v, *l)
            } else {
                w
            }
        });
        let _ = writeln!(
            out,
            "| {label} | {} | {:.4} | {:.1} | {:.1} | {:.2e} | {:.2} | {} {:+.2} at {:+.3} s (bound {:.3}) |",
            s.name,
            s.rms,
            s.fit_percent,
            s.correlation_time,
            s.whiteness_p,
            s.lags_outside,
            worst.0,
            worst.1,
            worst.2,
            s.cross_bound
        );
    }
}

/// The markdown report.
pub fn markdown(validation: &Validation, log_name: &str) -> String {
    let v = validation;
    let d = &v.data;
    let mut out = String::new();
    let _ = writeln!(out, "# Validation of {log_name}\n");
    let _ = writeln!(
        out,
        "Equation-error route ({:?}): {} samples analysed at {:.1} Hz, smoothing cut-off {:.1} Hz, \
         sticking below {:.3e} {} left out of the torque equation. Sensor noise estimated from the data: \
         torque {:.4} {} (axis side), motor encoder {:.3e} {}, load encoder {:.3e} {}.\n",
        d.structure,
        d.len(),
        1.0 / d.dt,
        d.cutoff_hz,
        d.stick_speed,
        axis_unit("rad/s", d.linear),
        d.torque_sigma,
        axis_unit("N m", d.linear),
        d.motor_pos_sigma,
        axis_unit("rad", d.linear),
        d.load_pos_sigma,
        axis_unit("rad", d.linear)
    );
    if d.linear {
        let _ = writeln!(
            out,
            "The axis is linear (positions in metres): axis-side values are in m, m/s, N, kg, N/m and N s/m (an axis of unit radius); motor-side values (motor inertia, torque constant) stay rotary. Small positions are printed in mm.\n"
        );
    }
    for note in &v.notes {
        let _ = writeln!(out, "- note: {note}");
    }
    effects_section(&mut out, v);
    standing_section(&mut out, v);
    recheck_section(&mut out, v);
    collinear_section(&mut out, v);
    detection_section(&mut out, v);
    delay_band_section(&mut out, v);
    if let Some(drift) = &v.tacho_drift {
        drift_section(&mut out, drift);
    }
    if let Some(skew) = &v.current_skew {
        let _ = writeln!(
            out,
            "\n## Current skew taken out before the search\n\nThe delay of the applied torque, estimated over the unsmoothed band from no delay, is negative: the motion answers before the logged current, which no physical delay can do. The current's columns were shifted back by it before the effects were searched.\n\n{}.\n",
            skew.describe()
        );
    }
    if let Some(error) = &v.load_encoder_error {
        sensor_section(&mut out, error);
    }
    if let Some(t) = &v.twist {
        twist_section(&mut out, t, v.encoder_skew, d.linear);
    }
    if let Some(o) = &v.output {
        output_section(&mut out, o, d.linear);
    }
    if let Some(f) = &v.frequency {
        frequency_section(&mut out, f);
    }
    hints_section(&mut out, v);
    equation_section(&mut out, v);
    search_steps_section(&mut out, v);
    out
}

/// The effects found, with their parameters and what the data cannot tell them from.
fn effects_section(out: &mut String, v: &Validation) {
    let _ = writeln!(out, "\n## Effects found\n");
    let withdrawn = v.output.as_ref().and_then(|o| o.withdrawn.as_ref());
    if let Some(w) = withdrawn {
        let names: Vec<&str> = w.kinds.iter().map(|k| k.name()).collect();
        let _ = writeln!(
            out,
            "**No effect is claimed.** The search had added {}, but {}. The claims are withdrawn and the corrected parameter set is the starting one.\n",
            names.join(", "),
            w.reason
        );
    } else if v.selection.found.is_empty() {
        let _ = writeln!(out, "No significant missing effect.\n");
    }
    for found in &v.selection.found {
        let _ = writeln!(out, "**{}** ({})\n", found.kind.name(), found.kind.description());
        let _ = writeln!(out, "| parameter | value | standard deviation | unit |\n|---|---|---|---|");
        for (name, value, sd, unit) in &found.parameters {
            let unit = if name.starts_with("motor.") { unit.as_str() } else { axis_unit(unit, v.data.linear) };
            let _ = writeln!(out, "| {name} | {value:.6e} | {sd:.3e} | {unit} |");
        }
        let _ = writeln!(out);
        if found.kind == Kind::Delay {
            let _ = writeln!(
                out,
                "**Delay or current skew: the data cannot tell.** A current stamped earlier than the encoders by the same time reads exactly as a drive delay; only a negative delay (the current stamped late) is a sensor skew for certain.\n"
            );
        }
        if !found.correlations.is_empty() {
            let list: Vec<String> =
                found.correlations.iter().map(|(other, r)| format!("{} {r:+.2}", other.name())).collect();
            let _ = writeln!(
                out,
                "Estimated jointly with the other found effects; the largest correlation of its parameters with theirs: {}. The standard deviations above hold that trade; near 1 in magnitude only the effects' sum is determined.\n",
                list.join(", ")
            );
        }
        for alternative in v.indistinct.iter().filter(|a| a.found == found.kind) {
            let _ = writeln!(
                out,
                "**{} or {}: the data cannot tell.** Over this log's range of motion {} ({}) reproduces what {} adds to the equations to within {:.1} % (RMS; what it leaves has a chi-square of {:.1}, not significant): {}. The law both give over the log is the corrected model's; a log with a wider range of motion (angle, speed) would separate them.\n",
                found.kind.name(),
                alternative.alternative.name(),
                alternative.alternative.name(),
                alternative.alternative.description(),
                found.kind.name(),
                100.0 * alternative.misfit,
                alternative.chi2,
                alternative.changes(&v.selection.corrected, &v.start)
            );
        }
        let checked: Vec<&(Kind, Kind, String)> =
            v.selection.alike_after_search.iter().filter(|(f, _, _)| *f == found.kind).collect();
        for (_, other, reason) in &checked {
            let _ = writeln!(
                out,
                "The data cannot tell it from: {} ({}). A check after the search: {reason}.\n",
                other.name(),
                other.description()
            );
        }
        let alike: Vec<Kind> = v
            .selection
            .equally_consistent(found.kind)
            .into_iter()
            .filter(|k| !checked.iter().any(|(_, other, _)| other == k))
            .collect();
        if !alike.is_empty() {
            let names: Vec<String> = alike.iter().map(|k| format!("{} ({})", k.name(), k.description())).collect();
            let _ = writeln!(
                out,
                "The data cannot tell it from: {}. Each was confirmed on its own and predicts the log as well as {}; a log with a wider range of motion (angle, speed) would separate them.\n",
                names.join(", "),
                found.kind.name()
            );
        }
    }
    let kept = v.kept_parameters();
    if !kept.cannot_tell.is_empty() {
        let _ = writeln!(
            out,
            "**The corrected parameter set keeps the simpler law** where the data cannot tell two apart (the log supports no more than it):\n"
        );
        for line in &kept.cannot_tell {
            let _ = writeln!(out, "- {line}");
        }
        let _ = writeln!(out);
    }
}

/// The families the start holds that the re-estimation tested and left as they were: the
/// equation error finds each in the data, but the change is below the noise or does not
/// predict the motion significantly better, so the data cannot tell the start's value from the
/// re-estimate.
fn standing_section(out: &mut String, v: &Validation) {
    let Some(last) = v.selection.steps.iter().rev().find(|s| s.re_estimate && s.chosen.is_none()) else { return };
    for score in last.scores.iter().filter(|s| s.significant) {
        let Some(reason) = &score.confirmation else { continue };
        let _ = writeln!(
            out,
            "**The start's {} stands** ({}): the equation error finds it in the data (chi-square {:.1} from its neutral value), but its re-estimate is not established ({reason}): the data cannot tell the start's value from the re-estimate.\n",
            score.kind.name(),
            score.kind.description(),
            score.likelihood_ratio
        );
    }
}

/// What the log could not have shown: the detection limit of every candidate the search's
/// last step tried and did not claim.
fn detection_section(out: &mut String, v: &Validation) {
    let limits = v.selection.detection_limits();
    if limits.is_empty() {
        return;
    }
    let _ = writeln!(
        out,
        "## Detection limits: what this log cannot show
"
    );
    let _ = writeln!(
        out,
        "For each candidate the search's last step tried and did not claim: the smallest change of its leading parameter that the equation error would have found significant (at that step's p threshold, with a positive BIC gain) and at least the noise. First order from the candidate's own fit: what an effect adds to the equations grows with its size and the test statistic with its square, so the fitted change over the square root of its chi-square is its standard error. A claim also needs the output error's confirmation, so these are lower bounds: an effect of the kind below its limit cannot be claimed from this log, whatever the truth holds, and one well above it would have been put to the simulation. Candidates that do not apply to this log are listed with the reason in the search steps below.\n"
    );
    let _ = writeln!(
        out,
        "| candidate | parameter | smallest claimable change | effect/noise | set by |\n|---|---|---|---|---|"
    );
    for (kind, limit) in &limits {
        let _ = writeln!(
            out,
            "| {} | {} | {} | {:.2} | {} |",
            kind.name(),
            limit.parameter,
            limit_text(limit, v.data.linear),
            limit.effect_to_noise,
            match limit.set_by {
                LimitSetBy::Significance => "the significance test".to_string(),
                LimitSetBy::NoiseFloor => "the noise floor".to_string(),
                LimitSetBy::Beside(kind) => format!(
                    "telling it from {}, which this log resolves below the noise floor (fitted beside it)",
                    kind.name()
                ),
            }
        );
    }
    let _ = writeln!(out);
}

/// The band estimate of the delay ([`crate::band_delay`]): a delay it finds that the search
/// did not claim, with the simulation's view, or its detection limit with its band.
fn delay_band_section(out: &mut String, v: &Validation) {
    let Some(account) = &v.delay_band else { return };
    let _ = writeln!(out, "## The delay over the unsmoothed band\n");
    let searched = v.selection.detection_limits().iter().any(|(kind, _)| *kind == Kind::Delay);
    if searched {
        let _ = writeln!(out, "The search's delay test above is {}.\n", delay_search_range(v));
    }
    if account.from_band {
        let _ = writeln!(out, "**A {}.**\n", account.finding());
    } else if let Some(claimed) = account.claimed {
        // The estimate starts from the start's delay unless that led to a wrapped remainder
        // of a longer delay (`delay_account`), when it starts from the band's best one.
        let from = if account.estimate.start == v.start.value(crate::parameters::names::DELAY) {
            "from the start's delay".to_string()
        } else {
            format!(
                "from {:.3} ms (the band's best delay over the search's range: from the start's delay it finds a wrapped remainder)",
                account.estimate.start * 1e3
            )
        };
        let _ = writeln!(
            out,
            "The search claimed a delay of {:.3} ms; {from}, {} gives {:.3} +- {:.3} ms.\n",
            claimed * 1e3,
            account.estimate.method(),
            account.estimate.delay() * 1e3,
            account.estimate.sigma * 1e3
        );
    } else if account.significant {
        let _ = writeln!(out, "**A {}.**\n", account.finding());
    } else {
        let _ = writeln!(
            out,
            "The band estimate finds no delay change ({:+.3} +- {:.3} ms, chi-square {:.1} at the p threshold {:.1e}); its detection limit is {}.\n",
            account.estimate.change * 1e3,
            account.estimate.sigma * 1e3,
            account.estimate.chi2(),
            account.threshold,
            account.limit_text()
        );
    }
}

/// The motor speed sensor's integrated drift, found and taken out before the search.
fn drift_section(out: &mut String, drift: &crate::sensor_errors::TachoDrift) {
    let _ = writeln!(
        out,
        "\n## Motor speed sensor's drift taken out before the search\n\nThe motor position is integrated from a speed signal, whose bias wanders: integrated, that is a motor-position error that wanders in time and enters the twist. A piecewise linear function of time (knots {:.2} s apart: the time the speed's integrated white noise takes to reach the load encoder's noise) and a twist proportional to the motor's travel (what is left of the speed sensor's scale error) were fitted as the twist's offset on both torque equations, beside every slow effect's columns (friction levels, offset, unbalance, inertias, stiffness, lost motion, torque constant) so that none of them is taken for drift, and subtracted from the motor position before the effects were searched; the twist offset is one constant from there on.\n\n{}.\n",
        drift.spacing(),
        drift.describe()
    );
}

/// The load encoder's error, found and taken out of the data before the search.
fn sensor_section(out: &mut String, error: &crate::sensor_errors::LoadEncoderError) {
    let _ = writeln!(
        out,
        "\n## Sensor errors taken out before the search\n\nThe twist less what the motor side explains (the shaft torque over the stiffness, the lost motion, a timing skew) holds a function of the load angle that no torque explains: the load encoder's error (eccentricity, graduation; a gear's transmission error enters the equations the same way). It was estimated on the sliding samples (a polynomial of degree 6 over the angle range {:.3} to {:.3} deg, and harmonics of the angle with at least 1.5 periods in that range, each kept at a 5-sigma level divided by the orders tried and at least 3 times the twist's noise) and subtracted from the load encoder before the effects were searched. Over a short range, neighbouring harmonic orders (within about 360 deg / range) are not told apart: the function is what is estimated, not the orders.\n\n{}.\n",
        error.low.to_degrees(),
        error.high.to_degrees(),
        error.describe()
    );
}

/// A detection limit's size in the units an engineer reads (backlash in arcsec, mm on a linear
/// axis; a delay in ms; the axis-side units of a linear axis), with the ranges its searched
/// parameters were searched over: the limit holds for those only.
pub fn limit_text(limit: &DetectionLimit, linear: bool) -> String {
    let size = limit_size_text(limit, linear);
    if limit.searched.is_empty() {
        return size;
    }
    let ranges: Vec<String> =
        limit.searched.iter().map(|(name, low, high, unit)| format!("{name} {low:.2e} to {high:.2e} {unit}")).collect();
    let why = if limit.searched.iter().any(|(name, ..)| name == crate::parameters::names::COGGING_PERIOD) {
        "; shorter periods not searched: below the continuous grid (down to the shortest period the smoothing passes at the median speed) only whole numbers of cycles per motor revolution are tried, up to 64 and only those the smoothing passes at the slowest twentieth of the moving samples"
    } else {
        ""
    };
    format!("{size} (searched over {}; outside that range not searched{why})", ranges.join(", "))
}

/// A detection limit's size alone, in the units of [`limit_text`].
pub fn limit_size_text(limit: &DetectionLimit, linear: bool) -> String {
    match limit.unit {
        "rad" => {
            let (value, unit) = display(limit.size, "rad", linear);
            format!("{value:.3} {unit}")
        }
        "s" => format!("{:.2} ms", limit.size * 1e3),
        "-" => format!("{:.2} %", limit.size * 100.0),
        unit => format!("{:.3e} {}", limit.size, axis_unit(unit, linear)),
    }
}

/// One line of the detection limits for the summary.
pub fn detection_summary(v: &Validation) -> Option<String> {
    let limits = v.selection.detection_limits();
    let mut parts: Vec<String> = limits
        .iter()
        .map(|(kind, limit)| {
            let range = if *kind == Kind::Delay { format!(" ({})", delay_search_range(v)) } else { String::new() };
            format!("{} {}{range}", kind.name(), limit_text(limit, v.data.linear))
        })
        .collect();
    if let Some(account) = v.delay_band.as_ref().filter(|a| !a.significant && a.claimed.is_none()) {
        parts.push(format!("delay {}", account.limit_text()));
    }
    if parts.is_empty() {
        return None;
    }
    Some(format!("detection limits (the smallest change the search would claim): {}", parts.join(", ")))
}

/// The range and band of the search's delay test, for its detection limit: the grid of tenths
/// of a sample on the smoothed torque balance.
pub fn delay_search_range(v: &Validation) -> String {
    format!(
        "searched from 0 to {:.0} ms in tenths of a sample on the torque balance smoothed to {:.1} Hz",
        crate::candidates::DELAY_SEARCH_SECONDS * 1e3,
        v.data.cutoff_hz
    )
}

/// The backward check of the effects found before a re-estimation, run again with the
/// re-estimated values in place: what it kept and what it withdrew, with the figures.
fn recheck_section(out: &mut String, v: &Validation) {
    let Some(r) = v.output.as_ref().and_then(|o| o.recheck.as_ref()) else { return };
    let _ = writeln!(out, "{}\n", recheck_summary(r));
}

/// One paragraph on the re-check after the re-estimation, for the report and the summary.
pub fn recheck_summary(r: &crate::Recheck) -> String {
    let list = |items: &[(crate::candidates::Kind, String)]| {
        items
            .iter()
            .map(|(k, why)| format!("{} (with it against without it: {why})", k.name()))
            .collect::<Vec<_>>()
            .join("; ")
    };
    let mut text = String::from(
        "**Re-checked after the re-estimation** (each effect found before it taken out in turn with the re-estimated values in place, the others refitted, and confirmed again on the output error):",
    );
    if !r.kept.is_empty() {
        text.push_str(&format!(" kept {}", list(&r.kept)));
    }
    if !r.withdrawn.is_empty() {
        if !r.kept.is_empty() {
            text.push(';');
        }
        text.push_str(&format!(
            " withdrawn {}: the model without it, with the re-estimated values, predicts as well",
            list(&r.withdrawn)
        ));
    }
    text.push('.');
    text
}

/// Found effects that are collinear over the log: only their sum is determined.
fn collinear_section(out: &mut String, v: &Validation) {
    for pair in &v.collinear {
        let _ = writeln!(
            out,
            "**{} and {} are collinear over this log** (weighted cosine of what they add to the equations {:.3}{}): the data determine only their sum, which is the corrected model's; neither value alone is established.\n",
            pair.first.name(),
            pair.second.name(),
            pair.cosine,
            if pair.cosine < 0.0 { ": they largely cancel" } else { "" }
        );
    }
}

/// What the output error alone would confirm, not claimed.
fn hints_section(out: &mut String, v: &Validation) {
    if !v.hints.is_empty() {
        let _ = writeln!(out, "## Not claimed: what the output error alone would confirm\n");
        let _ = writeln!(
            out,
            "These effects were not significant in the equation-error test (too few independent samples: the residual's correlation time against the log's length), \
             so they are not claimed and not in the corrected parameters; added to the corrected model, the simulation would predict significantly better:\n"
        );
        for h in &v.hints {
            let _ = writeln!(
                out,
                "- {} ({}; {}): {}; equation-error p {:.2e} against its threshold {:.2e}.",
                h.kind.name(),
                h.kind.description(),
                h.changes(&v.selection.corrected),
                h.comparison.reason,
                h.equation_p,
                h.threshold
            );
        }
        let _ = writeln!(out);
    }
}

/// The equation-error residual statistics before and after.
fn equation_section(out: &mut String, v: &Validation) {
    let d = &v.data;
    let _ = writeln!(out, "## Equation error before and after\n");
    let _ = writeln!(
        out,
        "Residuals in axis-side {} (divide the torque equation by the gear ratio {} for motor-side N m).\n",
        axis_unit("N m", d.linear),
        d.gear_ratio
    );
    let _ = writeln!(out, "| model | channel | RMS | NRMSE fit % | corr. time (samples) | whiteness p | lags outside | largest cross-correlation |");
    let _ = writeln!(out, "|---|---|---|---|---|---|---|---|");
    stats_rows(out, "before", &v.before);
    stats_rows(out, "after", &v.after);
}

/// The forward search, step by step, with every candidate's score.
fn search_steps_section(out: &mut String, v: &Validation) {
    let _ = writeln!(out, "\n## Search steps\n");
    for (i, step) in v.selection.steps.iter().enumerate() {
        let chosen = match (step.chosen, step.paired) {
            (Some(a), Some(b)) => {
                format!("{} and {} (jointly: no single effect passed, the pair did)", a.name(), b.name())
            }
            (Some(a), None) => a.name().to_string(),
            _ => "none".to_string(),
        };
        if step.re_estimate {
            let _ = writeln!(
                out,
                "Step {} (re-estimate of the families the start holds: each tested in the equation error from its neutral value at p threshold {:.2e}, its change fitted in the equation error, at least the noise, and judged on the output error): chosen **{chosen}**\n",
                i + 1,
                step.threshold
            );
        } else {
            let _ = writeln!(out, "Step {} (p threshold {:.2e}): chosen **{chosen}**\n", i + 1, step.threshold);
        }
        let _ = writeln!(
            out,
            "| candidate | chi2 | parameters | p | trials | BIC gain | effect/noise | significant | searched |"
        );
        let _ = writeln!(out, "|---|---|---|---|---|---|---|---|---|");
        for s in &step.scores {
            if let Some(reason) = &s.not_applicable {
                let _ = writeln!(out, "| {} | - | - | - | - | - | - | not applicable: {reason} | |", s.kind.name());
                continue;
            }
            let searched: Vec<String> = s.searched.iter().map(|(n, v)| format!("{n} = {v:.4e}")).collect();
            let _ = writeln!(
                out,
                "| {} | {:.1} | {} | {:.2e} | {:.0} | {:.1} | {:.2} | {} | {} |",
                s.kind.name(),
                s.likelihood_ratio,
                s.parameters,
                s.p_value,
                s.trials,
                s.bic_gain,
                s.effect_to_noise,
                if s.significant { "yes" } else { "no" },
                searched.join(", ")
            );
        }
        let _ = writeln!(out);
    }
}

const ARCSEC: f64 = 180.0 * 3600.0 / std::f64::consts::PI;

/// A value in display units: angles in arcsec, speeds in arcsec/s; on a linear axis
/// positions in mm, speeds in mm/s, forces in N.
fn display(value: f64, unit: &str, linear: bool) -> (f64, &'static str) {
    match (unit, linear) {
        ("rad", false) => (value * ARCSEC, "arcsec"),
        ("rad/s", false) => (value * ARCSEC, "arcsec/s"),
        ("rad", true) => (value * 1e3, "mm"),
        ("rad/s", true) => (value * 1e3, "mm/s"),
        (_, false) => (value, "N m"),
        (_, true) => (value, "N"),
    }
}

/// Small axis-side positions for the text: (factor from SI, label).
fn small_position(linear: bool) -> (f64, &'static str) {
    if linear {
        (1e3, "mm")
    } else {
        (ARCSEC, "arcsec")
    }
}

/// The unit of an axis-side quantity on a linear axis (an axis of unit radius), or as it is on
/// a rotary one.
pub fn axis_unit(unit: &str, linear: bool) -> &str {
    if !linear {
        return unit;
    }
    match unit {
        "N m" => "N",
        "N m/rad" => "N/m",
        "N m s/rad" => "N s/m",
        "kg m^2" => "kg",
        "rad" => "m",
        "rad/s" => "m/s",
        "rad/(N m)" => "m/N",
        other => other,
    }
}

fn output_section(out: &mut String, o: &OutputReport, linear: bool) {
    let _ = writeln!(out, "## Output error before and after (plant FMU, windowed simulation)\n");
    let _ = writeln!(
        out,
        "The plant FMU (`AzimuthPlant`, {:?} drive, {:?} input) was simulated through its C ABI over {} windows of {:.3} s ({}), each started from the measured state \
         (Savitzky-Golay order 4 over {} samples) and driven by the logged command, held over each log interval at the mean of its two samples. \
         RMS over all window samples; NRMSE fit against the measured signal's variation within each window.\n",
        o.config.drive,
        o.config.input,
        o.plan.starts.len(),
        o.plan.seconds,
        o.plan.reason,
        2 * o.state_half_width + 1
    );
    if o.state_through_motor {
        let _ = writeln!(
            out,
            "The load encoder does not resolve the twist's motion at the state filter's bandwidth (its noise through the filter exceeds the twist rate's RMS): the load side's state at each window start is the motor encoder's less the smoothed twist.\n"
        );
    }
    if o.plan.drive_length < o.plan.length {
        let _ = writeln!(
            out,
            "The twist (the drive-path channel) is simulated on pieces of about {} samples ({}), each restarted from the measured state.\n",
            o.plan.drive_length, o.plan.drive_reason
        );
    }
    let _ = writeln!(out, "| output | scored | RMS before | RMS after | after/before | NRMSE fit before (%) | NRMSE fit after (%) |\n|---|---|---|---|---|---|---|");
    for (b, a) in o.before.channels.iter().zip(&o.after.channels) {
        let (rb, unit) = display(b.rms, b.kind.unit(), linear);
        let (ra, _) = display(a.rms, a.kind.unit(), linear);
        let _ = writeln!(
            out,
            "| {} | {} | {rb:.4} {unit} | {ra:.4} {unit} | {:.3} | {:.1} | {:.1} |",
            b.kind.name(),
            if b.scored {
                "yes"
            } else if b.criterion {
                "before/after only"
            } else {
                "no"
            },
            a.rms / b.rms,
            b.fit_percent,
            a.fit_percent
        );
    }
    let _ = writeln!(out, "\nCorrected against starting model: {}.\n", o.overall.reason);
    if let Some(c) = &o.calibration {
        let _ = writeln!(
            out,
            "Friction-form calibration (presliding compliance, not an effect): presliding displacement at breakaway {:.3e} rad (bristle stiffness {:.4e} N m/rad, damping {:.4e} N m s/rad, axis side), {} evaluations; {}; {}.\n",
            c.displacement,
            c.stiffness,
            c.damping,
            c.evaluations.len(),
            c.comparison.reason,
            if c.kept { "kept: \"before\" and \"after\" above are with it" } else { "not kept: the rigid stick stays" }
        );
        if let Some(starting) = &o.starting {
            let rows: Vec<String> = starting
                .channels
                .iter()
                .zip(&o.before.channels)
                .zip(&o.after.channels)
                .filter(|((s, _), _)| s.scored)
                .map(|((s, b), a)| {
                    let (rs, unit) = display(s.rms, s.kind.unit(), linear);
                    let (rb, _) = display(b.rms, b.kind.unit(), linear);
                    let (ra, _) = display(a.rms, a.kind.unit(), linear);
                    format!("{} {rs:.4} -> {rb:.4} -> {ra:.4} {unit}", s.kind.name())
                })
                .collect();
            let _ = writeln!(out, "Starting model (rigid stick) -> calibrated -> corrected: {}.\n", rows.join("; "));
        }
    }
    let refits = [
        (&o.refit, "Parameters refitted on the output error", "the equation-error fit's"),
        (
            &o.refit_after_reestimate,
            "After the re-estimation of the start's families, all found effects' parameters refitted together",
            "the re-estimated model's",
        ),
        (
            &o.recheck.as_ref().and_then(|r| r.refit.clone()),
            "After the re-check withdrew an effect, the effects left refitted together",
            "the model without it",
        ),
    ];
    for (refit, what, of) in refits {
        let Some(r) = refit else { continue };
        let changes: Vec<String> = r.changes.iter().map(|(name, a, b)| format!("{name} {a:.4e} -> {b:.4e}")).collect();
        let _ = writeln!(
            out,
            "{what} (Levenberg-Marquardt, {} iterations): {}; score {:.3} of {of}.\n",
            r.iterations,
            changes.join(", "),
            r.score_after
        );
    }
    if !o.confirmations.is_empty() {
        let _ = writeln!(
            out,
            "Output-error confirmations asked during the search (each effect against the model without it):\n"
        );
        for (kind, c) in &o.confirmations {
            let _ = writeln!(
                out,
                "- {}: {} -> **{}**",
                kind.name(),
                c.reason,
                if c.confirmed { "confirmed" } else { "rejected" }
            );
        }
        let _ = writeln!(out);
    }
}

/// One line on what the twist says, for the KUKA summary and the report.
pub fn twist_summary(t: &TwistAnalysis, corrected: Option<f64>, linear: bool) -> String {
    let (scale, small) = small_position(linear);
    let mut parts = Vec::new();
    let skew = t.skew();
    parts.push(match corrected {
        Some(tau) => format!(
            "load encoder **{:.2} ms behind** the motor encoder (+- {:.2} ms; data corrected)",
            tau * 1e3,
            skew.sd * 1e3
        ),
        None => format!("no encoder timing skew ({:.3} +- {:.3} ms, not significant)", skew.value * 1e3, skew.sd * 1e3),
    });
    if let Some((k, sd)) = t.rigid_stiffness() {
        parts.push(format!(
            "path compliance: K = {k:.3e} +- {sd:.1e} {} (twist {:.1} {small} RMS)",
            t.compliance().rms * scale,
            axis_unit("N m/rad", linear)
        ));
    } else if t.structure != Structure::TwoMass {
        parts.push(format!(
            "no significant path compliance (1/K = {:.2e} +- {:.1e} {})",
            t.compliance().value,
            t.compliance().sd,
            axis_unit("rad/(N m)", linear)
        ));
    }
    let b = t.lost_motion();
    if b.significant && t.structure != Structure::TwoMass {
        parts.push(format!("lost motion {:.1} +- {:.1} {small}", b.value * scale, b.sd * scale));
    }
    let position = t.position_dependent();
    if position.significant {
        parts.push(format!("position-dependent twist (transmission error) {:.1} {small} RMS", position.rms * scale));
    }
    parts.push(format!(
        "twist residual {:.1} -> {:.1} {small} RMS (sensor noise {:.2} {small})",
        t.rms_before * scale,
        t.rms_after * scale,
        t.noise * scale
    ));
    parts.join("; ")
}

fn twist_section(out: &mut String, t: &TwistAnalysis, corrected: Option<f64>, linear: bool) {
    let (scale, small) = small_position(linear);
    let _ = writeln!(out, "## Two encoders: what the twist says\n");
    let _ = writeln!(
        out,
        "The measured twist (motor encoder referred to the axis minus load encoder) less the model's own twist, regressed on a constant (encoder offsets), \
         the load speed (a timing skew between the encoders), the shaft torque the model says the motor delivers (compliance), its smoothed sign \
         (lost motion) and a cubic in the axis angle (transmission error); {} samples where the motor slides (a sticking motor's friction, and with it \
         the shaft torque, is not a function of the speed), residual correlation time {:.1} samples. {}.\n",
        t.samples,
        t.correlation_time,
        twist_summary(t, corrected, linear)
    );
    let _ = writeln!(out, "| term | value | standard deviation | unit | RMS added to the twist ({small}) | significant |\n|---|---|---|---|---|---|");
    for term in &t.terms {
        let _ = writeln!(
            out,
            "| {} | {:.4e} | {:.2e} | {} | {:.3} | {} |",
            term.name,
            term.value,
            term.sd,
            axis_unit(term.unit, linear),
            term.rms * scale,
            if term.significant { "yes" } else { "no" }
        );
    }
    if t.structure == Structure::TwoMass {
        let _ = writeln!(out, "\nWith a two-mass starting set, compliance and lost motion are judged by the candidate library (stiffness, backlash); only the skew is acted on here. The shaft torque's motor-side viscous and Coulomb friction are taken from the total-torque equation, in which a skew between the encoders cancels, so that a friction change found on skewed data does not stand in for part of the skew.");
    } else if t.rigid_stiffness().is_some() || t.lost_motion().significant {
        let _ = writeln!(
            out,
            "\nNot written into the corrected parameters: a compliant plant also needs the split of the inertia between motor and load, which a rigid starting set does not have. \
             Give path.stiffness and load.inertia in the starting set to check compliance and lost motion in the two torque equations."
        );
    }
    let _ = writeln!(out);
}

fn frequency_section(out: &mut String, f: &FrequencyResponse) {
    let _ = writeln!(out, "## Frequency response, torque to motor speed\n");
    let measured = match f.measured_anti_resonance {
        Some(m) => format!("{m:.3} Hz"),
        None => "not resolved (coherence below its 95 % threshold over more than 20 % of the band)".to_string(),
    };
    let _ = writeln!(
        out,
        "H1 from the logged torque to the motor speed, band {:.2}-{:.2} Hz around the model's anti-resonance; broadband excitation there: {}. \
         Anti-resonance (trough): measured {measured}, model before {:.3} Hz, after {:.3} Hz.\n",
        f.band.0,
        f.band.1,
        if f.broadband { "yes" } else { "no" },
        f.before_anti_resonance,
        f.after_anti_resonance
    );
}

/// Writes the figures: output error (measured and simulated, residuals), equation-error
/// residuals and fit, spectra, frequency response.
pub fn figures(validation: &Validation, dir: &Path, stem: &str) -> Result<Vec<String>, String> {
    let v = validation;
    type Draw<'a> = Box<dyn Fn() -> Figure + Sync + 'a>;
    let mut drawn: Vec<(String, Draw)> = vec![
        (format!("{stem}_residuals.png"), Box::new(|| residuals_figure(v, stem))),
        (format!("{stem}_spectra.png"), Box::new(|| spectra_figure(v, stem))),
    ];
    if let Some(o) = &v.output {
        drawn.push((format!("{stem}_output.png"), Box::new(move || output_figure(o, stem))));
    }
    if let Some(t) = &v.twist {
        drawn.push((format!("{stem}_twist.png"), Box::new(move || twist_figure(t, v.encoder_skew, stem))));
    }
    if let Some(f) = &v.frequency {
        drawn.push((format!("{stem}_frequency.png"), Box::new(move || frequency_figure(f, stem))));
    }
    // The figures do not depend on each other: they are drawn and written side by side, and
    // listed (or the first failure reported) in the order above.
    let saved: Vec<Result<String, String>> = drawn
        .par_iter()
        .map(|(name, draw)| {
            let path = dir.join(name);
            draw().save_png(&path).map_err(|e| e.to_string())?;
            Ok(path.display().to_string())
        })
        .collect();
    saved.into_iter().collect()
}

/// The equation-error residuals before and after, with the measured and modelled torques.
fn residuals_figure(v: &Validation, stem: &str) -> Figure {
    let t = &v.data.time;
    let before_fitted = v.selection.before.fitted();
    let after_fitted = v.selection.after.fitted();
    let mut figure =
        Figure::new(1400, 450 * v.before.len() as u32 * 2).title(&format!("{stem}: equation-error residuals and fit"));
    for (c, channel) in v.selection.before.channels.iter().enumerate() {
        let measured = &channel.measured;
        figure = figure.panel(
            Panel::new(&format!("{}: measured and model (N m)", channel.name))
                .x_label("time (s)")
                .y_label("torque (N m)")
                .line("measured", t, measured)
                .line("model before", t, &before_fitted[c])
                .line("model after", t, &after_fitted[c]),
        );
        figure = figure.panel(
            Panel::new(&format!(
                "{}: residual before (RMS {:.3}) and after (RMS {:.3})",
                channel.name, v.before[c].rms, v.after[c].rms
            ))
            .x_label("time (s)")
            .y_label("residual (N m)")
            .line("before", t, &v.selection.before.residual[c])
            .line("after", t, &v.selection.after.residual[c]),
        );
    }
    figure
}

/// The equation-error residuals' spectra before and after, with the smoothing's cut-off.
fn spectra_figure(v: &Validation, stem: &str) -> Figure {
    let d = &v.data;
    let mut spectra = Figure::new(1200, 450 * v.before.len() as u32).title(&format!("{stem}: residual spectra"));
    for (c, channel) in v.selection.before.channels.iter().enumerate() {
        let segment = (d.len() / 8).clamp(64, 4096);
        let config = antenna_dsp::WelchConfig::new(segment.min(d.len()));
        let (Ok(before), Ok(after)) = (
            antenna_dsp::welch_psd(&v.selection.before.residual[c], 1.0 / d.dt, &config),
            antenna_dsp::welch_psd(&v.selection.after.residual[c], 1.0 / d.dt, &config),
        ) else {
            continue;
        };
        let (f, before, after) = (before.frequency_hz, before.psd, after.psd);
        spectra = spectra.panel(
            Panel::new(&format!("{}: residual PSD", channel.name))
                .x_label("frequency (Hz)")
                .y_label("PSD ((N m)^2/Hz)")
                .log_x()
                .log_y()
                .line("before", &f[1..], &before[1..])
                .line("after", &f[1..], &after[1..])
                .vertical_line("smoothing cut-off", d.cutoff_hz),
        );
    }
    spectra
}

/// The measured twist less the model's, what the significant terms fit of it, and what is
/// left, in arcsec.
pub fn twist_figure(t: &TwistAnalysis, corrected: Option<f64>, stem: &str) -> Figure {
    let scale = |x: &[f64]| x.iter().map(|v| v * ARCSEC).collect::<Vec<f64>>();
    let residual: Vec<f64> = t.before.iter().zip(&t.fitted).map(|(b, f)| (b - f) * ARCSEC).collect();
    let skew = match corrected {
        Some(tau) => format!("load encoder {:.2} ms behind the motor encoder", tau * 1e3),
        None => "no timing skew".to_string(),
    };
    Figure::new(1400, 900)
        .title(&format!("{stem}: twist (motor minus load encoder) less the model's; {skew}"))
        .panel(
            Panel::new(&format!("measured (RMS {:.2} arcsec) and the significant terms", t.rms_before * ARCSEC))
                .x_label("time (s)")
                .y_label("arcsec")
                .line("measured less model", &t.time, &scale(&t.before))
                .line("fitted terms", &t.time, &scale(&t.fitted)),
        )
        .panel(
            Panel::new(&format!(
                "left after the terms (RMS {:.2} arcsec; sensor noise {:.2} arcsec)",
                t.rms_after * ARCSEC,
                t.noise * ARCSEC
            ))
            .x_label("time (s)")
            .y_label("arcsec")
            .line("residual", &t.time, &residual),
        )
}

/// Values of consecutive windows with a NaN between windows, so a line breaks at each restart.
fn with_gaps(values: &[f64], length: usize, scale: f64) -> Vec<f64> {
    let mut out = Vec::with_capacity(values.len() + values.len() / length.max(1));
    for (i, v) in values.iter().enumerate() {
        if i > 0 && i % length == 0 {
            out.push(f64::NAN);
        }
        out.push(v * scale);
    }
    out
}

/// Measured and simulated motion and the residual, before and after, per scored output.
pub fn output_figure(o: &OutputReport, stem: &str) -> Figure {
    let length = o.plan.length;
    let time = with_gaps(&o.before.time, length, 1.0);
    let scored: Vec<usize> = (0..o.before.channels.len()).filter(|&c| o.before.channels[c].criterion).collect();
    let mut figure = Figure::new(1400, 420 * 2 * scored.len() as u32).title(&format!(
        "{stem}: output error (plant FMU over {} windows of {:.2} s)",
        o.plan.starts.len(),
        o.plan.seconds
    ));
    for c in scored {
        let (b, a) = (&o.before.channels[c], &o.after.channels[c]);
        let per_second = b.kind.unit() != "rad";
        let largest = |series: &[&[f64]]| {
            series.iter().flat_map(|s| s.iter()).filter(|v| v.is_finite()).fold(0.0f64, |m, v| m.max(v.abs()))
        };
        let (motion_scale, motion_unit) =
            angle_display(largest(&[&b.measured, &b.simulated, &a.simulated]), per_second);
        figure = figure.panel(
            Panel::new(&format!("{}: measured and simulated", b.kind.name()))
                .x_label("time (s)")
                .y_label(motion_unit)
                .line("measured", &time, &with_gaps(&b.measured, length, motion_scale))
                .line("model before", &time, &with_gaps(&b.simulated, length, motion_scale))
                .line("model after", &time, &with_gaps(&a.simulated, length, motion_scale)),
        );
        let (residual_before, residual_after) = (b.residual(), a.residual());
        let (scale, unit) = angle_display(largest(&[&residual_before, &residual_after]), per_second);
        figure = figure.panel(
            Panel::new(&format!(
                "{}: residual, RMS {:.4} -> {:.4} {unit}",
                b.kind.name(),
                b.rms * scale,
                a.rms * scale
            ))
            .x_label("time (s)")
            .y_label(unit)
            .line("before", &time, &with_gaps(&residual_before, length, scale))
            .line("after", &time, &with_gaps(&residual_after, length, scale)),
        );
    }
    figure
}

/// The display unit that fits angles (or angular speeds) up to `largest` rad (rad/s): degrees
/// for motions of a degree and more, arcsec for small residuals, so the tick labels stay
/// plain numbers (no mix of decimals and powers of ten). (factor from SI, unit)
fn angle_display(largest: f64, per_second: bool) -> (f64, &'static str) {
    let degree = std::f64::consts::PI / 180.0;
    match (largest >= degree, per_second) {
        (true, false) => (1.0 / degree, "deg"),
        (true, true) => (1.0 / degree, "deg/s"),
        (false, false) => (ARCSEC, "arcsec"),
        (false, true) => (ARCSEC, "arcsec/s"),
    }
}

/// Measured H1 with the model responses, and the coherence.
pub fn frequency_figure(f: &FrequencyResponse, stem: &str) -> Figure {
    let keep: Vec<usize> = (1..f.frequency_hz.len()).collect();
    let x: Vec<f64> = keep.iter().map(|&k| f.frequency_hz[k]).collect();
    let db = |h: &[antenna_dsp::Complex64]| keep.iter().map(|&k| 20.0 * h[k].norm().log10()).collect::<Vec<_>>();
    let mut magnitude = Panel::new("torque to motor speed |H| (dB re 1 rad/s per N m)")
        .x_label("frequency (Hz)")
        .y_label("dB")
        .log_x()
        .line("measured H1", &x, &db(&f.measured))
        .line("model before", &x, &db(&f.before))
        .line("model after", &x, &db(&f.after))
        .vertical_line("model anti-resonance (before)", f.before_anti_resonance);
    if let Some(m) = f.measured_anti_resonance {
        magnitude = magnitude.vertical_line("measured anti-resonance", m);
    }
    let coherence: Vec<f64> = keep.iter().map(|&k| f.coherence[k]).collect();
    Figure::new(1200, 900).title(&format!("{stem}: frequency response")).panel(magnitude).panel(
        Panel::new("coherence")
            .x_label("frequency (Hz)")
            .y_label("coherence")
            .log_x()
            .y_range(0.0, 1.05)
            .line("coherence", &x, &coherence)
            .horizontal_line("95 % threshold", f.coherence_threshold),
    )
}

/// The section of docs/results/validation-results.md on measured logs (the KUKA axes): per axis the
/// effects found with their parameters, the output and equation errors before and after, the
/// confirmations that were rejected, and the figures. `rows` holds (axis, validation, run time
/// in seconds, figure paths).
pub fn kuka_section(rows: &[(usize, Validation, f64, Vec<String>)]) -> String {
    let mut out = String::new();
    let _ = writeln!(
        out,
        "Starting sets `tools/validate/data/kuka/axisN.params`: only the published gear ratio, motor inertia and torque constant (no stiffness, \
         so the plant FMU runs with a rigid drive and only the total torque equation is used). Output error: the plant FMU driven by the \
         logged motor torque over windows re-initialised from the measured state; positions in arcsec (1 deg = 3600 arcsec). \
         Equation error: axis-side N m (motor side = / gear ratio).\n"
    );
    let _ = writeln!(out, "| axis | effects found (value +- sd) | windows | axis position RMS before -> after | motor position RMS before -> after | NRMSE fit (axis position) | total torque RMS before -> after (axis N m) | fit (torque) | whiteness p after | run time |");
    let _ = writeln!(out, "|---|---|---|---|---|---|---|---|---|---|");
    for (axis, v, seconds, _) in rows {
        kuka_row(&mut out, *axis, v, *seconds);
    }
    let _ = writeln!(out);
    for (axis, v, _, figures) in rows {
        kuka_axis_notes(&mut out, *axis, v, figures);
    }
    out
}

/// One axis's row of the KUKA table.
fn kuka_row(out: &mut String, axis: usize, v: &Validation, seconds: f64) {
    let found: Vec<String> = v
        .selection
        .found
        .iter()
        .map(|f| {
            let params: Vec<String> = f
                .parameters
                .iter()
                .filter(|p| !p.0.ends_with("change"))
                .map(|(n, value, sd, unit)| format!("{n} = {value:.4e} +- {sd:.2e} {unit}"))
                .collect();
            format!("**{}**: {}", f.kind.name(), params.join(", "))
        })
        .collect();
    let mut found = found;
    if let Some(skew) = v.encoder_skew {
        found.insert(
            0,
            format!("**encoder skew**: load encoder {:.2} ms behind the motor encoder (data corrected)", skew * 1e3),
        );
    }
    if let Some(error) = &v.load_encoder_error {
        found.insert(
            0,
            format!("**load encoder error**: {:.2} arcsec RMS over the log (data corrected)", error.rms * ARCSEC),
        );
    }
    let found = if found.is_empty() { "none".to_string() } else { found.join("; ") };
    let (windows, axis_pos, motor_pos, fit) = match &v.output {
        Some(o) => {
            let pick = |kind: ChannelKind| -> String {
                match (o.before.channel(kind), o.after.channel(kind)) {
                    (Some(b), Some(a)) => {
                        format!("{:.1} -> {:.1} ({:.2})", b.rms * ARCSEC, a.rms * ARCSEC, a.rms / b.rms)
                    }
                    _ => "-".into(),
                }
            };
            let fit = match (o.before.channel(ChannelKind::AxisPosition), o.after.channel(ChannelKind::AxisPosition)) {
                (Some(b), Some(a)) => format!("{:.1} -> {:.1} %", b.fit_percent, a.fit_percent),
                _ => "-".into(),
            };
            (
                format!("{} x {:.2} s", o.plan.starts.len(), o.plan.seconds),
                pick(ChannelKind::AxisPosition),
                pick(ChannelKind::MotorPosition),
                fit,
            )
        }
        None => ("-".into(), "-".into(), "-".into(), "-".into()),
    };
    let c = v.most_improved_channel();
    let _ = writeln!(
        out,
        "| {axis} | {found} | {windows} | {axis_pos} | {motor_pos} | {fit} | {:.0} -> {:.0} ({:.2}) | {:.1} -> {:.1} % | {:.1e} | {:.1} s |",
        v.before[c].rms,
        v.after[c].rms,
        v.after[c].rms / v.before[c].rms,
        v.before[c].fit_percent,
        v.after[c].fit_percent,
        v.after[c].whiteness_p,
        seconds
    );
}

/// One axis's paragraph under the KUKA table: rejected confirmations, windows, the twist, the
/// hints, the notes and the figures.
fn kuka_axis_notes(out: &mut String, axis: usize, v: &Validation, figures: &[String]) {
    let _ = writeln!(out, "**Axis {axis}.**");
    if let Some(o) = &v.output {
        let rejected: Vec<String> = o
            .confirmations
            .iter()
            .filter(|(_, c)| !c.confirmed)
            .map(|(k, c)| format!("{} ({})", k.name(), c.reason))
            .collect();
        if !rejected.is_empty() {
            let _ = writeln!(
                out,
                "Significant in the equation error but not confirmed by the output error: {}.",
                rejected.join("; ")
            );
        }
        let _ = writeln!(out, "Windows: {}. Corrected against starting model: {}.", o.plan.reason, o.overall.reason);
    }
    if let Some(t) = &v.twist {
        let _ = writeln!(out, "Two encoders: {}.", twist_summary(t, v.encoder_skew, false));
    }
    for h in &v.hints {
        let _ = writeln!(
            out,
            "Not claimed (equation-error p {:.1e} above its threshold {:.1e}), but the output error alone would confirm **{}** ({}) on top of the corrected model: {}.",
            h.equation_p,
            h.threshold,
            h.kind.name(),
            h.changes(&v.selection.corrected),
            h.comparison.reason
        );
    }
    for note in &v.notes {
        let _ = writeln!(out, "Note: {note}.");
    }
    let names: Vec<String> = figures
        .iter()
        .filter_map(|f| {
            Path::new(f).file_name().map(|n| format!("[{}](../figures/{})", n.to_string_lossy(), n.to_string_lossy()))
        })
        .collect();
    let _ = writeln!(out, "Figures: {}.\n", names.join(", "));
}
