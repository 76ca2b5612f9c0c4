//! The sweep's report beside its CSV: `sweep.md` with the pass probability of every requirement
//! and its confidence interval, percentiles of the figure, the worst samples with the command
//! that reruns each alone with traces, the sensitivity ranking, and the figures (histograms
//! against the limit, tornado charts, the figure against the two most influential parameters).

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use antenna_plot::{Colour, Figure, LegendPosition, Panel, PlotError, Series};

use super::analysis::{clopper_pearson, percentile, sensitivity, Influence, SweepData};
use super::{Sweep, SweepSpec};
use antenna_fmus::parameters::Scale;

/// The confidence of the intervals.
pub const CONFIDENCE: f64 = 0.95;

/// How the worst samples and the report name the sweep's command.
const PROGRAM: &str = "cargo run --release -p antenna-cli --bin antenna -- sweep";

/// How a run went, when the report is written by the run itself.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Timing {
    pub wall_s: f64,
    pub threads: usize,
    pub simulated_s: f64,
}

/// Writes `sweep.md` and the figures into `folder`; returns the report's path.
pub fn write_report(
    data: &SweepData,
    sweep: &Sweep,
    timing: Option<Timing>,
    folder: &Path,
) -> Result<PathBuf, ReportWriteError> {
    // Parameters spread on a log scale are plotted on one.
    let log_scaled: Vec<&str> =
        sweep.parameters.iter().filter(|p| p.scale == Scale::Log).map(|p| p.name.as_str()).collect();
    let figures = plot_figures(data, &log_scaled, folder)?;
    let text = markdown(data, &sweep.spec, timing, &figures);
    let path = folder.join("sweep.md");
    std::fs::write(&path, text).map_err(|source| ReportWriteError::Write { path: path.clone(), source })?;
    Ok(path)
}

/// Why the report could not be written.
#[derive(Debug, thiserror::Error)]
pub enum ReportWriteError {
    #[error("cannot write {}", path.display())]
    Write { path: PathBuf, source: std::io::Error },
    #[error(transparent)]
    Plot(#[from] PlotError),
}

/// A figure in a requirement's unit ("not settled" for +inf).
fn figure_text(value: f64, unit: &str) -> String {
    if !value.is_finite() {
        "not settled".to_string()
    } else if unit == "s" {
        format!("{value:.2}")
    } else {
        format!("{value:.3}")
    }
}

fn percent(p: f64) -> String {
    format!("{:.1} %", 100.0 * p)
}

/// The report's text.
pub fn markdown(
    data: &SweepData,
    spec: &SweepSpec,
    timing: Option<Timing>,
    figures: &[(usize, Vec<String>)],
) -> String {
    let mut out = String::from("# Sweep report\n\n");
    let varied = data.varied_parameters();
    let _ = writeln!(out, "Command: `{PROGRAM} {} --out DIR`\n", spec.command_line());
    let _ = writeln!(
        out,
        "{} samples ({} sampling, seed {}), {} scenarios each, {} rows; {} parameters varied: {}.\n",
        data.samples.len(),
        spec.method.name(),
        spec.seed,
        data.scenarios.len(),
        data.scenarios.iter().map(|s| s.figures.len()).sum::<usize>(),
        varied.len(),
        varied.iter().map(|&p| format!("`{}`", data.parameter_names[p])).collect::<Vec<_>>().join(", ")
    );
    if let Some(t) = timing {
        let _ = writeln!(
            out,
            "Run: {:.0} s simulated in {:.1} s wall-clock on {} threads ({:.2} samples/s).\n",
            t.simulated_s,
            t.wall_s,
            t.threads,
            data.samples.len() as f64 / t.wall_s
        );
    }
    if data.failed_samples > 0 {
        let _ = writeln!(
            out,
            "**{} of {} samples could not run** and are left out of everything below (a parameter set the FMUs refuse is no antenna; a run that stopped is listed in the CSV's `error` column). The first: {}\n",
            data.failed_samples,
            data.failed_samples + data.samples.len() as u64,
            data.first_failure.as_deref().unwrap_or("")
        );
    }
    out.push_str(&requirement_table(data));
    out.push_str(&scenario_table(data));
    out.push_str(&worst_samples(data, spec));
    out.push_str(&sensitivity_section(data, figures));
    out
}

/// The table of pass probabilities per requirement (markdown), as the report and the command
/// print it.
pub fn requirement_table(data: &SweepData) -> String {
    let mut out = format!(
        "## Pass probability per requirement\n\nA sample meets a requirement when every one of its scenarios of that requirement passes; its figure is the worst of them. Interval: exact (Clopper-Pearson), {:.0} %.\n\n",
        100.0 * CONFIDENCE
    );
    out.push_str("| Req. | limit | samples | passed | pass probability | 95 % interval | 5 % | median | 95 % | 99 % | worst | most influential parameter (Spearman rho, first-order index) |\n");
    out.push_str("|---|---|---|---|---|---|---|---|---|---|---|---|\n");
    for (r, info) in data.requirements.iter().enumerate() {
        let outcomes = data.outcomes(r);
        let n = outcomes.len() as u64;
        let k = outcomes.iter().filter(|(_, o)| o.passed).count() as u64;
        let (lo, hi) = clopper_pearson(k, n, CONFIDENCE);
        let mut figures: Vec<f64> = outcomes.iter().map(|(_, o)| o.worst).collect();
        figures.sort_by(f64::total_cmp);
        let q = |p| figure_text(percentile(&figures, p), &info.unit);
        let top = sensitivity(data, r).first().map_or("-".to_string(), |i| {
            let first_order = i.first_order.map_or("-".to_string(), |s| format!("{s:.2}"));
            format!("`{}` ({}, {first_order})", data.parameter_names[i.parameter], correlation_text(i))
        });
        let _ = writeln!(
            out,
            "| {} | < {} {} | {n} | {k} | {} | {} - {} | {} | {} | {} | {} | {} | {top} |",
            info.label,
            info.limit,
            info.unit,
            percent(k as f64 / n.max(1) as f64),
            percent(lo),
            percent(hi),
            q(0.05),
            q(0.5),
            q(0.95),
            q(0.99),
            q(1.0),
        );
    }
    out.push('\n');
    out
}

fn scenario_table(data: &SweepData) -> String {
    let mut out = String::from("## Per scenario\n\n| scenario | Req. | runs | pass probability | 95 % interval | median | 95 % | worst |\n|---|---|---|---|---|---|---|---|\n");
    for s in &data.scenarios {
        let unit = data.requirements.iter().find(|r| r.label == s.requirement).map_or("", |r| r.unit.as_str());
        let mut sorted = s.figures.clone();
        sorted.sort_by(f64::total_cmp);
        let n = sorted.len() as u64;
        let (lo, hi) = clopper_pearson(s.passes, n, CONFIDENCE);
        let _ = writeln!(
            out,
            "| {} | {} | {n} | {} | {} - {} | {} | {} | {} |",
            s.name,
            s.requirement,
            percent(s.passes as f64 / n.max(1) as f64),
            percent(lo),
            percent(hi),
            figure_text(percentile(&sorted, 0.5), unit),
            figure_text(percentile(&sorted, 0.95), unit),
            figure_text(percentile(&sorted, 1.0), unit),
        );
    }
    out.push('\n');
    out
}

/// The samples with the worst figure of each requirement, and the command that reruns one alone
/// with its traces and pointing-error plots.
fn worst_samples(data: &SweepData, spec: &SweepSpec) -> String {
    let mut out = String::from("## Worst samples\n\nEach reruns alone, with every scenario's trace (for the fmpy master too) and the pointing-error plots, by the command beside it.\n\n| Req. | sample | figure | scenario | rerun |\n|---|---|---|---|---|\n");
    for (r, info) in data.requirements.iter().enumerate() {
        let mut outcomes = data.outcomes(r);
        outcomes.sort_by(|a, b| b.1.worst.total_cmp(&a.1.worst).then(a.0.sample.cmp(&b.0.sample)));
        for (sample, outcome) in outcomes.iter().take(3) {
            let _ = writeln!(
                out,
                "| {} | {} | {} {} | {} | `{PROGRAM} {} --only-sample {} --trace out/sweep-sample-{}` |",
                info.label,
                sample.sample,
                figure_text(outcome.worst, &info.unit),
                info.unit,
                outcome.worst_scenario,
                spec.command_line(),
                sample.sample,
                sample.sample
            );
        }
    }
    out.push('\n');
    out
}

/// A parameter's correlation as the tables print it: Spearman's rho signed, or for an angle over
/// the whole circle the circular-linear correlation with the direction of the largest figure.
fn correlation_text(influence: &Influence) -> String {
    match influence.worst_direction_deg {
        Some(direction) => format!("circular {:.2}, worst at {direction:.0} deg", influence.spearman),
        None => format!("{:+.2}", influence.spearman),
    }
}

fn sensitivity_section(data: &SweepData, figures: &[(usize, Vec<String>)]) -> String {
    let mut out = String::from("## Sensitivity\n\nSpearman's rho is the rank correlation between the parameter and the sample's worst figure (positive: a larger value gives a larger, worse figure; only |rho| above about 2/sqrt(samples) stands out of the noise). The first-order index is the share of the figure's variance the parameter explains alone, also where the figure rises and falls with it, as with a phase (binned estimate from the same sample, bias removed; shown with at least 50 samples and every run settled). Parameters are ranked by the larger of the first-order index and rho squared. An angle over the whole circle (the wind's direction) has no rank order: its correlation is the circular-linear one (Mardia's, 0 to 1, the multiple correlation of the figure with the angle's cosine and sine), given with the direction where the figure peaks.\n\n");
    for (r, info) in data.requirements.iter().enumerate() {
        let ranking = sensitivity(data, r);
        let _ = writeln!(out, "### {}\n", info.label);
        if let Some((_, paths)) = figures.iter().find(|(i, _)| *i == r) {
            for path in paths {
                let _ = writeln!(out, "![{}]({path})", info.label);
            }
            out.push('\n');
        }
        out.push_str("| rank | parameter | Spearman rho | first-order index |\n|---|---|---|---|\n");
        for (rank, influence) in ranking.iter().take(12).enumerate() {
            let _ = writeln!(
                out,
                "| {} | `{}` | {} | {} |",
                rank + 1,
                data.parameter_names[influence.parameter],
                correlation_text(influence),
                influence.first_order.map_or("-".to_string(), |s| format!("{s:.3}"))
            );
        }
        out.push('\n');
    }
    out
}

/// A file name part for a requirement label (`Req. 1` -> `req1`).
fn slug(label: &str) -> String {
    label.chars().filter(|c| c.is_ascii_alphanumeric()).collect::<String>().to_lowercase()
}

const PASS_COLOUR: Colour = Colour::rgb(0x1f, 0x77, 0xb4);
const FAIL_COLOUR: Colour = Colour::rgb(0xd6, 0x27, 0x28);
const LIMIT_COLOUR: Colour = Colour::rgb(0xa0, 0x00, 0x00);

/// Every requirement's figures (file names relative to the folder), by requirement index.
fn plot_figures(data: &SweepData, log_scaled: &[&str], folder: &Path) -> Result<Vec<(usize, Vec<String>)>, PlotError> {
    let mut all = Vec::new();
    for (r, info) in data.requirements.iter().enumerate() {
        let outcomes = data.outcomes(r);
        if outcomes.is_empty() {
            continue;
        }
        let slug = slug(&info.label);
        let figures: Vec<f64> = outcomes.iter().map(|(_, o)| o.worst).collect();
        let mut names = vec![format!("histogram-{slug}.png")];
        histogram(&info.label, &info.unit, info.limit, &figures).save_png(folder.join(&names[0]))?;
        let ranking = sensitivity(data, r);
        if !ranking.is_empty() {
            names.push(format!("tornado-{slug}.png"));
            tornado(&info.label, data, &ranking).save_png(folder.join(&names[1]))?;
            names.push(format!("scatter-{slug}.png"));
            let plot = ScatterPlot { label: &info.label, unit: &info.unit, limit: info.limit, log_scaled };
            plot.figure(data, r, &ranking).save_png(folder.join(&names[2]))?;
        }
        all.push((r, names));
    }
    Ok(all)
}

/// The histogram of the samples' worst figures with the limit; runs that never settled are
/// counted in the title.
fn histogram(label: &str, unit: &str, limit: f64, figures: &[f64]) -> Figure {
    let finite: Vec<f64> = figures.iter().copied().filter(|v| v.is_finite()).collect();
    let unsettled = figures.len() - finite.len();
    let low = finite.iter().copied().fold(f64::INFINITY, f64::min).min(limit);
    let high = finite.iter().copied().fold(f64::NEG_INFINITY, f64::max).max(limit);
    let bins = ((figures.len() as f64).sqrt().ceil() as usize).clamp(5, 60);
    let width = ((high - low) / bins as f64).max(f64::MIN_POSITIVE);
    let mut counts = vec![0.0; bins];
    for v in &finite {
        counts[(((v - low) / width) as usize).min(bins - 1)] += 1.0;
    }
    // One band in the shape of the bars: each bin's count held over its width.
    let mut x = Vec::with_capacity(2 * bins);
    let mut upper = Vec::with_capacity(2 * bins);
    for (b, &count) in counts.iter().enumerate() {
        x.extend([low + b as f64 * width, low + (b as f64 + 1.0) * width]);
        upper.extend([count, count]);
    }
    let panel = Panel::new(&format!(
        "{label}: the samples' worst figure ({} samples{})",
        figures.len(),
        if unsettled > 0 { format!(", {unsettled} never settled") } else { String::new() }
    ))
    .x_label(&format!("figure ({unit})"))
    .y_label("samples")
    .legend(LegendPosition::UpperRight)
    .band("samples per bin", &x, &vec![0.0; x.len()], &upper)
    .vertical_line_coloured(&format!("limit {limit} {unit}"), limit, LIMIT_COLOUR);
    Figure::new(1000, 560).panel(panel)
}

/// The tornado chart: one horizontal bar per parameter, its Spearman rho, in the ranking's order
/// (the most influential at the top).
fn tornado(label: &str, data: &SweepData, ranking: &[Influence]) -> Figure {
    let shown: Vec<&Influence> = ranking.iter().take(10).collect();
    let mut panel =
        Panel::new(&format!("{label}: the most influential parameters and their rank correlation with the figure"))
            .x_label("Spearman rho")
            .y_label("most influential at the top (legend)")
            // The axis runs on past rho = 1 to leave the legend a place beside the bars.
            .x_range(-1.0, 2.1)
            .y_range(0.0, shown.len() as f64 + 1.0)
            .legend(LegendPosition::UpperRight);
    for (i, influence) in shown.iter().enumerate() {
        let y = (shown.len() - i) as f64;
        let rho = influence.spearman;
        let x = [rho.min(0.0), rho.max(0.0)];
        let name =
            format!("{}. {} ({})", i + 1, data.parameter_names[influence.parameter], correlation_text(influence));
        panel = panel.band(&name, &x, &[y - 0.35, y - 0.35], &[y + 0.35, y + 0.35]);
    }
    Figure::new(1100, 620).panel(panel.vertical_line_coloured("", 0.0, Colour::rgb(0, 0, 0)))
}

/// The figure against each of the two most influential parameters, passes and failures apart.
struct ScatterPlot<'a> {
    label: &'a str,
    unit: &'a str,
    limit: f64,
    log_scaled: &'a [&'a str],
}

impl ScatterPlot<'_> {
    fn figure(&self, data: &SweepData, r: usize, ranking: &[Influence]) -> Figure {
        let (unit, limit) = (self.unit, self.limit);
        let outcomes = data.outcomes(r);
        let mut figure = Figure::new(1000, 900)
            .title(&format!("{}: the figure against the most influential parameters", self.label));
        for influence in ranking.iter().take(2) {
            let name = &data.parameter_names[influence.parameter];
            let mut panel = Panel::new(&format!("{name} ({})", correlation_text(influence)))
                .x_label(name)
                .y_label(&format!("figure ({unit})"));
            if self.log_scaled.contains(&name.as_str()) {
                panel = panel.log_x();
            }
            for (passed, colour, legend) in [(true, PASS_COLOUR, "pass"), (false, FAIL_COLOUR, "FAIL")] {
                let (x, y): (Vec<f64>, Vec<f64>) = outcomes
                    .iter()
                    .filter(|(_, o)| o.passed == passed && o.worst.is_finite())
                    .map(|(s, o)| (s.values[influence.parameter].unwrap_or(f64::NAN), o.worst))
                    .unzip();
                if !x.is_empty() {
                    panel = panel.series(Series::new(legend, &x, &y).markers_only().colour(colour));
                }
            }
            figure =
                figure.panel(panel.horizontal_line_coloured(&format!("limit {limit} {unit}"), limit, LIMIT_COLOUR));
        }
        figure
    }
}
