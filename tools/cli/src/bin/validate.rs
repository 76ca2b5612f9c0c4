//! validate: traces a measured log's residual to effects the model lacks.
//!
//! Usage:
//!   validate run LOG.csv --params START.params [--out DIR] [--fmu PATH | --no-fmu]
//!                [--window SECONDS] [--drive-window SECONDS] [--no-refit] [--no-presliding] [--alpha 1e-3] [--verbose]
//!       Validates one log: writes DIR/<log>_report.md, DIR/<log>_corrected.params (the plant
//!       FMU's parameter file, loadable through its `parameter_file` variable),
//!       DIR/<log>_corrected_axis.params (the single-axis set, usable as a start) and PNG
//!       figures, and prints the summary. Exit code 0 on success, 2 on an input error.
//!   validate suite --generate [--suite DIR] [--threads N] [--kuka DIR] [--fmu PATH | --no-fmu]
//!       Generates the test suite (truthgen) into DIR (default target/validation-suite),
//!       validates and scores every log, runs the three KUKA axes, and regenerates
//!       docs/validation-results.md, docs/validation-detection.csv, the figures under
//!       docs/figures/ and the summary tables in README.md.
//!   validate suite DIR [--out DIR2] [--threads N] [--fmu PATH | --no-fmu]
//!       Validates and scores an existing suite: writes DIR2 (default DIR)/results.md,
//!       detection.csv and detection.png.
//!   validate kuka [--kuka DIR] [--out DIR]
//!       Runs the three KUKA axes with tools/validate/data/kuka/axisN.params and writes their reports.
//!   validate holdout [--suite DIR] [--threads N] [--fmu PATH]
//!       Generates the holdout suites (truth::suite::holdout_suites: other sensors, or other log
//!       rates, noise, drives, and seeds than the main suite), validates and scores them, and writes
//!       docs/validation-holdout.md.
//!   validate floor [--seed N]
//!       The investigation of the error floors on clean logs (docs/validation.md): equation-
//!       and output-error residuals of the nominal model on clean truth logs with each sensor
//!       noise switched off in turn, and with softer LuGre bristles.
//!
//! The plant FMU defaults to target/fmu/AzimuthPlant.fmu (package it first with
//! `cargo run --release -p xtask --bin package`).

use antenna_validate::measured_log::MeasuredLog;
use antenna_truth::suite::{self, SuiteConfig};
use antenna_validate::output_error::PlantSimulator;
use antenna_validate::parameters::{fmu_parameter_text, ParameterSet};
use antenna_validate::plant_fmu::{FmuSimulator, PlantFmu};
use antenna_truth::scoring;
use antenna_validate::{self as validate, report, ValidateOptions, Validation};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;

fn main() {
    if let Err(message) = run(std::env::args().skip(1).collect()) {
        eprintln!("validate: {message}");
        std::process::exit(2);
    }
}

struct Arguments {
    command: String,
    target: Option<String>,
    params: Option<PathBuf>,
    out: Option<PathBuf>,
    suite: Option<PathBuf>,
    kuka: Option<PathBuf>,
    fmu: Option<PathBuf>,
    generate: bool,
    verbose: bool,
    threads: usize,
    options: ValidateOptions,
}

fn parse(args: Vec<String>) -> Result<Arguments, String> {
    let command = args.first().ok_or("expected a command: run, suite or kuka (see the source header)")?.clone();
    let mut a = Arguments {
        command,
        target: None,
        params: None,
        out: None,
        suite: None,
        kuka: None,
        fmu: Some(PlantFmu::default_path()),
        generate: false,
        verbose: false,
        threads: std::thread::available_parallelism().map(|n| n.get()).unwrap_or(1),
        options: ValidateOptions::default(),
    };
    let mut i = 1;
    while i < args.len() {
        let flag = args[i].as_str();
        let mut value = || -> Result<String, String> {
            i += 1;
            args.get(i).cloned().ok_or_else(|| format!("{flag} needs a value"))
        };
        match flag {
            "--params" => a.params = Some(PathBuf::from(value()?)),
            "--out" => a.out = Some(PathBuf::from(value()?)),
            "--suite" => a.suite = Some(PathBuf::from(value()?)),
            "--kuka" => a.kuka = Some(PathBuf::from(value()?)),
            "--fmu" => a.fmu = Some(PathBuf::from(value()?)),
            "--no-fmu" => a.fmu = None,
            "--generate" => a.generate = true,
            "--verbose" => a.verbose = true,
            "--threads" => a.threads = value()?.parse().map_err(|_| "--threads needs a count")?,
            "--alpha" => a.options.selection.alpha = value()?.parse().map_err(|_| "--alpha needs a number")?,
            "--min-effect-to-noise" => {
                a.options.selection.min_effect_to_noise =
                    value()?.parse().map_err(|_| "--min-effect-to-noise needs a number")?
            }
            "--window" => {
                a.options.output.window_seconds = Some(value()?.parse().map_err(|_| "--window needs seconds")?)
            }
            "--no-refit" => a.options.output.refit = false,
            "--no-presliding" => a.options.output.presliding = false,
            "--drive-window" => {
                a.options.output.drive_window_seconds =
                    Some(value()?.parse().map_err(|_| "--drive-window needs seconds")?)
            }
            other if !other.starts_with("--") && a.target.is_none() => a.target = Some(other.to_string()),
            other => return Err(format!("unknown option '{other}'")),
        }
        i += 1;
    }
    Ok(a)
}

fn run(args: Vec<String>) -> Result<(), String> {
    let a = parse(args)?;
    match a.command.as_str() {
        "run" => {
            let log_path = PathBuf::from(a.target.as_deref().ok_or("expected a log file")?);
            let params_path = a.params.clone().ok_or("--params is required")?;
            let (validation, _) = run_one(&log_path, &params_path, &a)?;
            if let Some(dir) = &a.out {
                write_outputs(&validation, &log_path, &params_path, dir, &stem_of(&log_path))?;
            }
            if a.verbose {
                println!("{}", report::markdown(&validation, &log_path.display().to_string()));
            } else {
                print_summary(&validation);
            }
        }
        "suite" => {
            let root = antenna_fmus::workspace_root();
            if a.generate {
                let dir = a.suite.clone().unwrap_or_else(|| root.join("target").join("validation-suite"));
                let clock = Instant::now();
                suite::write_suite_parallel(&dir, &SuiteConfig::default(), a.threads, &|line| println!("{line}"))?;
                let generation = clock.elapsed().as_secs_f64();
                let clock = Instant::now();
                let results = score_suite(&dir, &a)?;
                let scoring_time = clock.elapsed().as_secs_f64();
                let kuka_dir = a.kuka.clone().unwrap_or_else(|| {
                    root.parent().unwrap_or(&root).join("shared").join("data").join("kuka-robot-drive")
                });
                let docs = root.join("docs");
                let figures = docs.join("figures");
                std::fs::create_dir_all(&figures).map_err(|e| format!("cannot create {}: {e}", figures.display()))?;
                let clock = Instant::now();
                let kuka = if kuka_dir.is_dir() { Some(run_kuka(&kuka_dir, &figures, &a)?) } else { None };
                let kuka_time = clock.elapsed().as_secs_f64();
                let timing = format!(
                    "Generated {} logs in {generation:.0} s and validated them in {scoring_time:.0} s on {} threads; the KUKA axes took {kuka_time:.1} s.",
                    results.len(),
                    a.threads
                );
                let text = results_document(&results, kuka.as_deref(), &timing);
                std::fs::write(docs.join("validation-results.md"), text).map_err(|e| e.to_string())?;
                replace_readme_block(&root.join("README.md"), &scoring::summary_markdown(&results))?;
                std::fs::write(docs.join("validation-detection.csv"), scoring::detection_csv(&results))
                    .map_err(|e| e.to_string())?;
                scoring::detection_figure(&results, &figures.join("validation-detection.png"))?;
                println!("{}", scoring::summary_markdown(&results));
                println!("{timing}");
                println!("wrote {}", docs.join("validation-results.md").display());
            } else {
                let dir = PathBuf::from(a.target.as_deref().ok_or("expected a suite folder (or --generate)")?);
                let out = a.out.clone().unwrap_or_else(|| dir.clone());
                std::fs::create_dir_all(&out).map_err(|e| e.to_string())?;
                let results = score_suite(&dir, &a)?;
                let mut text = String::from("## Results on the generated suite\n\n");
                text.push_str(&scoring::summary_markdown(&results));
                text.push_str("\n### All cases\n\n");
                text.push_str(&scoring::table_markdown(&results));
                std::fs::write(out.join("results.md"), &text).map_err(|e| e.to_string())?;
                std::fs::write(out.join("detection.csv"), scoring::detection_csv(&results))
                    .map_err(|e| e.to_string())?;
                scoring::detection_figure(&results, &out.join("detection.png"))?;
                println!("{}", scoring::summary_markdown(&results));
                println!("wrote {}", out.join("results.md").display());
            }
        }
        "holdout" => {
            let root = antenna_fmus::workspace_root();
            let dir = a.suite.clone().unwrap_or_else(|| root.join("target").join("validation-holdout"));
            let mut text = String::from(HOLDOUT_HEADER);
            for (name, description, config) in suite::holdout_suites() {
                let sub = dir.join(name);
                let clock = Instant::now();
                suite::write_suite_parallel(&sub, &config, a.threads, &|line| println!("{name} {line}"))?;
                let generation = clock.elapsed().as_secs_f64();
                let clock = Instant::now();
                let results = score_suite(&sub, &a)?;
                let _ = write!(
                    text,
                    "## {name}: {description}\n\nSeeds {:?}, clean seeds {:?}; {} logs generated in {generation:.0} s and validated in {:.0} s on {} threads.\n\n{}\n### All cases\n\n{}\n",
                    config.seeds,
                    config.clean_seeds,
                    results.len(),
                    clock.elapsed().as_secs_f64(),
                    a.threads,
                    scoring::summary_markdown(&results),
                    scoring::table_markdown(&results)
                );
            }
            let path = root.join("docs").join("validation-holdout.md");
            std::fs::write(&path, text).map_err(|e| e.to_string())?;
            println!("wrote {}", path.display());
        }
        "kuka" => {
            let root = antenna_fmus::workspace_root();
            let kuka_dir = a
                .kuka
                .clone()
                .unwrap_or_else(|| root.parent().unwrap_or(&root).join("shared").join("data").join("kuka-robot-drive"));
            let out = a.out.clone().unwrap_or_else(|| PathBuf::from("."));
            std::fs::create_dir_all(&out).map_err(|e| e.to_string())?;
            let section = run_kuka(&kuka_dir, &out, &a)?;
            println!("{section}");
        }
        "floor" => {
            let seed = a
                .target
                .as_deref()
                .map(|s| s.parse::<u64>().map_err(|_| "floor takes a seed"))
                .transpose()?
                .unwrap_or(1);
            floor(seed, &a)?;
        }
        other => return Err(format!("unknown command '{other}'")),
    }
    Ok(())
}

/// The floor investigation: what limits the residuals of the right model on clean logs.
fn floor(seed: u64, a: &Arguments) -> Result<(), String> {
    use antenna_truth::{simulate, NoiseConfig, TruthConfig};
    let mut simulator = a.fmu.as_deref().map(FmuSimulator::open).transpose()?;
    println!("| truth variant (seed {seed}) | torque equation RMS (axis N m) | load equation RMS (N m) | output error: axis position (arcsec) | twist (arcsec) | load side driven by the motor encoder (arcsec) |");
    println!("|---|---|---|---|---|---|");
    let quiet = NoiseConfig {
        current_sigma: 0.0,
        current_step: 1e-9,
        load_encoder_counts: 2f64.powi(40),
        load_encoder_sigma: 0.0,
        motor_encoder_counts: 2f64.powi(36),
        ..NoiseConfig::default()
    };
    let current_only = NoiseConfig {
        current_sigma: NoiseConfig::default().current_sigma,
        current_step: NoiseConfig::default().current_step,
        ..quiet.clone()
    };
    let encoders_only = NoiseConfig { current_sigma: 0.0, current_step: 1e-9, ..NoiseConfig::default() };
    for (label, noise, presliding) in [
        ("as in the suite: sensor noise, LuGre with 1e-7 rad presliding", NoiseConfig::default(), 1e-7),
        ("no sensor noise", quiet.clone(), 1e-7),
        ("current noise only", current_only, 1e-7),
        ("encoder noise and quantisation only", encoders_only, 1e-7),
        ("sensor noise, softer bristles (1e-5 rad presliding)", NoiseConfig::default(), 1e-5),
        ("no sensor noise, softer bristles", quiet.clone(), 1e-5),
        ("no sensor noise, stiffer bristles (1e-8 rad)", quiet, 1e-8),
    ] {
        let mut config = TruthConfig { seed, ..TruthConfig::default() };
        config.plant.presliding_displacement = presliding;
        config.noise = noise;
        let start = config.plant.starting_parameters();
        let log = simulate(&config).log;
        let mut options = a.options.clone();
        options.selection.max_effects = 0;
        let v =
            validate::validate_with(&log, &start, &options, simulator.as_mut().map(|s| s as &mut dyn PlantSimulator))?;
        let arcsec = 180.0 * 3600.0 / std::f64::consts::PI;
        use validate::output_error::ChannelKind;
        let rms_of = |kind: ChannelKind| {
            v.output.as_ref().and_then(|o| o.before.channel(kind)).map_or(f64::NAN, |c| c.rms * arcsec)
        };
        let (position, twist, load_side) =
            (rms_of(ChannelKind::AxisPosition), rms_of(ChannelKind::Twist), rms_of(ChannelKind::LoadSide));
        println!(
            "| {label} | {:.1} | {:.2} | {position:.2} | {twist:.3} | {load_side:.3} |",
            v.before[0].rms,
            v.before.get(1).map_or(f64::NAN, |c| c.rms)
        );
    }
    Ok(())
}

const HOLDOUT_HEADER: &str = "# Holdout suites: logs unlike the generated suite\n\n\
Generated by `cargo run --release -p antenna-cli --bin validate -- holdout` (about 20 minutes on 2 threads). \
The same truth generator and the same `validate` (no option changed) on suites whose sensors (a motor speed \
signal instead of the motor encoder with two motors' currents; the load encoder alone), or log rate, sensor \
noise, drive resonance and inertia, and seeds differ from the main suite's (`docs/validation-results.md`), \
every effect kind at 10 and 20 times the noise: a check that the tool is not tuned to the suite it was developed on. \
The starting parameter set of each is its truth's nominal plant. Reading: docs/validation.md, \"Logs unlike the suite\".\n\n";

fn stem_of(path: &Path) -> String {
    path.file_stem().map(|s| s.to_string_lossy().to_string()).unwrap_or_else(|| "log".into())
}

/// Validates one log; returns the validation and the log.
fn run_one(log_path: &Path, params_path: &Path, a: &Arguments) -> Result<(Validation, MeasuredLog), String> {
    let log = MeasuredLog::read(log_path).map_err(|e| format!("{}: {e}", log_path.display()))?;
    let start = ParameterSet::read(params_path)?;
    let mut simulator = a.fmu.as_deref().map(FmuSimulator::open).transpose()?;
    let validation =
        validate::validate_with(&log, &start, &a.options, simulator.as_mut().map(|s| s as &mut dyn PlantSimulator))?;
    Ok((validation, log))
}

/// Writes the report, the corrected parameter sets and the figures of one validation.
fn write_outputs(
    validation: &Validation,
    log_path: &Path,
    params_path: &Path,
    dir: &Path,
    stem: &str,
) -> Result<Vec<String>, String> {
    std::fs::create_dir_all(dir).map_err(|e| format!("cannot create {}: {e}", dir.display()))?;
    let text = report::markdown(validation, &log_path.display().to_string());
    std::fs::write(dir.join(format!("{stem}_report.md")), &text).map_err(|e| e.to_string())?;
    let header = format!("Corrected by validate from {} on {}.", params_path.display(), log_path.display());
    validation.selection.corrected.write(
        &dir.join(format!("{stem}_corrected_axis.params")),
        &format!("{header}\nSingle-axis parameter set (validate's own form; usable as a starting set)."),
    )?;
    if let Some(o) = &validation.output {
        let fmu_text = fmu_parameter_text(
            &validation.selection.corrected,
            &o.config,
            &format!("{header}\nAzimuthPlant parameter file: load it through the FMU's parameter_file variable.\nMapping from the single-axis set: docs/validation.md, validate::parameters::FMU_MAPPING."),
        )?;
        std::fs::write(dir.join(format!("{stem}_corrected.params")), fmu_text).map_err(|e| e.to_string())?;
    }
    report::figures(validation, dir, stem)
}

fn score_suite(dir: &Path, a: &Arguments) -> Result<Vec<scoring::CaseResult>, String> {
    scoring::run_suite(dir, &a.options, a.fmu.as_deref(), a.threads, &|r| {
        let truth = suite::describe(&r.truth);
        let found =
            r.error.clone().unwrap_or_else(|| if r.found.is_empty() { "none".into() } else { r.found.join(", ") });
        let ratio = r.output.as_ref().map(|o| format!("{:.2}", o.ratio())).unwrap_or_else(|| "-".into());
        let summed = r.score_ratio.map(|x| format!("{x:.2}")).unwrap_or_else(|| "-".into());
        let response = r.response.as_ref().map(|o| format!("{:.2}", o.ratio())).unwrap_or_else(|| "-".into());
        println!(
            "{}: {truth} -> {found} (output error after/before {ratio} most-improved channel, {summed} all scored channels; response error {response}; {:.1} s)",
            r.truth.log_file, r.seconds
        );
    })
}

/// Runs the KUKA axes and returns the markdown section; figures go to `figures`.
fn run_kuka(data_dir: &Path, figures: &Path, a: &Arguments) -> Result<String, String> {
    let root = antenna_fmus::workspace_root();
    let mut rows = Vec::new();
    for axis in 1..=3 {
        let log_path = data_dir.join(format!("axis{axis}.csv"));
        let params_path = root.join("tools").join("data").join("kuka").join(format!("axis{axis}.params"));
        let clock = Instant::now();
        let (validation, _) = run_one(&log_path, &params_path, a)?;
        let seconds = clock.elapsed().as_secs_f64();
        let stem = format!("validation-kuka-axis{axis}");
        let written = report::figures(&validation, figures, &stem)?;
        rows.push((axis, validation, seconds, written));
    }
    Ok(report::kuka_section(&rows))
}

/// The README's copy of the suite summary lies between these lines; `suite --generate` rewrites
/// it, and a test checks it against docs/validation-results.md.
const README_BEGIN: &str = "<!-- validation-summary: generated by `validate suite --generate`, do not edit -->";
const README_END: &str = "<!-- end of validation-summary -->";

/// Puts `summary` between the README's markers.
fn replace_readme_block(readme: &Path, summary: &str) -> Result<(), String> {
    let text = std::fs::read_to_string(readme).map_err(|e| format!("cannot read {}: {e}", readme.display()))?;
    let (Some(begin), Some(end)) = (text.find(README_BEGIN), text.find(README_END)) else {
        return Err(format!("{} has no validation-summary markers", readme.display()));
    };
    let updated = format!("{}{README_BEGIN}\n{summary}{}", &text[..begin], &text[end..]);
    std::fs::write(readme, updated).map_err(|e| format!("cannot write {}: {e}", readme.display()))
}

/// The generated results document (docs/validation-results.md).
fn results_document(results: &[scoring::CaseResult], kuka: Option<&str>, timing: &str) -> String {
    let mut text = String::from(
        "# Validation results (generated)\n\nRegenerated by `cargo run --release -p antenna-cli --bin validate -- suite --generate` \
         (package the FMUs first). Method and reading: docs/validation.md.\n\n",
    );
    text.push_str(&format!("{timing}\n\n## Generated suite\n\n"));
    text.push_str(&scoring::summary_markdown(results));
    text.push_str("\n![Detection rate against effect size](figures/validation-detection.png)\n\nCurve data: `docs/validation-detection.csv`.\n\n");
    text.push_str("### All cases\n\nSize = RMS of what the effect adds to its channel over that channel's sensor noise. Output error: the scored position channel whose error dropped most, RMS over all windows in arcsec; equation error: the equation whose residual dropped most, axis-side N m.\n\n");
    text.push_str(&scoring::table_markdown(results));
    if let Some(section) = kuka {
        text.push_str("\n## KUKA robot drive (`shared/data/kuka-robot-drive/`)\n\n");
        text.push_str(section);
    }
    text
}

fn print_summary(v: &Validation) {
    if v.selection.found.is_empty() {
        println!("no significant missing effect");
    }
    for found in &v.selection.found {
        println!("found {} ({})", found.kind.name(), found.kind.description());
        for (name, value, sd, unit) in &found.parameters {
            println!("    {name} = {value:.6e} +- {sd:.2e} {unit}");
        }
        let alike = v.selection.equally_consistent(found.kind);
        if !alike.is_empty() {
            println!(
                "    the data cannot tell it from: {}",
                alike.iter().map(|k| k.name()).collect::<Vec<_>>().join(", ")
            );
        }
    }
    for (b, a) in v.before.iter().zip(&v.after) {
        println!(
            "{}: RMS {:.4} -> {:.4} N m (axis side), fit {:.1} -> {:.1} %, whiteness p {:.1e} -> {:.1e}",
            b.name, b.rms, a.rms, b.fit_percent, a.fit_percent, b.whiteness_p, a.whiteness_p
        );
    }
    if let Some(o) = &v.output {
        println!(
            "output error over {} windows of {:.3} s ({}); twist on pieces of {} samples:",
            o.plan.starts.len(),
            o.plan.seconds,
            o.plan.reason,
            o.plan.drive_length
        );
        for (b, a) in o.before.channels.iter().zip(&o.after.channels) {
            println!(
                "    {}: RMS {:.4e} -> {:.4e} {}, fit {:.1} -> {:.1} %",
                b.kind.name(),
                b.rms,
                a.rms,
                b.kind.unit(),
                b.fit_percent,
                a.fit_percent
            );
        }
        for (kind, c) in &o.confirmations {
            println!(
                "    confirmation of {}: {} -> {}",
                kind.name(),
                c.reason,
                if c.confirmed { "confirmed" } else { "rejected" }
            );
        }
    }
    if let Some(f) = &v.frequency {
        println!(
            "frequency response: anti-resonance measured {}, model {:.3} -> {:.3} Hz (broadband: {})",
            f.measured_anti_resonance.map(|m| format!("{m:.3} Hz")).unwrap_or_else(|| "not resolved".into()),
            f.before_anti_resonance,
            f.after_anti_resonance,
            f.broadband
        );
    }
    for h in &v.hints {
        println!(
            "not claimed, but the output error alone would confirm {} ({}): {} (equation-error p {:.2e} above its threshold {:.2e})",
            h.kind.name(),
            h.changes(&v.selection.corrected),
            h.comparison.reason,
            h.equation_p,
            h.threshold
        );
    }
    for note in &v.notes {
        println!("note: {note}");
    }
}
