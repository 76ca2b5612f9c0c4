//! Report of a validation run: a markdown summary (effects found, fitted parameters with
//! uncertainty, error before and after, residual statistics, the search steps) and PNG figures
//! of the residuals and the fit before and after, and of the residual spectra.

use super::stats;
use super::{ChannelStats, Validation};
use crate::plot::{Figure, Panel};
use std::fmt::Write as _;
use std::path::Path;

fn stats_rows(out: &mut String, label: &str, stats: &[ChannelStats]) {
    for s in stats {
        let worst = s.cross_correlation.iter().fold(("", 0.0f64, 0.0f64), |w, (n, v, l)| if v.abs() > w.1.abs() { (n.as_str(), *v, *l) } else { w });
        let _ = writeln!(
            out,
            "| {label} | {} | {:.4} | {:.1} | {:.1} | {:.2e} | {:.2} | {} {:+.2} at {:+.3} s (bound {:.3}) |",
            s.name, s.rms, s.fit_percent, s.correlation_time, s.whiteness_p, s.lags_outside, worst.0, worst.1, worst.2, s.cross_bound
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
         sticking below {:.3e} rad/s left out of the torque equation. Sensor noise estimated from the data: \
         torque {:.4} N m (axis side), motor encoder {:.3e} rad, load encoder {:.3e} rad.\n",
        d.structure,
        d.len(),
        1.0 / d.dt,
        d.cutoff_hz,
        d.stick_speed,
        d.torque_sigma,
        d.motor_pos_sigma,
        d.load_pos_sigma
    );
    for note in &v.notes {
        let _ = writeln!(out, "- note: {note}");
    }
    let _ = writeln!(out, "\n## Effects found\n");
    if v.selection.found.is_empty() {
        let _ = writeln!(out, "No significant missing effect.\n");
    }
    for found in &v.selection.found {
        let _ = writeln!(out, "**{}** ({})\n", found.kind.name(), found.kind.description());
        let _ = writeln!(out, "| parameter | value | standard deviation | unit |\n|---|---|---|---|");
        for (name, value, sd, unit) in &found.parameters {
            let _ = writeln!(out, "| {name} | {value:.6e} | {sd:.3e} | {unit} |");
        }
        let _ = writeln!(out);
    }
    let _ = writeln!(out, "## Error before and after\n");
    let _ = writeln!(out, "Residuals in axis-side N m (divide the torque equation by the gear ratio {} for motor-side N m).\n", d.gear_ratio);
    let _ = writeln!(out, "| model | channel | RMS | NRMSE fit % | corr. time (samples) | whiteness p | lags outside | largest cross-correlation |");
    let _ = writeln!(out, "|---|---|---|---|---|---|---|---|");
    stats_rows(&mut out, "before", &v.before);
    stats_rows(&mut out, "after", &v.after);
    let _ = writeln!(out, "\n## Search steps\n");
    for (i, step) in v.selection.steps.iter().enumerate() {
        let chosen = step.chosen.map(|k| k.name()).unwrap_or("none");
        let _ = writeln!(out, "Step {} (p threshold {:.2e}): chosen **{chosen}**\n", i + 1, step.threshold);
        let _ = writeln!(out, "| candidate | chi2 | parameters | p | trials | BIC gain | effect/noise | significant | searched |");
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
    out
}

/// Writes the figures: residuals before/after, measured vs model before/after, spectra.
pub fn figures(validation: &Validation, dir: &Path, stem: &str) -> Result<Vec<String>, String> {
    let v = validation;
    let d = &v.data;
    let mut written = Vec::new();
    let t = &d.time;
    let before_fitted = v.selection.before.fitted();
    let after_fitted = v.selection.after.fitted();
    let mut figure = Figure::new(1400, 450 * v.before.len() as u32 * 2).title(&format!("{stem}: equation-error residuals and fit"));
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
            Panel::new(&format!("{}: residual before (RMS {:.3}) and after (RMS {:.3})", channel.name, v.before[c].rms, v.after[c].rms))
                .x_label("time (s)")
                .y_label("residual (N m)")
                .line("before", t, &v.selection.before.residual[c])
                .line("after", t, &v.selection.after.residual[c]),
        );
    }
    let path = dir.join(format!("{stem}_residuals.png"));
    figure.save_png(&path).map_err(|e| e.to_string())?;
    written.push(path.display().to_string());

    let mut spectra = Figure::new(1200, 450 * v.before.len() as u32).title(&format!("{stem}: residual spectra"));
    for (c, channel) in v.selection.before.channels.iter().enumerate() {
        let segment = (d.len() / 8).clamp(64, 4096);
        let (f, before) = stats::welch_psd(&v.selection.before.residual[c], 1.0 / d.dt, segment);
        let (_, after) = stats::welch_psd(&v.selection.after.residual[c], 1.0 / d.dt, segment);
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
    let path = dir.join(format!("{stem}_spectra.png"));
    spectra.save_png(&path).map_err(|e| e.to_string())?;
    written.push(path.display().to_string());
    Ok(written)
}
