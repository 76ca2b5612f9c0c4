//! Scoring the validate tool against a generated suite's hidden truth: was the right effect
//! named, are its parameters within 10 % of the effect's size (a delay within one sample), how
//! much did the error drop, and how does detection depend on the effect's size.
//!
//! Only this module reads the `.truth` sidecars; the validation itself never sees them.

use crate::suite::{parse_truth, CaseTruth, SuiteError};
use crate::Effect;
use antenna_validate::measured_log::MeasuredLog;
use antenna_validate::output_error::PlantSimulator;
use antenna_validate::parameters::{names, ParameterError, ParameterSet};
use antenna_validate::plant_fmu::FmuSimulator;
use antenna_validate::{validate_with, ValidateOptions, Validation};
use rayon::prelude::*;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// Why a suite could not be scored or its figure drawn. A validation that fails on one log is
/// not one of these: it is recorded in that case's [`CaseResult::error`].
#[derive(Debug, thiserror::Error)]
pub enum ScoringError {
    /// A truth file or the suite folder could not be read.
    #[error("cannot read {}: {source}", path.display())]
    Read { path: PathBuf, source: std::io::Error },
    /// A truth file is malformed.
    #[error("{}: {source}", path.display())]
    Truth { path: PathBuf, source: SuiteError },
    /// The suite's starting parameter set could not be read.
    #[error(transparent)]
    StartParameters(#[from] ParameterError),
    /// The worker threads could not be started.
    #[error("cannot start {threads} threads: {source}")]
    Threads { threads: usize, source: rayon::ThreadPoolBuildError },
    /// A worker could not open its plant FMU.
    #[error(transparent)]
    Fmu(#[from] antenna_validate::plant_fmu::PlantFmuError),
    /// The detection figure could not be written.
    #[error("cannot write the detection figure {}: {source}", path.display())]
    Figure { path: PathBuf, source: antenna_plot::PlotError },
}

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
    /// Per true effect the validation did not name, how its report accounts for it: the data
    /// cannot tell it from a found effect, the log's sensors cannot observe it, or it is below
    /// the log's detection limit for its kind (family, explanation).
    pub accounted: Vec<(String, String)>,
    /// True effects not named and not accounted for: missed.
    pub missed: Vec<String>,
    /// Found effects that are neither in the truth nor a "cannot tell" stand-in for one: wrong.
    pub wrong: Vec<String>,
    /// Per found effect, the candidates the data could not tell from it (reported, never
    /// counted as named).
    pub equally_consistent: Vec<(String, Vec<String>)>,
    /// Output error (the windowed simulation of the plant FMU): the scored channel whose error
    /// dropped most, its RMS before and after (rad) and NRMSE fit before and after (%).
    pub output: Option<ErrorFigures>,
    /// Equation error: the channel where the error dropped most, RMS (axis N m) and fit.
    pub equation: Option<ErrorFigures>,
    /// Anti-resonance error: |measured trough - model trough| (Hz) before and after, where the
    /// log's excitation resolves the measured trough (the paper's check of the stiffness).
    pub anti_resonance: Option<ErrorFigures>,
    /// The measured trough itself (Hz), when resolved.
    pub measured_trough: Option<f64>,
    /// Complex error of the torque-to-motor-speed response over its coherent bins
    /// (`frequency::response_error`), before and after: sees a delay's phase and a
    /// stiffness's shape alike, where the excitation is broadband.
    pub response: Option<ErrorFigures>,
    /// The output error of all scored channels together: the root of the normalised score
    /// (each scored channel's mean squared error over the starting model's, averaged over the
    /// channels) of the corrected model; the starting model's is 1. An RMS ratio comparable
    /// with the most-improved channel's, which cannot flatter by picking a channel.
    pub score_ratio: Option<f64>,
    pub error: Option<String>,
    /// Wall-clock time of the validation (s).
    pub seconds: f64,
}

/// Error before and after in one channel.
#[derive(Debug, Clone)]
pub struct ErrorFigures {
    pub channel: String,
    pub unit: String,
    pub before: f64,
    pub after: f64,
    pub fit_before: f64,
    pub fit_after: f64,
}

impl ErrorFigures {
    pub fn ratio(&self) -> f64 {
        self.after / self.before
    }
}

impl CaseResult {
    /// Relabels the error figures of a linear axis's log, which `validate` computes in the same
    /// numbers as a rotary axis of unit radius: metres for radians, newtons for newton metres.
    fn in_linear_units(&mut self) {
        for figures in [&mut self.output, &mut self.equation].into_iter().flatten() {
            figures.unit = match figures.unit.as_str() {
                "rad" => "m".into(),
                "rad/s" => "m/s".into(),
                "N m" => "N".into(),
                other => other.into(),
            };
        }
    }

    /// The right effect, or an honest account of why it is not named ("the data cannot tell
    /// it from X", below the log's detection limit, not observable with its sensors), for
    /// every true effect, and nothing wrong claimed.
    pub fn honest(&self) -> bool {
        self.error.is_none() && self.missed.is_empty() && self.wrong.is_empty()
    }

    pub fn size(&self) -> f64 {
        self.truth.effects.iter().map(|e| e.1).fold(0.0, f64::max)
    }

    /// "Error after <= 20 % of before", on the output error (the criterion the issue's
    /// "error before and after" is read as).
    pub fn error_criterion(&self) -> bool {
        self.output.as_ref().is_some_and(|o| o.after <= 0.2 * o.before)
    }

    /// The same on the summed score of all scored channels (see `score_ratio`).
    pub fn score_criterion(&self) -> bool {
        self.score_ratio.is_some_and(|r| r <= 0.2)
    }

    /// The same on the complex frequency-response error.
    pub fn response_criterion(&self) -> bool {
        self.response.as_ref().is_some_and(|o| o.after <= 0.2 * o.before)
    }

    /// The same on the equation error, for comparison.
    pub fn equation_criterion(&self) -> bool {
        self.equation.as_ref().is_some_and(|o| o.after <= 0.2 * o.before)
    }
}

/// The true change of the parameter an effect sets, and the found change, from the corrected
/// parameter set.
fn compare(effect: &Effect, start: &ParameterSet, corrected: &ParameterSet) -> (f64, f64) {
    let change = |name: &str| corrected.value(name) - start.value(name);
    match *effect {
        Effect::Coulomb(d) => (d, change(names::COULOMB)),
        Effect::Stribeck(d) => (d, change(names::STATIC) - change(names::COULOMB)),
        Effect::Asymmetry(a) | Effect::TorqueOffset(a) => {
            (a, change(names::TORQUE_OFFSET) + change(names::ASYMMETRY) * start.value(names::COULOMB))
        }
        Effect::Backlash(b) => (b, change(names::BACKLASH_WIDTH)),
        Effect::StiffnessFactor(f) => (start.value(names::STIFFNESS) * (f - 1.0), change(names::STIFFNESS)),
        Effect::InertiaFactor(f) => (start.value(names::LOAD_INERTIA) * (f - 1.0), change(names::LOAD_INERTIA)),
        Effect::Unbalance { amplitude, .. } => (amplitude, corrected.value(names::UNBALANCE_TORQUE)),
        Effect::Delay(d) => (d, change(names::DELAY)),
        Effect::TorqueConstantScale(s) => (s - 1.0, change(names::TORQUE_CONSTANT_SCALE)),
        Effect::Cogging { amplitude, .. } => (amplitude, corrected.value(names::COGGING_AMPLITUDE)),
    }
}

/// Each found effect with the effects the report says the data cannot tell it from (the
/// search's equally consistent alternatives and the indistinct pairs), those with any.
fn equally_consistent(validation: &Validation) -> Vec<(String, Vec<String>)> {
    validation
        .selection
        .found
        .iter()
        .map(|f| {
            (
                f.kind.name().to_string(),
                validation
                    .selection
                    .equally_consistent(f.kind)
                    .iter()
                    .chain(validation.indistinct.iter().filter(|a| a.found == f.kind).map(|a| &a.alternative))
                    .map(|k| k.name().to_string())
                    .fold(Vec::new(), |mut names: Vec<String>, name| {
                        if !names.contains(&name) {
                            names.push(name);
                        }
                        names
                    }),
            )
        })
        .filter(|(_, alike)| !alike.is_empty())
        .collect()
}

/// Scores one validated case against its truth.
pub fn score(truth: &CaseTruth, validation: &Validation, start: &ParameterSet, seconds: f64) -> CaseResult {
    // A stand-in for the path's model form is reported, not claimed (`model_form_stand_ins`).
    let stand_ins = validation.model_form_stand_ins();
    let mut found: Vec<String> = validation
        .selection
        .found
        .iter()
        .filter(|f| !stand_ins.contains(&f.kind))
        .map(|f| f.kind.name().to_string())
        .collect();
    let equally_consistent = equally_consistent(validation);
    found.extend(sensor_claims(
        &truth.conditions,
        validation.encoder_skew,
        validation.current_skew.is_some(),
        validation.load_encoder_error.is_some(),
    ));
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
    let extras: Vec<String> = found.iter().filter(|g| !families.contains(&g.as_str())).cloned().collect();
    let (accounted, missed) = account_for_unnamed(truth, validation, &found, &equally_consistent, &parameters);
    let stands_in_for_truth = |g: &String| {
        equally_consistent.iter().any(|(f, alike)| f == g && alike.iter().any(|a| families.contains(&a.as_str())))
    };
    let wrong = extras.iter().filter(|g| !stands_in_for_truth(g)).cloned().collect();
    let c = validation.most_improved_channel();
    let equation = Some(ErrorFigures {
        channel: validation.before[c].name.clone(),
        unit: "N m".into(),
        before: validation.before[c].rms,
        after: validation.after[c].rms,
        fit_before: validation.before[c].fit_percent,
        fit_after: validation.after[c].fit_percent,
    });
    let output = validation.output.as_ref().and_then(|o| {
        let (i, before, after) = o.most_improved()?;
        Some(ErrorFigures {
            channel: o.before.channels[i].kind.name().to_string(),
            unit: o.before.channels[i].kind.unit().to_string(),
            before,
            after,
            fit_before: o.before.channels[i].fit_percent,
            fit_after: o.after.channels[i].fit_percent,
        })
    });
    let anti_resonance = validation.frequency.as_ref().and_then(|f| {
        let measured = f.measured_anti_resonance?;
        Some(ErrorFigures {
            channel: "anti-resonance".into(),
            unit: "Hz".into(),
            before: (measured - f.before_anti_resonance).abs(),
            after: (measured - f.after_anti_resonance).abs(),
            fit_before: f64::NAN,
            fit_after: f64::NAN,
        })
    });
    let measured_trough = validation.frequency.as_ref().and_then(|f| f.measured_anti_resonance);
    let response = validation.frequency.as_ref().and_then(|f| {
        Some(ErrorFigures {
            channel: "torque-to-motor-speed response".into(),
            unit: "-".into(),
            before: f.response_error_before?,
            after: f.response_error_after?,
            fit_before: f64::NAN,
            fit_after: f64::NAN,
        })
    });
    let score_ratio = validation.output.as_ref().map(|o| (o.overall.score_after / o.overall.score_before).sqrt());
    CaseResult {
        truth: truth.clone(),
        found,
        parameters,
        named,
        extras,
        accounted,
        missed,
        wrong,
        equally_consistent,
        output,
        equation,
        anti_resonance,
        measured_trough,
        response,
        score_ratio,
        error: None,
        seconds,
    }
}

/// The sensor errors the validation took out of the data that the truth's log does not have:
/// claims like any effect's. A load encoder read at another instant than the motor encoder, a
/// current read later than the encoders (the truth's `current_skew` is the current's sampling instant less
/// the encoders', negative for a current read late) and a load encoder error are each a
/// property of the data acquisition; finding one the log has is right, finding one it lacks is
/// a claim the suite counts as wrong (its own logs have none).
fn sensor_claims(
    conditions: &std::collections::BTreeMap<String, String>,
    encoder_skew: Option<f64>,
    current_late: bool,
    encoder_error: bool,
) -> Vec<String> {
    let condition = |key: &str| conditions.get(key).and_then(|v| v.parse::<f64>().ok()).unwrap_or(0.0);
    let mut claims = Vec::new();
    // The truth's load encoder skew is the instant the load encoder is read less the motor
    // encoder's (positive: read later, so its value leads); `validate`'s is how far its value
    // lags, the opposite sign.
    if encoder_skew.is_some_and(|skew| skew * condition("load_encoder_skew") >= 0.0) {
        claims.push("encoder_skew".to_string());
    }
    if current_late && condition("current_skew") >= 0.0 {
        claims.push("current_skew".to_string());
    }
    if encoder_error && condition("load_encoder_error_rms") <= 0.0 {
        claims.push("load_encoder_error".to_string());
    }
    claims
}

/// How the validation's report accounts for each true effect it did not name: a found effect
/// the data cannot tell it from, a candidate the log's signals cannot set up, or a true size
/// below the detection limit the report gives for its kind. The rest are missed.
fn account_for_unnamed(
    truth: &CaseTruth,
    validation: &Validation,
    found: &[String],
    equally_consistent: &[(String, Vec<String>)],
    parameters: &[(String, f64, f64, f64, bool)],
) -> (Vec<(String, String)>, Vec<String>) {
    let limits = validation.selection.detection_limits();
    let unobservable = validation.selection.unobservable();
    let (mut accounted, mut missed) = (Vec::new(), Vec::new());
    for ((_, _, effect), (_, true_change, ..)) in truth.effects.iter().zip(parameters) {
        let family = effect.family();
        if found.iter().any(|g| g == family) {
            continue;
        }
        let why = if let Some((stand_in, _)) =
            equally_consistent.iter().find(|(_, alike)| alike.iter().any(|a| a == family))
        {
            Some(format!("the data cannot tell it from {stand_in}"))
        } else if let Some(stand_in) = validation.model_form_stand_ins().iter().find(|k| k.name() == family) {
            Some(if validation.even_friction.is_some() && stand_in.name() == "stribeck" {
                "the data cannot tell it from a friction term even in the speed (stribeck found as its stand-in)"
                    .to_string()
            } else {
                format!(
                    "the data cannot tell it from the path's model form ({} found as a two-mass stand-in for a path with a second mode)",
                    stand_in.name()
                )
            })
        } else if let Some((_, reason)) = unobservable.iter().find(|(k, _)| k.name() == family) {
            Some(format!("not observable: {reason}"))
        } else {
            limits
                .iter()
                .find(|(k, _)| k.name() == family)
                .filter(|(_, limit)| true_change.abs() < limit.size)
                .map(|(_, limit)| format!("below the log's detection limit {:.3e} {}", limit.size, limit.unit))
        };
        match why {
            Some(why) => accounted.push((family.to_string(), why)),
            None => missed.push(family.to_string()),
        }
    }
    (accounted, missed)
}

/// Validates one log of a suite folder against its truth.
pub fn run_case(
    path: &Path,
    start: &ParameterSet,
    options: &ValidateOptions,
    simulator: Option<&mut dyn PlantSimulator>,
) -> Result<CaseResult, ScoringError> {
    let truth_path = path.with_extension("truth");
    let text = std::fs::read_to_string(&truth_path)
        .map_err(|source| ScoringError::Read { path: truth_path.clone(), source })?;
    let truth = parse_truth(&text).map_err(|source| ScoringError::Truth { path: truth_path.clone(), source })?;
    let clock = std::time::Instant::now();
    let mut linear = false;
    let result = MeasuredLog::read(path).map_err(|e| e.to_string()).and_then(|log| {
        linear = log.is_linear();
        validate_with(&log, start, options, simulator).map_err(|e| e.to_string())
    });
    let seconds = clock.elapsed().as_secs_f64();
    Ok(match result {
        Ok(validation) => {
            let mut scored = score(&truth, &validation, start, seconds);
            if linear {
                scored.in_linear_units();
            }
            scored
        }
        Err(message) => CaseResult {
            truth,
            found: Vec::new(),
            parameters: Vec::new(),
            named: false,
            extras: Vec::new(),
            accounted: Vec::new(),
            missed: Vec::new(),
            wrong: Vec::new(),
            equally_consistent: Vec::new(),
            output: None,
            equation: None,
            anti_resonance: None,
            measured_trough: None,
            response: None,
            score_ratio: None,
            error: Some(message),
            seconds,
        },
    })
}

/// Validates every `log_*.csv` in a suite folder against `start.params` and scores it, on
/// `threads` threads, each with its own plant FMU instance (none: equation error only).
pub fn run_suite(
    dir: &Path,
    options: &ValidateOptions,
    fmu: Option<&Path>,
    threads: usize,
    progress: &(dyn Fn(&CaseResult) + Sync),
) -> Result<Vec<CaseResult>, ScoringError> {
    let start = ParameterSet::read(&dir.join("start.params"))?;
    let mut logs: Vec<_> = std::fs::read_dir(dir)
        .map_err(|source| ScoringError::Read { path: dir.to_path_buf(), source })?
        .filter_map(|e| e.ok().map(|e| e.path()))
        // The suite's own logs only: the results a previous run wrote into the same folder
        // (detection.csv) are not logs.
        .filter(|p| {
            p.extension().is_some_and(|x| x == "csv")
                && p.file_name().is_some_and(|n| n.to_string_lossy().starts_with("log_"))
        })
        .collect();
    logs.sort();
    let bar = crate::progress_bar(logs.len(), "validating logs");
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads.max(1))
        .build()
        .map_err(|source| ScoringError::Threads { threads, source })?;
    // Each worker opens its own plant FMU instance; a case's result does not depend on which
    // worker ran it, and the results are collected in the sorted log order.
    let results: Vec<Result<CaseResult, ScoringError>> = pool.install(|| {
        logs.par_iter()
            .map_init(
                || fmu.map(FmuSimulator::open).transpose(),
                |simulator, path| {
                    let simulator = simulator.as_mut().map_err(|e| ScoringError::Fmu(e.clone()))?;
                    let result =
                        run_case(path, &start, options, simulator.as_mut().map(|s| s as &mut dyn PlantSimulator))?;
                    bar.suspend(|| progress(&result));
                    bar.inc(1);
                    Ok(result)
                },
            )
            .collect()
    });
    bar.finish_and_clear();
    results.into_iter().collect()
}

const ARCSEC_PER_RAD: f64 = 180.0 * 3600.0 / std::f64::consts::PI;

/// Error figures as text: RMS before -> after in display units (arcsec for angles, mm for a
/// linear axis's positions), ratio, fit before -> after.
fn figures_text(f: &Option<ErrorFigures>) -> (String, String, String, String) {
    match f {
        None => ("-".into(), "-".into(), "-".into(), "-".into()),
        Some(f) => {
            let (scale, unit) = if f.unit == "rad" {
                (ARCSEC_PER_RAD, "arcsec")
            } else if f.unit == "rad/s" {
                (ARCSEC_PER_RAD, "arcsec/s")
            } else if f.unit == "m" {
                (1e3, "mm")
            } else if f.unit == "m/s" {
                (1e3, "mm/s")
            } else {
                (1.0, f.unit.as_str())
            };
            (
                f.channel.clone(),
                format!("{:.3} -> {:.3} {unit}", f.before * scale, f.after * scale),
                format!("{:.2}", f.ratio()),
                format!("{:.1} -> {:.1}", f.fit_before, f.fit_after),
            )
        }
    }
}

/// One table row per case, sorted by effect and size.
pub fn table_markdown(results: &[CaseResult]) -> String {
    let mut rows: Vec<&CaseResult> = results.iter().collect();
    rows.sort_by(|a, b| {
        let key = |r: &CaseResult| r.truth.effects.iter().map(|e| e.0.clone()).collect::<Vec<_>>().join("+");
        key(a).cmp(&key(b)).then(a.size().total_cmp(&b.size())).then(a.truth.seed.cmp(&b.truth.seed))
    });
    let mut out = String::new();
    let _ = writeln!(
        out,
        "| log | effect (truth) | size / noise | found | parameter: true -> found (error) | output error: channel | RMS before -> after | after/before | fit before -> after (%) | equation error: channel | RMS before -> after | after/before |"
    );
    let _ = writeln!(out, "|---|---|---|---|---|---|---|---|---|---|---|---|");
    for r in rows {
        let effect = if r.truth.effects.is_empty() {
            "clean".to_string()
        } else {
            r.truth.effects.iter().map(|e| e.0.clone()).collect::<Vec<_>>().join(" + ")
        };
        let size = if r.truth.effects.is_empty() { "-".to_string() } else { format!("{}", r.size()) };
        let accounted: String = r.accounted.iter().map(|(family, why)| format!("; {family}: {why}")).collect();
        let found = if let Some(e) = &r.error {
            format!("error: {e}")
        } else if r.found.is_empty() {
            format!("none{accounted}")
        } else {
            let shown: Vec<String> = r
                .found
                .iter()
                .map(|f| match r.equally_consistent.iter().find(|(g, _)| g == f) {
                    Some((_, alike)) => format!("{f} (the data cannot tell it from {})", alike.join(", ")),
                    None => f.clone(),
                })
                .collect();
            format!("{}{accounted}", shown.join(", "))
        };
        let params: Vec<String> = r
            .parameters
            .iter()
            .map(|(family, t, f, e, ok)| {
                let error = if family == "delay" { format!("{e:.2} samples") } else { format!("{:.1} %", 100.0 * e) };
                format!("{family}: {t:.4e} -> {f:.4e} ({error}{})", if *ok { "" } else { ", out" })
            })
            .collect();
        let (oc, orms, oratio, ofit) = figures_text(&r.output);
        let (ec, erms, eratio, _) = figures_text(&r.equation);
        let _ = writeln!(
            out,
            "| {} | {effect} | {size} | {found} | {} | {oc} | {orms} | {oratio} | {ofit} | {ec} | {erms} | {eratio} |",
            r.truth.log_file,
            params.join("; ")
        );
    }
    out
}

/// One row of the detection curve: single-effect logs of one size.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CurvePoint {
    pub size: f64,
    pub cases: usize,
    pub named: usize,
    pub named_without_extra: usize,
    pub parameters_within_tolerance: usize,
    /// Output error after <= 20 % of before (the criterion), and the same on the equation
    /// error for comparison.
    pub error_criterion: usize,
    pub equation_criterion: usize,
    /// The right effect or an honest account of it, nothing wrong ([`CaseResult::honest`]).
    pub honest: usize,
}

/// Detection rate against size, single-effect logs.
pub fn detection_curve(results: &[CaseResult]) -> Vec<CurvePoint> {
    let mut sizes: Vec<f64> = results.iter().filter(|r| r.truth.effects.len() == 1).map(|r| r.size()).collect();
    sizes.sort_by(|a, b| a.total_cmp(b));
    sizes.dedup();
    sizes
        .into_iter()
        .map(|size| {
            let cases: Vec<&CaseResult> =
                results.iter().filter(|r| r.truth.effects.len() == 1 && r.size() == size).collect();
            CurvePoint {
                size,
                cases: cases.len(),
                named: cases.iter().filter(|r| r.named).count(),
                named_without_extra: cases.iter().filter(|r| r.named && r.extras.is_empty()).count(),
                parameters_within_tolerance: cases
                    .iter()
                    .filter(|r| r.named && r.parameters.iter().all(|p| p.4))
                    .count(),
                error_criterion: cases.iter().filter(|r| r.error_criterion()).count(),
                equation_criterion: cases.iter().filter(|r| r.equation_criterion()).count(),
                honest: cases.iter().filter(|r| r.honest()).count(),
            }
        })
        .collect()
}

/// Summary text: detection curve, per-effect results at >= 10x noise, the drive path in the
/// frequency domain, clean and two-effect logs.
pub fn summary_markdown(results: &[CaseResult]) -> String {
    let mut out = String::new();
    detection_summary(&mut out, results);
    by_effect_summary(&mut out, results);
    frequency_summary(&mut out, results);
    clean_and_pair_summary(&mut out, results);
    out
}

/// The detection curve as a table.
fn detection_summary(out: &mut String, results: &[CaseResult]) {
    let _ = writeln!(out, "Detection against effect size (single-effect logs). \"Error after <= 20 %\" is on the output error (windowed simulation of the plant FMU, the scored position channel where the error dropped most); the equation-error figure is given for comparison. \"An honest account\" of an effect not named is what the report says of it: a found effect the data cannot tell it from, a candidate the log's sensors cannot set up, or a true size below the detection limit the report gives for its kind; \"nothing wrong\" allows a found effect only where it is the truth's or a stand-in the report says the data cannot tell from it.\n");
    let _ = writeln!(out, "| size / noise | cases | right effect named | named, nothing extra | parameters within tolerance | output error after <= 20 % of before | equation error after <= 20 % of before | right effect or an honest account, nothing wrong |");
    let _ = writeln!(out, "|---|---|---|---|---|---|---|---|");
    for p in detection_curve(results) {
        let pct = |k: usize| 100.0 * k as f64 / p.cases.max(1) as f64;
        let _ = writeln!(
            out,
            "| {} | {} | {} ({:.0} %) | {} ({:.0} %) | {} ({:.0} %) | {} ({:.0} %) | {} ({:.0} %) | {} ({:.0} %) |",
            p.size,
            p.cases,
            p.named,
            pct(p.named),
            p.named_without_extra,
            pct(p.named_without_extra),
            p.parameters_within_tolerance,
            pct(p.parameters_within_tolerance),
            p.error_criterion,
            pct(p.error_criterion),
            p.equation_criterion,
            pct(p.equation_criterion),
            p.honest,
            pct(p.honest)
        );
    }
}

/// Per effect kind, single-effect logs at 10 times the noise and above.
fn by_effect_summary(out: &mut String, results: &[CaseResult]) {
    let _ = writeln!(out, "\nBy effect, single-effect logs at 10 times the noise and above (median after/before of each error over those logs):\n");
    let _ = writeln!(
        out,
        "| effect | cases | right effect named | nothing extra | parameters within tolerance | output error after <= 20 % (most-improved channel) | median after/before (most-improved channel) | output error after <= 20 % (all scored channels) | median after/before (all scored channels) | equation error after <= 20 % | median equation error after/before | right effect or an honest account, nothing wrong |"
    );
    let _ = writeln!(out, "|---|---|---|---|---|---|---|---|---|---|---|---|");
    let mut kinds: Vec<String> =
        results.iter().filter(|r| r.truth.effects.len() == 1).map(|r| r.truth.effects[0].0.clone()).collect();
    kinds.sort();
    kinds.dedup();
    let median = |mut v: Vec<f64>| -> f64 {
        v.retain(|x| x.is_finite());
        v.sort_by(|a, b| a.total_cmp(b));
        if v.is_empty() {
            f64::NAN
        } else {
            v[v.len() / 2]
        }
    };
    for kind in kinds {
        let cases: Vec<&CaseResult> = results
            .iter()
            .filter(|r| r.truth.effects.len() == 1 && r.truth.effects[0].0 == kind && r.size() >= 10.0)
            .collect();
        if cases.is_empty() {
            continue;
        }
        let count = |f: &dyn Fn(&CaseResult) -> bool| cases.iter().filter(|r| f(r)).count();
        let _ = writeln!(
            out,
            "| {kind} | {} | {} | {} | {} | {} | {:.2} | {} | {:.2} | {} | {:.2} | {} |",
            cases.len(),
            count(&|r| r.named),
            count(&|r| r.named && r.extras.is_empty()),
            count(&|r| r.named && r.parameters.iter().all(|p| p.4)),
            count(&|r| r.error_criterion()),
            median(cases.iter().filter_map(|r| r.output.as_ref().map(|o| o.ratio())).collect()),
            count(&|r| r.score_criterion()),
            median(cases.iter().filter_map(|r| r.score_ratio).collect()),
            count(&|r| r.equation_criterion()),
            median(cases.iter().filter_map(|r| r.equation.as_ref().map(|o| o.ratio())).collect()),
            count(&|r| r.honest()),
        );
    }
}

/// The anti-resonance and response errors of the drive-path effects.
fn frequency_summary(out: &mut String, results: &[CaseResult]) {
    let _ = writeln!(
        out,
        "\nThe drive path in the frequency domain, as the paper checks its stiffness: the anti-resonance error |measured trough - model trough| of the \
         torque-to-motor-speed response (H1, where the log's excitation resolves the trough), single-effect logs at 10 times the noise and above:\n"
    );
    let _ = writeln!(
        out,
        "| effect | cases resolved | measured trough (Hz) | error before (Hz) | error after (Hz) | after <= 20 % of before | cases with a response error | response error after/before | after <= 20 % of before |"
    );
    let _ = writeln!(out, "|---|---|---|---|---|---|---|---|---|");
    for kind in ["stiffness", "backlash", "delay"] {
        let cases: Vec<(&CaseResult, &ErrorFigures)> = results
            .iter()
            .filter(|r| r.truth.effects.len() == 1 && r.truth.effects[0].0 == kind && r.size() >= 10.0)
            .filter_map(|r| r.anti_resonance.as_ref().map(|a| (r, a)))
            .collect();
        let responses: Vec<f64> = results
            .iter()
            .filter(|r| r.truth.effects.len() == 1 && r.truth.effects[0].0 == kind && r.size() >= 10.0)
            .filter_map(|r| r.response.as_ref().map(|e| e.ratio()))
            .collect();
        if cases.is_empty() && responses.is_empty() {
            continue;
        }
        let range = |values: Vec<f64>, digits: usize| {
            if values.is_empty() {
                return "-".to_string();
            }
            let (low, high) = values.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| (a.min(v), b.max(v)));
            format!("{low:.digits$}-{high:.digits$}")
        };
        let troughs: Vec<f64> = cases.iter().filter_map(|(r, _)| r.measured_trough).collect();
        let _ = writeln!(
            out,
            "| {kind} | {} | {} | {} | {} | {} | {} | {} | {} |",
            cases.len(),
            range(troughs, 3),
            range(cases.iter().map(|(_, a)| a.before).collect(), 3),
            range(cases.iter().map(|(_, a)| a.after).collect(), 3),
            cases.iter().filter(|(_, a)| a.after <= 0.2 * a.before).count(),
            responses.len(),
            range(responses.clone(), 2),
            responses.iter().filter(|r| **r <= 0.2).count()
        );
    }
}

/// The response error's floor, claims on clean logs, two-effect logs, failures.
fn clean_and_pair_summary(out: &mut String, results: &[CaseResult]) {
    let clean: Vec<&CaseResult> = results.iter().filter(|r| r.truth.effects.is_empty()).collect();
    let clean_response: Vec<f64> = clean.iter().filter_map(|r| r.response.as_ref().map(|e| e.before)).collect();
    let delay_after: Vec<f64> = results
        .iter()
        .filter(|r| r.truth.effects.len() == 1 && r.truth.effects[0].0 == "delay" && r.size() >= 10.0)
        .filter_map(|r| r.response.as_ref().map(|e| e.after))
        .collect();
    if !clean_response.is_empty() {
        let span = |v: &[f64]| v.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &x| (a.min(x), b.max(x)));
        let (cl, ch) = span(&clean_response);
        let (dl, dh) = span(&delay_after);
        let _ = writeln!(
            out,
            "\nThe response error's own level: {cl:.3}-{ch:.3} on the clean logs with the starting model (the model-form and estimation floor), {} on the corrected delay logs above.",
            if delay_after.is_empty() { "-".to_string() } else { format!("{dl:.3}-{dh:.3}") }
        );
    }
    let claims: Vec<String> = clean
        .iter()
        .filter(|r| !r.found.is_empty())
        .map(|r| format!("{} ({})", r.truth.log_file, r.found.join(", ")))
        .collect();
    let _ = writeln!(
        out,
        "\nClean logs: {} of {} with an effect claimed{}.",
        claims.len(),
        clean.len(),
        if claims.is_empty() { String::new() } else { format!(": {}", claims.join("; ")) }
    );
    let pairs: Vec<&CaseResult> = results.iter().filter(|r| r.truth.effects.len() == 2).collect();
    if !pairs.is_empty() {
        let both = pairs.iter().filter(|r| r.named).count();
        let _ = writeln!(out, "Two-effect logs: both effects named in {} of {}.", both, pairs.len());
    }
    let errors = results.iter().filter(|r| r.error.is_some()).count();
    if errors > 0 {
        let _ = writeln!(out, "Logs that could not be validated: {errors}.");
    }
}

/// The detection curve as CSV.
pub fn detection_csv(results: &[CaseResult]) -> String {
    let mut out = String::from("size_over_noise,cases,named,named_without_extra,parameters_within_tolerance,output_error_after_le_20pct,equation_error_after_le_20pct\n");
    for p in detection_curve(results) {
        let _ = writeln!(
            out,
            "{},{},{},{},{},{},{}",
            p.size,
            p.cases,
            p.named,
            p.named_without_extra,
            p.parameters_within_tolerance,
            p.error_criterion,
            p.equation_criterion
        );
    }
    out
}

/// The detection curve as a PNG.
pub fn detection_figure(results: &[CaseResult], path: &Path) -> Result<(), ScoringError> {
    use antenna_plot::{Figure, Panel, Series};
    let curve = detection_curve(results);
    let x: Vec<f64> = curve.iter().map(|c| c.size).collect();
    let rate = |k: fn(&CurvePoint) -> usize| -> Vec<f64> {
        curve.iter().map(|c| 100.0 * k(c) as f64 / c.cases.max(1) as f64).collect()
    };
    // The first three rates are often equal: the widest line goes first and the narrower,
    // differently dashed ones on top, each with markers, so every line stays visible.
    Figure::new(1000, 600)
        .panel(
            Panel::new("Detection rate against effect size (generated suite, single-effect logs)")
                .x_label("effect size / sensor noise")
                .y_label("cases (%)")
                .log_x()
                // Headroom above 100 % for the legend, which would otherwise cover the top line.
                .y_range(0.0, 135.0)
                .series(Series::new("right effect named", &x, &rate(|c| c.named)).width(7).with_markers())
                .series(Series::new("named, nothing extra", &x, &rate(|c| c.named_without_extra)).width(3).dashed())
                .series(
                    Series::new("parameters within tolerance", &x, &rate(|c| c.parameters_within_tolerance))
                        .width(2)
                        .dotted()
                        .with_markers(),
                )
                .series(Series::new("output error after <= 20 % of before", &x, &rate(|c| c.error_criterion)).width(2))
                .series(
                    Series::new("equation error after <= 20 % of before", &x, &rate(|c| c.equation_criterion))
                        .width(2)
                        .dashed()
                        .with_markers(),
                ),
        )
        .save_png(path)
        .map_err(|source| ScoringError::Figure { path: path.to_path_buf(), source })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_sensor_error_is_a_claim_only_where_the_truth_lacks_it() {
        let none = std::collections::BTreeMap::new();
        assert!(sensor_claims(&none, None, false, false).is_empty());
        assert_eq!(
            sensor_claims(&none, Some(1e-3), true, true),
            vec!["encoder_skew", "current_skew", "load_encoder_error"]
        );
        let skewed: std::collections::BTreeMap<String, String> =
            [("load_encoder_skew".to_string(), "1e-3".to_string()), ("current_skew".to_string(), "-5e-4".to_string())]
                .into_iter()
                .collect();
        assert!(sensor_claims(&skewed, Some(-0.9e-3), true, false).is_empty());
        // A skew of the wrong sign is not the log's.
        assert_eq!(sensor_claims(&skewed, Some(0.9e-3), false, true), vec!["encoder_skew", "load_encoder_error"]);
        let early: std::collections::BTreeMap<String, String> =
            [("current_skew".to_string(), "5e-4".to_string())].into_iter().collect();
        assert_eq!(sensor_claims(&early, None, true, false), vec!["current_skew"]);
    }

    #[test]
    fn the_detection_figure_is_written_when_rates_coincide() {
        let truth = |size: f64| CaseTruth {
            log_file: "log_001.csv".into(),
            seed: 1,
            effects: vec![("coulomb".into(), size, Effect::Coulomb(1.0))],
            torque_sigma: 1.0,
            twist_sigma: 1.0,
            sample_interval: 0.002,
            conditions: Default::default(),
        };
        let results: Vec<CaseResult> = [1.0, 2.0, 5.0, 10.0, 20.0, 50.0]
            .iter()
            .map(|&size| CaseResult {
                truth: truth(size),
                found: vec!["coulomb".into()],
                parameters: vec![("coulomb".into(), 1.0, 1.0, 0.0, size >= 5.0)],
                named: size >= 2.0,
                extras: Vec::new(),
                accounted: Vec::new(),
                missed: Vec::new(),
                wrong: Vec::new(),
                equally_consistent: Vec::new(),
                output: None,
                equation: None,
                anti_resonance: None,
                measured_trough: None,
                response: None,
                score_ratio: None,
                error: None,
                seconds: 0.0,
            })
            .collect();
        let path = std::env::temp_dir().join(format!("detection-{}.png", std::process::id()));
        detection_figure(&results, &path).unwrap();
        assert!(std::fs::metadata(&path).unwrap().len() > 1000);
        if std::env::var_os("KEEP_FIGURE").is_none() {
            std::fs::remove_file(&path).unwrap();
        }
    }

    #[test]
    fn a_linear_axis_case_prints_its_errors_in_millimetres_and_newtons() {
        let figures = |unit: &str, before: f64| ErrorFigures {
            channel: "axis position".into(),
            unit: unit.into(),
            before,
            after: before / 10.0,
            fit_before: 90.0,
            fit_after: 99.0,
        };
        let mut case = CaseResult {
            truth: CaseTruth {
                log_file: "log_001.csv".into(),
                seed: 1,
                effects: Vec::new(),
                torque_sigma: 1.0,
                twist_sigma: 1.0,
                sample_interval: 0.002,
                conditions: Default::default(),
            },
            found: Vec::new(),
            parameters: Vec::new(),
            named: true,
            extras: Vec::new(),
            accounted: Vec::new(),
            missed: Vec::new(),
            wrong: Vec::new(),
            equally_consistent: Vec::new(),
            output: Some(figures("rad", 2e-3)),
            equation: Some(figures("N m", 30.0)),
            anti_resonance: None,
            measured_trough: None,
            response: None,
            score_ratio: None,
            error: None,
            seconds: 0.0,
        };
        assert!(figures_text(&case.output).1.ends_with("arcsec"), "a rotary axis stays in arcsec");
        case.in_linear_units();
        assert_eq!(figures_text(&case.output).1, "2.000 -> 0.200 mm");
        assert_eq!(figures_text(&case.equation).1, "30.000 -> 3.000 N");
    }

    #[test]
    fn a_suite_folder_validated_before_is_not_read_as_logs() {
        // A previous `validate suite DIR` leaves detection.csv beside the logs; it has no
        // .truth sidecar and must not be taken for a log.
        let dir = std::env::temp_dir().join(format!("suite-rerun-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        crate::TruthPlant::default().starting_parameters().write(&dir.join("start.params"), "test").unwrap();
        std::fs::write(dir.join("detection.csv"), "size,rate\n10,1\n").unwrap();
        let results = run_suite(&dir, &ValidateOptions::default(), None, 1, &|_| {});
        std::fs::remove_dir_all(&dir).unwrap();
        assert_eq!(results.map(|r| r.len()).map_err(|e| e.to_string()), Ok(0));
    }
}
