//! validate: traces a measured log's residual to effects the model lacks.
//!
//! Subcommands (each has `--help`): `run` validates one log (the measured-log format of
//! docs/measured-log-format.md, or an fmpy result file of the plant FMU); `suite` generates
//! and scores the validation suite; `holdout` the holdout suites; `limits` checks the detection
//! limits by injection; `kuka` runs the three KUKA axes; `floor` investigates the error floors
//! on clean logs. Exit codes: 0 ok, 2 bad usage or
//! bad input (an unreadable or malformed log, a missing column, an invalid parameter, NaN in
//! the data or the results).
//!
//! The plant FMU defaults to target/fmu/AzimuthPlant.fmu (package it first with
//! `cargo xtask package`).

use antenna_truth::limits::{self, LimitsConfig};
use antenna_truth::scoring;
use antenna_truth::suite::{self, SuiteConfig};
use antenna_validate::candidates::Kind;
use antenna_validate::measured_log::MeasuredLog;
use antenna_validate::output_error::PlantSimulator;
use antenna_validate::parameters::{fmu_parameter_text, ParameterSet};
use antenna_validate::plant_fmu::{FmuSimulator, PlantFmu};
use antenna_validate::report::axis_unit;
use antenna_validate::{self as validate, documents, report, ValidateOptions, Validation};
use anyhow::{anyhow, bail, Context};
use clap::{Args, Parser, Subcommand};
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Instant;

/// Traces a measured drive log's residual to the effects the model lacks (friction, offsets,
/// compliance, backlash, delay ...), confirms them on the plant FMU's output error, and writes
/// the corrected parameter sets and a report.
#[derive(Parser)]
#[command(version, long_about = None)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Validate one log: prints the summary; with --out writes DIR/<log>_report.md,
    /// DIR/<log>_corrected.params (the plant FMU's parameter file, loadable through its
    /// `parameter_file` variable), DIR/<log>_corrected_axis.params (the single-axis set) and
    /// PNG figures.
    Run {
        /// The log: the measured-log format (docs/measured-log-format.md) or an fmpy result CSV
        /// of the AzimuthPlant/ElevationPlant FMU.
        log: PathBuf,
        /// The starting parameter set (`name = value  # unit, comment` lines).
        #[arg(long, value_name = "FILE")]
        params: PathBuf,
        /// Folder for the report, the corrected parameter sets and the figures.
        #[arg(long, value_name = "DIR")]
        out: Option<PathBuf>,
        /// Print the whole markdown report instead of the summary.
        #[arg(long)]
        verbose: bool,
        #[command(flatten)]
        fmu: FmuArgs,
        #[command(flatten)]
        tuning: TuningArgs,
    },
    /// Validate and score a generated suite: with --generate, generate it (truthgen) first,
    /// run the KUKA axes and write results/validation-results.md, results/validation-detection.csv
    /// and the figures under figures/ of --docs (`cargo xtask docs` gives docs/); with a suite
    /// folder, write results.md, detection.csv and detection.png into --out (default the folder).
    Suite {
        /// An existing suite folder (log_NNN.csv with .truth sidecars and start.params).
        #[arg(required_unless_present = "generate")]
        dir: Option<PathBuf>,
        /// Generate the suite first (into --suite, default target/validation-suite).
        #[arg(long, conflicts_with = "dir")]
        generate: bool,
        /// Where --generate writes the suite.
        #[arg(long, value_name = "DIR")]
        suite: Option<PathBuf>,
        /// Where the results of an existing suite go (default: the suite folder).
        #[arg(long, value_name = "DIR")]
        out: Option<PathBuf>,
        /// The KUKA data folder (default tests/data/measured/kuka-robot-drive in the repository).
        #[arg(long, value_name = "DIR")]
        kuka: Option<PathBuf>,
        /// With --generate: the documentation folder the results go into, as results/ and
        /// figures/ (default out/validation; `cargo xtask docs` passes the repository's docs/).
        #[arg(long, value_name = "DIR", requires = "generate")]
        docs: Option<PathBuf>,
        #[command(flatten)]
        threads: ThreadArgs,
        #[command(flatten)]
        fmu: FmuArgs,
        #[command(flatten)]
        tuning: TuningArgs,
    },
    /// Generate the holdout suites (other sensors, log rates, noise, drives and seeds than the
    /// main suite), validate and score them, and write each suite's section into its document
    /// under results/ of --docs: validation-holdout-variants.md for the sensor variants (coarse
    /// load encoder, current command, noiseless current, linear axis, short stroke),
    /// validation-holdout-hidden.md for what hidden logs had (load-encoder error, skews,
    /// drifting tacho, motor-pole cogging, three-mass drive, 2 kHz noiseless current),
    /// validation-holdout.md for the others.
    Holdout {
        /// Where the holdout suites are generated (default target/validation-holdout).
        #[arg(long, value_name = "DIR")]
        suite: Option<PathBuf>,
        /// The documentation folder the documents go into, as results/ (default out/validation;
        /// `cargo xtask docs` passes the repository's docs/).
        #[arg(long, value_name = "DIR")]
        docs: Option<PathBuf>,
        /// Only these holdout suites (comma-separated names): their sections are replaced in
        /// their documents, and every other section is kept.
        #[arg(long, value_delimiter = ',', value_name = "NAMES")]
        only: Vec<String>,
        #[command(flatten)]
        threads: ThreadArgs,
        #[command(flatten)]
        fmu: FmuArgs,
        #[command(flatten)]
        tuning: TuningArgs,
    },
    /// Run the three KUKA axes with tools/validate/data/kuka/axisN.params: prints the results
    /// section and writes it to DIR/report.md with the figures.
    Kuka {
        /// The KUKA data folder (default tests/data/measured/kuka-robot-drive in the repository).
        #[arg(long, value_name = "DIR")]
        kuka: Option<PathBuf>,
        /// Folder for report.md and the figures (default: the current folder).
        #[arg(long, value_name = "DIR")]
        out: Option<PathBuf>,
        #[command(flatten)]
        fmu: FmuArgs,
        #[command(flatten)]
        tuning: TuningArgs,
    },
    /// Check the detection limits by injection (issue 34): for each sensor variant, a clean log
    /// states the smallest change of each effect kind its search would claim; logs of the same
    /// excitation with other noise and the kind's effect at --factor times that limit must have
    /// it named (found, or listed as one the data cannot tell from a found effect) in at least
    /// 90 % of them. Logs of other excitations (other seeds) are counted beside, each with its
    /// own clean log's limit. Writes DIR/limits.md (the table) and DIR/limits.csv (one line per
    /// injection).
    Limits {
        /// Sensor variants: "suite" (the suite's own sensors) and holdout suites by name
        /// (`validate holdout --help`).
        #[arg(long, value_delimiter = ',', value_name = "NAMES", default_values_t = ["suite".to_string(), "noiseless-current".to_string()])]
        variants: Vec<String>,
        /// Effect kinds, as the truth generator names them.
        #[arg(long, value_delimiter = ',', value_name = "KINDS", default_values_t = LimitsConfig::default().kinds)]
        kinds: Vec<String>,
        /// Injected logs per variant and kind.
        #[arg(long, value_name = "N", default_value_t = 10)]
        injections: usize,
        /// The injected change over the stated limit.
        #[arg(long, value_name = "X", default_value_t = 1.5)]
        factor: f64,
        /// Seed of the clean log that states the limits.
        #[arg(long, default_value_t = 301)]
        clean_seed: u64,
        /// Inject only into the clean log's excitation (no logs of other seeds).
        #[arg(long)]
        same_excitation_only: bool,
        /// Folder for limits.md and limits.csv.
        #[arg(long, value_name = "DIR", default_value = ".")]
        out: PathBuf,
        /// The document's header line (`cargo xtask docs` passes the command and commit).
        #[arg(long, value_name = "TEXT")]
        header: Option<String>,
        #[command(flatten)]
        threads: ThreadArgs,
        #[command(flatten)]
        fmu: FmuArgs,
        #[command(flatten)]
        tuning: TuningArgs,
    },
    /// The investigation of the error floors on clean logs (docs/validation.md): equation- and
    /// output-error residuals of the nominal model on clean truth logs with each sensor noise
    /// switched off in turn, and with softer LuGre bristles.
    Floor {
        /// Seed of the truth runs.
        #[arg(default_value_t = 1)]
        seed: u64,
        #[command(flatten)]
        fmu: FmuArgs,
        #[command(flatten)]
        tuning: TuningArgs,
    },
}

/// The plant FMU for the output error.
#[derive(Args, Clone)]
struct FmuArgs {
    /// The plant FMU (default target/fmu/AzimuthPlant.fmu).
    #[arg(long, value_name = "PATH")]
    fmu: Option<PathBuf>,
    /// No output error: the equation error alone.
    #[arg(long, conflicts_with = "fmu")]
    no_fmu: bool,
}

impl FmuArgs {
    fn path(&self) -> Option<PathBuf> {
        (!self.no_fmu).then(|| self.fmu.clone().unwrap_or_else(PlantFmu::default_path))
    }
}

/// Worker threads of the suite runs.
#[derive(Args, Clone)]
struct ThreadArgs {
    /// Logs generated and validated in parallel (default: the machine's cores).
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u64).range(1..))]
    threads: Option<u64>,
}

impl ThreadArgs {
    fn count(&self) -> usize {
        self.threads
            .map(|n| n as usize)
            .unwrap_or_else(|| std::thread::available_parallelism().map(|n| n.get()).unwrap_or(1))
    }
}

/// The validation's settings a user may change.
#[derive(Args, Clone)]
struct TuningArgs {
    /// Family-wise significance level of the effect search, in (0, 0.5].
    #[arg(long, value_name = "P", value_parser = probability)]
    alpha: Option<f64>,
    /// Smallest effect, relative to the noise, that is claimed, in [0, 1000].
    #[arg(long, value_name = "RATIO", value_parser = effect_to_noise)]
    min_effect_to_noise: Option<f64>,
    /// Output-error window length, 0.01 to 600 s (default: from the motor speed's
    /// autocorrelation).
    #[arg(long, value_name = "SECONDS", value_parser = window_seconds)]
    window: Option<f64>,
    /// Length of the pieces the twist is simulated on, 0.01 to 600 s.
    #[arg(long, value_name = "SECONDS", value_parser = window_seconds)]
    drive_window: Option<f64>,
    /// Do not refit the parameters on the output error.
    #[arg(long)]
    no_refit: bool,
    /// Do not calibrate the presliding (bristle) compliance.
    #[arg(long)]
    no_presliding: bool,
    /// Do not re-estimate the effect families the starting set already holds.
    #[arg(long)]
    no_reestimate: bool,
}

/// A number within `[low, high]` (`low` itself excluded when `open_low`), or the reason it is
/// refused, which clap prints naming the option (exit 2).
fn number_within(text: &str, low: f64, high: f64, open_low: bool) -> Result<f64, String> {
    let value: f64 = text.trim().parse().map_err(|_| format!("`{text}` is not a number"))?;
    let above_low = if open_low { value > low } else { value >= low };
    if value.is_finite() && above_low && value <= high {
        Ok(value)
    } else {
        let bracket = if open_low { "(" } else { "[" };
        Err(format!("{} is outside {bracket}{low}, {high}]", text.trim()))
    }
}

fn probability(text: &str) -> Result<f64, String> {
    number_within(text, 0.0, 0.5, true)
}

fn effect_to_noise(text: &str) -> Result<f64, String> {
    number_within(text, 0.0, 1000.0, false)
}

fn window_seconds(text: &str) -> Result<f64, String> {
    number_within(text, 0.01, 600.0, false)
}

impl TuningArgs {
    fn options(&self) -> ValidateOptions {
        let mut options = ValidateOptions::default();
        if let Some(alpha) = self.alpha {
            options.selection.alpha = alpha;
        }
        if let Some(ratio) = self.min_effect_to_noise {
            options.selection.min_effect_to_noise = ratio;
        }
        if self.window.is_some() {
            options.output.window_seconds = self.window;
        }
        if self.drive_window.is_some() {
            options.output.drive_window_seconds = self.drive_window;
        }
        if self.no_refit {
            options.output.refit = false;
        }
        if self.no_presliding {
            options.output.presliding = false;
        }
        if self.no_reestimate {
            options.output.reestimate = false;
        }
        options
    }
}

/// What a validation run needs besides its input files.
struct Settings {
    fmu: Option<PathBuf>,
    options: ValidateOptions,
    threads: usize,
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    match run(cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(error) => {
            eprintln!("validate: error: {error:#}");
            // Every failure here is bad input: a file that cannot be read or is malformed, an
            // invalid parameter, a missing FMU, NaN in the data or the results.
            ExitCode::from(2)
        }
    }
}

/// The library's text errors as anyhow errors.
fn text<T>(result: Result<T, String>) -> anyhow::Result<T> {
    result.map_err(|message| anyhow!(message))
}

fn run(cli: Cli) -> anyhow::Result<()> {
    let root = antenna_fmus::workspace_root();
    let default_kuka = || root.join("tests").join("data").join("measured").join("kuka-robot-drive");
    match cli.command {
        Command::Run { log, params, out, verbose, fmu, tuning } => {
            let settings = Settings { fmu: fmu.path(), options: tuning.options(), threads: 1 };
            run_log(&log, &params, out.as_deref(), verbose, &settings)
        }
        Command::Suite { dir, generate, suite, out, kuka, docs, threads, fmu, tuning } => {
            let settings = Settings { fmu: fmu.path(), options: tuning.options(), threads: threads.count() };
            if generate {
                let dir = suite.unwrap_or_else(|| root.join("target").join("validation-suite"));
                let docs = docs.unwrap_or_else(|| root.join("out").join("validation"));
                generate_suite(&docs, &dir, &kuka.unwrap_or_else(default_kuka), &settings)
            } else {
                let dir = dir.context("expected a suite folder (or --generate)")?;
                score_existing_suite(&dir, &out.unwrap_or_else(|| dir.clone()), &settings)
            }
        }
        Command::Holdout { suite, docs, only, threads, fmu, tuning } => {
            let settings = Settings { fmu: fmu.path(), options: tuning.options(), threads: threads.count() };
            let docs = docs.unwrap_or_else(|| root.join("out").join("validation"));
            holdout(&docs, &suite.unwrap_or_else(|| root.join("target").join("validation-holdout")), &only, &settings)
        }
        Command::Kuka { kuka, out, fmu, tuning } => {
            let settings = Settings { fmu: fmu.path(), options: tuning.options(), threads: 1 };
            let out = out.unwrap_or_else(|| PathBuf::from("."));
            std::fs::create_dir_all(&out).with_context(|| format!("cannot create {}", out.display()))?;
            let section = run_kuka(&kuka.unwrap_or_else(default_kuka), &out, &settings)?;
            let report = out.join("report.md");
            std::fs::write(&report, &section).with_context(|| format!("cannot write {}", report.display()))?;
            println!("{section}");
            Ok(())
        }
        Command::Limits {
            variants,
            kinds,
            injections,
            factor,
            clean_seed,
            same_excitation_only,
            out,
            header,
            threads,
            fmu,
            tuning,
        } => {
            let settings = Settings { fmu: fmu.path(), options: tuning.options(), threads: threads.count() };
            let config = LimitsConfig {
                variants,
                kinds,
                injections,
                factor,
                clean_seed,
                first_seed: clean_seed + 10,
                other_excitations: !same_excitation_only,
                ..LimitsConfig::default()
            };
            injection_check(&config, &out, header.as_deref(), &settings)
        }
        Command::Floor { seed, fmu, tuning } => {
            floor(seed, &Settings { fmu: fmu.path(), options: tuning.options(), threads: 1 })
        }
    }
}

/// `validate run`: one log.
fn run_log(
    log_path: &Path,
    params_path: &Path,
    out: Option<&Path>,
    verbose: bool,
    settings: &Settings,
) -> anyhow::Result<()> {
    let validation = run_one(log_path, params_path, settings)?;
    check_finite(&validation)?;
    if let Some(dir) = out {
        write_outputs(&validation, log_path, params_path, dir, &stem_of(log_path))?;
    }
    if verbose {
        println!("{}", report::markdown(&validation, &log_path.display().to_string()));
    } else {
        print_summary(&validation);
    }
    Ok(())
}

/// NaN in the results is an error with its cause, never "no significant missing effect".
fn check_finite(v: &Validation) -> anyhow::Result<()> {
    for (b, a) in v.before.iter().zip(&v.after) {
        if !(b.rms.is_finite() && a.rms.is_finite()) {
            bail!(
                "the {} residual is not finite (RMS {} before, {} after): the log or the parameter set gives the model no usable numbers",
                b.name,
                b.rms,
                a.rms
            );
        }
    }
    Ok(())
}

/// `validate suite --generate`: the suite, its scores, the KUKA axes and the documents, under
/// the documentation folder `docs`.
fn generate_suite(docs: &Path, dir: &Path, kuka_dir: &Path, settings: &Settings) -> anyhow::Result<()> {
    let clock = Instant::now();
    suite::write_suite_parallel(dir, &SuiteConfig::default(), settings.threads, &|line| println!("{line}"))?;
    let generation = clock.elapsed().as_secs_f64();
    let clock = Instant::now();
    let results = score_suite(dir, settings)?;
    let scoring_time = clock.elapsed().as_secs_f64();
    let figures = docs.join("figures");
    std::fs::create_dir_all(&figures).with_context(|| format!("cannot create {}", figures.display()))?;
    let results_folder = docs.join("results");
    std::fs::create_dir_all(&results_folder).with_context(|| format!("cannot create {}", results_folder.display()))?;
    let clock = Instant::now();
    let kuka = if kuka_dir.is_dir() { Some(run_kuka(kuka_dir, &figures, settings)?) } else { None };
    let kuka_time = clock.elapsed().as_secs_f64();
    let timing = format!(
        "Generated {} logs in {generation:.0} s and validated them in {scoring_time:.0} s on {} threads; the KUKA axes took {kuka_time:.1} s.",
        results.len(),
        settings.threads
    );
    let results_path = docs.join("results").join("validation-results.md");
    std::fs::write(&results_path, results_document(&results, kuka.as_deref(), &timing))
        .with_context(|| format!("cannot write {}", results_path.display()))?;
    let csv_path = docs.join("results").join("validation-detection.csv");
    std::fs::write(&csv_path, scoring::detection_csv(&results))
        .with_context(|| format!("cannot write {}", csv_path.display()))?;
    scoring::detection_figure(&results, &figures.join("validation-detection.png"))?;
    println!("{}", scoring::summary_markdown(&results));
    println!("{timing}");
    println!("wrote {}", results_path.display());
    Ok(())
}

/// `validate suite DIR`: scores an existing suite.
fn score_existing_suite(dir: &Path, out: &Path, settings: &Settings) -> anyhow::Result<()> {
    std::fs::create_dir_all(out).with_context(|| format!("cannot create {}", out.display()))?;
    let results = score_suite(dir, settings)?;
    let mut document = String::from("## Results on the generated suite\n\n");
    document.push_str(&scoring::summary_markdown(&results));
    document.push_str("\n### All cases\n\n");
    document.push_str(&scoring::table_markdown(&results));
    std::fs::write(out.join("results.md"), &document)
        .with_context(|| format!("cannot write into {}", out.display()))?;
    std::fs::write(out.join("detection.csv"), scoring::detection_csv(&results))
        .with_context(|| format!("cannot write into {}", out.display()))?;
    scoring::detection_figure(&results, &out.join("detection.png"))?;
    println!("{}", scoring::summary_markdown(&results));
    println!("wrote {}", out.join("results.md").display());
    Ok(())
}

/// The holdout suites that are sensor variants of the main suite's drive (issue 16): their
/// sections live in docs/results/validation-holdout-variants.md, the other suites' in
/// docs/results/validation-holdout.md.
const SENSOR_VARIANT_SUITES: [&str; 5] =
    ["coarse-load-encoder", "current-command", "noiseless-current", "linear-axis", "short-stroke"];

/// The holdout suites with what hidden logs of another generator had (issue 34): a load
/// encoder's error, skews, a drifting tacho, motor-pole cogging, a three-mass drive, 2 kHz logs
/// with a noiseless current; their sections live in docs/results/validation-holdout-hidden.md.
const HIDDEN_LOG_SUITES: [&str; 6] =
    ["load-encoder-error", "skews", "drifting-tacho", "motor-pole-cogging", "three-mass", "2khz-noiseless-current"];

/// The document, under docs/, that holds a holdout suite's section.
fn holdout_document(suite: &str) -> &'static str {
    if HIDDEN_LOG_SUITES.contains(&suite) {
        "validation-holdout-hidden.md"
    } else if SENSOR_VARIANT_SUITES.contains(&suite) {
        "validation-holdout-variants.md"
    } else {
        "validation-holdout.md"
    }
}

/// `validate holdout`: the holdout suites and their documents, under results/ of the
/// documentation folder `docs`.
fn holdout(docs: &Path, dir: &Path, only: &[String], settings: &Settings) -> anyhow::Result<()> {
    let known: Vec<&str> = suite::holdout_suites().iter().map(|s| s.0).collect();
    if let Some(unknown) = only.iter().find(|name| !known.contains(&name.as_str())) {
        bail!("no holdout suite '{unknown}' (known: {})", known.join(", "));
    }
    for (name, description, config) in suite::holdout_suites() {
        if !only.is_empty() && !only.iter().any(|o| o == name) {
            continue;
        }
        let sub = dir.join(name);
        let clock = Instant::now();
        suite::write_suite_parallel(&sub, &config, settings.threads, &|line| println!("{name} {line}"))?;
        let generation = clock.elapsed().as_secs_f64();
        let clock = Instant::now();
        let results = score_suite(&sub, settings)?;
        let section = format!(
            "## {name}: {description}\n\nRun on {}; seeds {:?}, clean seeds {:?}; {} logs generated in {generation:.0} s and validated in {:.0} s on {} threads.\n\n{}\n### All cases\n\n{}\n",
            utc_now(),
            config.seeds,
            config.clean_seeds,
            results.len(),
            clock.elapsed().as_secs_f64(),
            settings.threads,
            scoring::summary_markdown(&results),
            scoring::table_markdown(&results)
        );
        // Merged after every suite: this suite's section is replaced and every other one kept,
        // so that neither an --only run nor an interrupted full run loses the suites it did
        // not run. Each document lists and orders the suites it holds.
        let file = holdout_document(name);
        let folder = docs.join("results");
        std::fs::create_dir_all(&folder).with_context(|| format!("cannot create {}", folder.display()))?;
        let path = folder.join(file);
        let order: Vec<&str> = known.iter().copied().filter(|suite| holdout_document(suite) == file).collect();
        let existing = match std::fs::read_to_string(&path) {
            Ok(text) => text,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => String::new(),
            Err(e) => return Err(e).with_context(|| format!("cannot read {}", path.display())),
        };
        let merged = documents::merge_sections(&existing, HOLDOUT_HEADER, &[(name.to_string(), section)], &order);
        std::fs::write(&path, merged).with_context(|| format!("cannot write {}", path.display()))?;
        println!("wrote {} ({name} replaced, the other sections kept)", path.display());
    }
    Ok(())
}

/// `validate limits`: the detection limits checked by injection, into DIR/limits.md and
/// DIR/limits.csv.
fn injection_check(config: &LimitsConfig, out: &Path, header: Option<&str>, settings: &Settings) -> anyhow::Result<()> {
    let clock = Instant::now();
    let rows =
        limits::run(config, &settings.options, settings.fmu.as_deref(), settings.threads, &|line| println!("{line}"))?;
    let route =
        if settings.fmu.is_some() { "equation error and output error" } else { "equation error only (--no-fmu)" };
    let mut document = String::from("# Detection limits checked by injection (generated)\n\n");
    if let Some(header) = header {
        document.push_str(&format!("{header}\n\n"));
    }
    document.push_str(&format!(
        "Run on {}: variants {}, kinds {}, {} injections each at {} times the stated limit, limits stated by the clean log of seed {} (noise seed {}). The verdict's logs share that log's excitation (seed {}: trajectory and injected torque) with other sensor noise (noise seeds {} to {}); {}; {route}; {:.0} s on {} threads. Named = the kind is found, or the report lists it as one the data cannot tell from a found effect (counted in brackets). Method: docs/validation.md, \"Detection limits\".\n\n",
        utc_now(),
        config.variants.join(", "),
        config.kinds.join(", "),
        config.injections,
        config.factor,
        config.clean_seed,
        config.clean_seed,
        config.clean_seed,
        config.first_seed,
        config.first_seed + config.injections.saturating_sub(1) as u64,
        if config.other_excitations {
            format!(
                "the last column injects the same change into logs of other excitations (seeds {} to {}) and counts the misses where that log's own clean log states a limit at or above it",
                config.first_seed,
                config.first_seed + config.injections.saturating_sub(1) as u64
            )
        } else {
            "no logs of other excitations".to_string()
        },
        clock.elapsed().as_secs_f64(),
        settings.threads
    ));
    document.push_str(&limits::markdown(&rows, config));
    std::fs::create_dir_all(out).with_context(|| format!("cannot create {}", out.display()))?;
    let md = out.join("limits.md");
    std::fs::write(&md, &document).with_context(|| format!("cannot write {}", md.display()))?;
    let csv = out.join("limits.csv");
    std::fs::write(&csv, limits::csv(&rows)).with_context(|| format!("cannot write {}", csv.display()))?;
    println!("{}", limits::markdown(&rows, config));
    println!("wrote {} and {}", md.display(), csv.display());
    Ok(())
}

/// The floor investigation: what limits the residuals of the right model on clean logs.
fn floor(seed: u64, settings: &Settings) -> anyhow::Result<()> {
    use antenna_truth::{simulate, NoiseConfig, TruthConfig};
    let mut simulator = settings.fmu.as_deref().map(FmuSimulator::open).transpose()?;
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
        let mut options = settings.options.clone();
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

/// The current UTC date and time (minutes), for the line that says when a section was run.
fn utc_now() -> String {
    let seconds = std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map_or(0, |d| d.as_secs());
    let (days, rest) = ((seconds / 86_400) as i64, seconds % 86_400);
    // Days since 1970-01-01 to a civil date (Howard Hinnant's algorithm).
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let day = doy - (153 * mp + 2) / 5 + 1;
    let month = if mp < 10 { mp + 3 } else { mp - 9 };
    let year = yoe + era * 400 + i64::from(month <= 2);
    format!("{year:04}-{month:02}-{day:02} {:02}:{:02} UTC", rest / 3600, (rest % 3600) / 60)
}

const HOLDOUT_HEADER: &str = "# Holdout suites: logs unlike the generated suite\n\n\
Generated by `cargo run --release -p antenna-cli --bin validate -- holdout` (about 40 minutes on 2 threads for the first nine suites, more for all fifteen; \
the sensor variants of issue 16 in docs/results/validation-holdout-variants.md, the others in docs/results/validation-holdout.md; `--only NAMES` runs some of them). A run replaces the sections of the suites it ran \
and keeps the others, after each suite, so a stopped run leaves the suites it did not reach as they were. \
The same truth generator and the same `validate` (no option changed) on suites whose sensors (a motor speed \
signal instead of the motor encoder with two motors' currents; the load encoder alone; a 22-bit load encoder coarser \
than the twist; the current command logged; a noiseless current sensor; a linear axis; a short stroke without unbalance), or log rate, sensor \
noise, drive resonance and inertia, and seeds differ from the main suite's (`docs/validation-results.md`), \
every effect kind at 10 and 20 times the noise: a check that the tool is not tuned to the suite it was developed on. \
The starting parameter set of each is its truth's nominal plant. Reading: docs/validation.md, \"Logs unlike the suite\".\n\n";

fn stem_of(path: &Path) -> String {
    path.file_stem().map(|s| s.to_string_lossy().to_string()).unwrap_or_else(|| "log".into())
}

/// Validates one log.
fn run_one(log_path: &Path, params_path: &Path, settings: &Settings) -> anyhow::Result<Validation> {
    let log = MeasuredLog::read(log_path).with_context(|| format!("{}", log_path.display()))?;
    let start = ParameterSet::read(params_path)?;
    let mut simulator = settings.fmu.as_deref().map(FmuSimulator::open).transpose()?;
    let spinner = progress_spinner(&format!("validating {}", log_path.display()));
    let validation = validate::validate_with(
        &log,
        &start,
        &settings.options,
        simulator.as_mut().map(|s| s as &mut dyn PlantSimulator),
    );
    spinner.finish_and_clear();
    Ok(validation?)
}

/// A spinner with the elapsed time on stderr while one log is validated (tens of seconds for a
/// minute of a 1 kHz log), ticking on its own thread since the validation reports no steps.
/// Silent when stderr is not a terminal (indicatif draws nothing there), so piped output and
/// the reports stay as they were.
fn progress_spinner(message: &str) -> indicatif::ProgressBar {
    let spinner = indicatif::ProgressBar::new_spinner().with_message(message.to_string());
    if let Ok(style) = indicatif::ProgressStyle::with_template("{spinner} {msg} ({elapsed})") {
        spinner.set_style(style);
    }
    spinner.enable_steady_tick(std::time::Duration::from_millis(200));
    spinner
}

/// Writes the report, the corrected parameter sets and the figures of one validation.
fn write_outputs(
    validation: &Validation,
    log_path: &Path,
    params_path: &Path,
    dir: &Path,
    stem: &str,
) -> anyhow::Result<Vec<String>> {
    std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
    let report_path = dir.join(format!("{stem}_report.md"));
    std::fs::write(&report_path, report::markdown(validation, &log_path.display().to_string()))
        .with_context(|| format!("cannot write {}", report_path.display()))?;
    let kept = validation.kept_parameters();
    let mut header = format!("Corrected by validate from {} on {}.", params_path.display(), log_path.display());
    for line in kept.cannot_tell.iter().chain(&kept.also_fits) {
        header.push('\n');
        header.push_str(line);
    }
    kept.parameters.write(
        &dir.join(format!("{stem}_corrected_axis.params")),
        &format!("{header}\nSingle-axis parameter set (validate's own form; usable as a starting set)."),
    )?;
    if let Some(o) = &validation.output {
        let fmu_text = fmu_parameter_text(
            &kept.parameters,
            &o.config,
            &format!("{header}\nAzimuthPlant parameter file: load it through the FMU's parameter_file variable.\nMapping from the single-axis set: docs/validation.md, validate::parameters::FMU_MAPPING."),
        )?;
        let path = dir.join(format!("{stem}_corrected.params"));
        std::fs::write(&path, fmu_text).with_context(|| format!("cannot write {}", path.display()))?;
    }
    text(report::figures(validation, dir, stem))
}

fn score_suite(dir: &Path, settings: &Settings) -> anyhow::Result<Vec<scoring::CaseResult>> {
    Ok(scoring::run_suite(dir, &settings.options, settings.fmu.as_deref(), settings.threads, &|r| {
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
    })?)
}

/// Runs the KUKA axes and returns the markdown section; figures go to `figures`.
fn run_kuka(data_dir: &Path, figures: &Path, settings: &Settings) -> anyhow::Result<String> {
    let params_dir = antenna_fmus::workspace_root().join("tools").join("validate").join("data").join("kuka");
    let mut rows = Vec::new();
    for axis in 1..=3 {
        let log_path = data_dir.join(format!("axis{axis}.csv"));
        let params_path = params_dir.join(format!("axis{axis}.params"));
        let clock = Instant::now();
        let validation = run_one(&log_path, &params_path, settings)?;
        check_finite(&validation)?;
        let seconds = clock.elapsed().as_secs_f64();
        let stem = format!("validation-kuka-axis{axis}");
        let written = text(report::figures(&validation, figures, &stem))?;
        rows.push((axis, validation, seconds, written));
    }
    Ok(report::kuka_section(&rows))
}

/// The generated results document (docs/results/validation-results.md).
fn results_document(results: &[scoring::CaseResult], kuka: Option<&str>, timing: &str) -> String {
    let mut text = String::from(
        "# Validation results (generated)\n\nRegenerated by `cargo xtask docs --only validation` \
         (package the FMUs first). Method and reading: docs/validation.md.\n\n",
    );
    text.push_str(&format!("{timing}\n\n## Generated suite\n\n"));
    text.push_str(&scoring::summary_markdown(results));
    text.push_str("\n![Detection rate against effect size](../figures/validation-detection.png)\n\nCurve data: `docs/results/validation-detection.csv`.\n\n");
    text.push_str("### All cases\n\nSize = RMS of what the effect adds to its channel over that channel's sensor noise. Output error: the scored position channel whose error dropped most, RMS over all windows in arcsec; equation error: the equation whose residual dropped most, axis-side N m.\n\n");
    text.push_str(&scoring::table_markdown(results));
    if let Some(section) = kuka {
        text.push_str("\n## KUKA robot drive (`tests/data/measured/kuka-robot-drive/`)\n\n");
        text.push_str(section);
    }
    text
}

fn print_summary(v: &Validation) {
    let linear = v.data.linear;
    if v.selection.found.is_empty() {
        println!("no significant missing effect");
    }
    if let Some(line) = antenna_validate::report::detection_summary(v) {
        println!("{line}");
    }
    for found in &v.selection.found {
        println!("found {} ({})", found.kind.name(), found.kind.description());
        for (name, value, sd, unit) in &found.parameters {
            let unit = if name.starts_with("motor.") { unit.as_str() } else { axis_unit(unit, linear) };
            println!("    {name} = {value:.6e} +- {sd:.2e} {unit}");
        }
        if found.kind == Kind::Delay {
            println!(
                "    delay or current skew: the data cannot tell (a current stamped earlier than the encoders by as much reads the same)"
            );
        }
        let alike = v.selection.equally_consistent(found.kind);
        if !alike.is_empty() {
            println!(
                "    the data cannot tell it from: {}",
                alike.iter().map(|k| k.name()).collect::<Vec<_>>().join(", ")
            );
        }
        for alternative in v.indistinct.iter().filter(|a| a.found == found.kind) {
            println!(
                "    {} or {}: the data cannot tell ({} reproduces it within {:.1} % RMS over this log)",
                found.kind.name(),
                alternative.alternative.name(),
                alternative.alternative.name(),
                100.0 * alternative.misfit
            );
        }
    }
    let kept = v.kept_parameters();
    for line in kept.cannot_tell.iter().chain(&kept.also_fits) {
        println!("corrected set: {line}");
    }
    for (b, a) in v.before.iter().zip(&v.after) {
        println!(
            "{}: RMS {:.4} -> {:.4} {} (axis side), fit {:.1} -> {:.1} %, whiteness p {:.1e} -> {:.1e}",
            b.name,
            b.rms,
            a.rms,
            axis_unit("N m", linear),
            b.fit_percent,
            a.fit_percent,
            b.whiteness_p,
            a.whiteness_p
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
                axis_unit(b.kind.unit(), linear),
                b.fit_percent,
                a.fit_percent
            );
        }
        if let Some(r) = &o.recheck {
            println!("    {}", antenna_validate::report::recheck_summary(r).replace("**", ""));
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_sensor_variant_named_for_the_variants_document_is_a_holdout_suite() {
        // A renamed suite would otherwise move to the other document without a word.
        let known: Vec<&str> = suite::holdout_suites().iter().map(|s| s.0).collect();
        for name in SENSOR_VARIANT_SUITES.iter().chain(&HIDDEN_LOG_SUITES) {
            assert!(known.contains(name), "{name} is not a holdout suite (known: {known:?})");
        }
        let in_main: Vec<&str> =
            known.iter().copied().filter(|s| holdout_document(s) == "validation-holdout.md").collect();
        assert_eq!(in_main, ["speed-sensor", "load-encoder-only", "fast-stiff", "slow-soft"]);
    }
}
