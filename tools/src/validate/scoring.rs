//! Scoring the validate tool against a generated suite's hidden truth: was the right effect
//! named, are its parameters within 10 % of the effect's size (a delay within one sample), how
//! much did the error drop, and how does detection depend on the effect's size.
//!
//! Only this module reads the `.truth` sidecars; the validation itself never sees them.

use super::parameters::{names, ParameterSet};
use super::{validate, ValidateOptions, Validation};
use crate::measured_log::MeasuredLog;
use crate::truth::suite::{parse_truth, CaseTruth};
use crate::truth::Effect;
use std::fmt::Write as _;
use std::path::Path;

/// The outcome of one case.
#[derive(Debug, Clone)]
pub struct CaseResult {
    pub truth: CaseTruth,
    /// Names of the effects found, in the order found.
    pub found: Vec<String>,
    /// Per true effect: (family, true change, found change, relative error or error in samples
    /// for a delay, within tolerance).
    pub parameters: Vec<(String, f64, f64, f64, bool)>,
    /// Every true effect's family was named.
    pub named: bool,
    /// Effects found that are not in the truth.
    pub extras: Vec<String>,
    /// RMS residual before and after and NRMSE fit before and after, in the channel where the
    /// error dropped most, and that channel's name.
    pub channel: String,
    pub rms_before: f64,
    pub rms_after: f64,
    pub fit_before: f64,
    pub fit_after: f64,
    pub error: Option<String>,
}

impl CaseResult {
    pub fn size(&self) -> f64 {
        self.truth.effects.iter().map(|e| e.1).fold(0.0, f64::max)
    }
}

/// The true change of the parameter an effect sets, and the found change, from the corrected
/// parameter set.
fn compare(effect: &Effect, start: &ParameterSet, corrected: &ParameterSet) -> (f64, f64) {
    let change = |name: &str| corrected.value(name) - start.value(name);
    match *effect {
        Effect::Coulomb(d) => (d, change(names::COULOMB)),
        Effect::Stribeck(d) => (d, change(names::STATIC) - change(names::COULOMB)),
        Effect::Asymmetry(a) | Effect::TorqueOffset(a) => (a, change(names::TORQUE_OFFSET) + change(names::ASYMMETRY)),
        Effect::Backlash(b) => (b, change(names::BACKLASH_WIDTH)),
        Effect::StiffnessFactor(f) => (start.value(names::STIFFNESS) * (f - 1.0), change(names::STIFFNESS)),
        Effect::InertiaFactor(f) => (start.value(names::LOAD_INERTIA) * (f - 1.0), change(names::LOAD_INERTIA)),
        Effect::Unbalance { amplitude, .. } => (amplitude, corrected.value(names::UNBALANCE_TORQUE)),
        Effect::Delay(d) => (d, change(names::DELAY)),
        Effect::TorqueConstantScale(s) => (s - 1.0, change(names::TORQUE_CONSTANT_SCALE)),
        Effect::Cogging { amplitude, .. } => (amplitude, corrected.value(names::COGGING_AMPLITUDE)),
    }
}

/// Scores one validated case against its truth.
pub fn score(truth: &CaseTruth, validation: &Validation, start: &ParameterSet) -> CaseResult {
    let found: Vec<String> = validation.selection.found.iter().map(|f| f.kind.name().to_string()).collect();
    let mut parameters = Vec::new();
    for (_, _, effect) in &truth.effects {
        let (true_change, found_change) = compare(effect, start, &validation.selection.corrected);
        let (error, ok) = match effect {
            Effect::Delay(_) => {
                let samples = (found_change - true_change).abs() / truth.sample_interval;
                (samples, samples <= 1.0)
            }
            _ => {
                let relative = (found_change - true_change).abs() / true_change.abs().max(f64::MIN_POSITIVE);
                (relative, relative <= 0.1)
            }
        };
        parameters.push((effect.family().to_string(), true_change, found_change, error, ok));
    }
    let families: Vec<&str> = truth.effects.iter().map(|e| e.2.family()).collect();
    let named = families.iter().all(|f| found.iter().any(|g| g == f));
    let extras = found.iter().filter(|g| !families.contains(&g.as_str())).cloned().collect();
    let c = validation.most_improved_channel();
    CaseResult {
        truth: truth.clone(),
        found,
        parameters,
        named,
        extras,
        channel: validation.before[c].name.clone(),
        rms_before: validation.before[c].rms,
        rms_after: validation.after[c].rms,
        fit_before: validation.before[c].fit_percent,
        fit_after: validation.after[c].fit_percent,
        error: None,
    }
}

/// Validates every `log_*.csv` in a suite folder against `start.params` and scores it.
pub fn run_suite(dir: &Path, options: &ValidateOptions, progress: &mut dyn FnMut(&CaseResult)) -> Result<Vec<CaseResult>, String> {
    let start = ParameterSet::read(&dir.join("start.params"))?;
    let mut logs: Vec<_> = std::fs::read_dir(dir)
        .map_err(|e| format!("cannot read {}: {e}", dir.display()))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "csv"))
        .collect();
    logs.sort();
    let mut results = Vec::new();
    for path in logs {
        let truth_path = path.with_extension("truth");
        let text = std::fs::read_to_string(&truth_path).map_err(|e| format!("cannot read {}: {e}", truth_path.display()))?;
        let truth = parse_truth(&text)?;
        let result = match MeasuredLog::read(&path).map_err(|e| e.to_string()).and_then(|log| validate(&log, &start, options)) {
            Ok(validation) => score(&truth, &validation, &start),
            Err(message) => CaseResult {
                truth: truth.clone(),
                found: Vec::new(),
                parameters: Vec::new(),
                named: false,
                extras: Vec::new(),
                channel: String::new(),
                rms_before: f64::NAN,
                rms_after: f64::NAN,
                fit_before: f64::NAN,
                fit_after: f64::NAN,
                error: Some(message),
            },
        };
        progress(&result);
        results.push(result);
    }
    Ok(results)
}

/// One table row per case, sorted by effect and size.
pub fn table_markdown(results: &[CaseResult]) -> String {
    let mut rows: Vec<&CaseResult> = results.iter().collect();
    rows.sort_by(|a, b| {
        let key = |r: &CaseResult| r.truth.effects.iter().map(|e| e.0.clone()).collect::<Vec<_>>().join("+");
        key(a).cmp(&key(b)).then(a.size().total_cmp(&b.size())).then(a.truth.seed.cmp(&b.truth.seed))
    });
    let mut out = String::new();
    let _ = writeln!(out, "| log | effect (truth) | size / noise | found | parameter: true -> found (error) | channel | RMS before -> after (N m) | after/before | fit before -> after (%) |");
    let _ = writeln!(out, "|---|---|---|---|---|---|---|---|---|");
    for r in rows {
        let effect = if r.truth.effects.is_empty() { "clean".to_string() } else { r.truth.effects.iter().map(|e| e.0.clone()).collect::<Vec<_>>().join(" + ") };
        let size = if r.truth.effects.is_empty() { "-".to_string() } else { format!("{}", r.size()) };
        let found = if let Some(e) = &r.error { format!("error: {e}") } else if r.found.is_empty() { "none".to_string() } else { r.found.join(", ") };
        let params: Vec<String> = r
            .parameters
            .iter()
            .map(|(family, t, f, e, ok)| {
                let error = if family == "delay" { format!("{e:.2} samples") } else { format!("{:.1} %", 100.0 * e) };
                format!("{family}: {t:.4e} -> {f:.4e} ({error}{})", if *ok { "" } else { ", out" })
            })
            .collect();
        let _ = writeln!(
            out,
            "| {} | {effect} | {size} | {found} | {} | {} | {:.2} -> {:.2} | {:.2} | {:.1} -> {:.1} |",
            r.truth.log_file,
            params.join("; "),
            r.channel,
            r.rms_before,
            r.rms_after,
            r.rms_after / r.rms_before,
            r.fit_before,
            r.fit_after
        );
    }
    out
}

/// Detection rate against size: per size, (size, cases, named, named with no extra effect,
/// parameters within tolerance, error after <= 20 % of before).
pub fn detection_curve(results: &[CaseResult]) -> Vec<(f64, usize, usize, usize, usize, usize)> {
    let mut sizes: Vec<f64> = results.iter().filter(|r| r.truth.effects.len() == 1).map(|r| r.size()).collect();
    sizes.sort_by(|a, b| a.total_cmp(b));
    sizes.dedup();
    sizes
        .into_iter()
        .map(|size| {
            let cases: Vec<&CaseResult> = results.iter().filter(|r| r.truth.effects.len() == 1 && r.size() == size).collect();
            let named = cases.iter().filter(|r| r.named).count();
            let clean = cases.iter().filter(|r| r.named && r.extras.is_empty()).count();
            let params = cases.iter().filter(|r| r.named && r.parameters.iter().all(|p| p.4)).count();
            let error = cases.iter().filter(|r| r.rms_after <= 0.2 * r.rms_before).count();
            (size, cases.len(), named, clean, params, error)
        })
        .collect()
}

/// Summary text: detection curve, per-effect results at >= 10x noise, clean logs.
pub fn summary_markdown(results: &[CaseResult]) -> String {
    let mut out = String::new();
    let _ = writeln!(out, "Detection against effect size (single-effect logs):\n");
    let _ = writeln!(out, "| size / noise | cases | right effect named | named, nothing extra | parameters within tolerance | error after <= 20 % of before |");
    let _ = writeln!(out, "|---|---|---|---|---|---|");
    for (size, n, named, clean, params, error) in detection_curve(results) {
        let pct = |k: usize| 100.0 * k as f64 / n.max(1) as f64;
        let _ = writeln!(out, "| {size} | {n} | {named} ({:.0} %) | {clean} ({:.0} %) | {params} ({:.0} %) | {error} ({:.0} %) |", pct(named), pct(clean), pct(params), pct(error));
    }
    let clean: Vec<&CaseResult> = results.iter().filter(|r| r.truth.effects.is_empty()).collect();
    let claims = clean.iter().filter(|r| !r.found.is_empty()).count();
    let _ = writeln!(out, "\nClean logs: {} of {} with an effect claimed.", claims, clean.len());
    let pairs: Vec<&CaseResult> = results.iter().filter(|r| r.truth.effects.len() == 2).collect();
    if !pairs.is_empty() {
        let both = pairs.iter().filter(|r| r.named).count();
        let _ = writeln!(out, "Two-effect logs: both effects named in {} of {}.", both, pairs.len());
    }
    out
}

/// The detection curve as CSV.
pub fn detection_csv(results: &[CaseResult]) -> String {
    let mut out = String::from("size_over_noise,cases,named,named_without_extra,parameters_within_tolerance,error_after_le_20pct\n");
    for (size, n, named, clean, params, error) in detection_curve(results) {
        let _ = writeln!(out, "{size},{n},{named},{clean},{params},{error}");
    }
    out
}

/// The detection curve as a PNG.
pub fn detection_figure(results: &[CaseResult], path: &Path) -> Result<(), String> {
    use crate::plot::{Figure, Panel};
    let curve = detection_curve(results);
    let x: Vec<f64> = curve.iter().map(|c| c.0).collect();
    let rate = |k: fn(&(f64, usize, usize, usize, usize, usize)) -> usize| -> Vec<f64> { curve.iter().map(|c| 100.0 * k(c) as f64 / c.1.max(1) as f64).collect() };
    Figure::new(1000, 600)
        .panel(
            Panel::new("Detection rate against effect size (generated suite)")
                .x_label("effect size / sensor noise")
                .y_label("cases (%)")
                .log_x()
                .y_range(0.0, 105.0)
                .line("right effect named", &x, &rate(|c| c.2))
                .line("named, nothing extra", &x, &rate(|c| c.3))
                .line("parameters within tolerance", &x, &rate(|c| c.4))
                .line("error after <= 20 % of before", &x, &rate(|c| c.5)),
        )
        .save_png(path)
        .map_err(|e| e.to_string())
}
