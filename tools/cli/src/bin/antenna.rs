//! The main job: builds and packages the FMUs, runs the coupled antenna through the
//! requirement scenarios of the seed paper (Req. 1-5 at 15, 45 and 88 deg elevation, optimal
//! and normal wind) and prints the requirement table; writes it as markdown and CSV with plots
//! of the pointing error into `out/antenna/`.
//!
//! `--config paper` runs the seed paper's drive-only model (no structure, ideal sensors, a
//! coherent gust) instead of the realistic antenna of docs/parameters.csv.
//!
//! `--trace <dir>` also writes, per scenario, its command table, its configuration (wind, step
//! and every parameter override, `name = value` lines) and its full trace as CSV, which the fmpy master
//! (tools/fmpy_master/coupled_master.py) reads to run the same scenario. `--commands <file.csv>`
//! runs a pointing table of your own instead of the requirement scenarios, judged by the
//! Req. 1 jitter. `--ssp <dir>` writes each scenario as an SSP 1.0 archive for other
//! co-simulation engines (docs/ssp.md). A failed requirement is a finding of the report, not
//! an error: the exit code is 0 whenever the report was written.
//!
//! `antenna sweep ...` draws samples over the ranges of docs/parameters.csv and runs the
//! requirement scenarios for each, on all cores or on a distributed engine, and writes the rows
//! and a report (docs/sweeps.md); the work is `antenna_sim::sweep`'s, this file parses and prints.

use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::sync::Arc;
use std::time::Instant;

use anyhow::{bail, Context};
use clap::{Args, Parser, Subcommand, ValueEnum};
use indicatif::{ProgressBar, ProgressStyle};
use rayon::prelude::*;

use antenna_sim::command::CommandTable;
use antenna_sim::coupled::WindCondition;
use antenna_sim::pointing_model::PointingModel;
use antenna_sim::pointing_model_fit::{self, DerivationGrid};
use antenna_sim::report::{csv, markdown, plot, run_scenario, run_with_budget, spread_seeds, Outcome, SeedSpread};
use antenna_sim::scenario::{
    normal_wind, optimal_wind, requirement_scenarios, Analysis, Requirement, Scenario, JITTER_WINDOW_S,
};
use antenna_sim::{ssp, sweep};
use antenna_sim::{AntennaConfig, AntennaSetup, Configuration, FmuSet, Lanes};

/// Runs the coupled antenna FMUs through the requirement scenarios (Req. 1-5) and writes the
/// requirement report.
#[derive(Parser)]
// `about` is left to this doc comment: the crate description is that of all the commands.
#[command(version, long_about = None, args_conflicts_with_subcommands = true)]
#[command(group(clap::ArgGroup::new("exports").args(["trace", "ssp"]).multiple(true)))]
struct Cli {
    #[command(subcommand)]
    command: Option<Command>,
    /// Use the FMUs already packaged in target/fmu (or $MEERKAT_FMU_DIR) instead of building and
    /// packaging them first.
    #[arg(long)]
    no_build: bool,
    /// Run only the requirement scenarios whose name contains this text.
    #[arg(long, value_name = "NAME PART", conflicts_with = "commands")]
    only: Option<String>,
    /// Folder for report.md, report.csv and the figures [default: out/antenna].
    #[arg(long, value_name = "DIR")]
    out: Option<PathBuf>,
    /// Also write each scenario's command table, configuration and full trace (CSV) here.
    #[arg(long, value_name = "DIR")]
    trace: Option<PathBuf>,
    /// Run this pointing table (columns time_s,azimuth_deg,elevation_deg; a repeated time marks
    /// a jump) instead of the requirement scenarios, judged by the Req. 1 jitter.
    #[arg(long, value_name = "TABLE.csv")]
    commands: Option<PathBuf>,
    /// The wind for --commands.
    #[arg(long, value_enum, default_value_t = Wind::Optimal, requires = "commands")]
    wind: Wind,
    /// The wind's seed for --commands.
    #[arg(long, default_value_t = 1, requires = "commands")]
    seed: i32,
    /// Which antenna: the realistic one (docs/parameters.csv's defaults: structure between
    /// encoders and beam, encoder errors, friction at sidereal rates) or the paper's model.
    #[arg(long, value_enum, default_value_t = ConfigurationName::Realistic)]
    config: ConfigurationName,
    /// Repeat every jitter scenario (Req. 1 and 5) with this many gust seeds and report the
    /// median and the worst figure (1: only the scenario's own seed).
    #[arg(long, default_value_t = 8, value_parser = clap::value_parser!(u16).range(1..=1000))]
    seeds: u16,
    /// Couple the structure one way: its modes swing on the drives without pushing back on
    /// them (the plants take the wind's torques and their whole load inertia), as before the
    /// two-way coupling; for comparison.
    #[arg(long)]
    one_way_structure: bool,
    /// The structure's modes from this modes file (docs/structure-model.md: the modes of your
    /// own finite-element model, at the zenith and, with horizon_frequency, the horizon) in
    /// place of the shipped ones. Not with --config paper, which has no structure.
    #[arg(long, value_name = "MODES.params")]
    modes: Option<PathBuf>,
    /// Hold a parameter of docs/parameters.csv at this value instead of the configuration's
    /// (repeatable; the names of `antenna sweep --fix`): the report at one point of the ranges.
    #[arg(long, value_name = "NAME=VALUE", value_parser = parse_fix)]
    set: Vec<(String, f64)>,
    /// Also write each scenario as an SSP 1.0 archive (<scenario>.ssp: the FMUs, their
    /// connections and parameters) here, and plant.ssp, the first scenario's antenna without
    /// its controllers (docs/ssp.md).
    #[arg(long, value_name = "DIR")]
    ssp: Option<PathBuf>,
    /// Write what another master needs for each scenario (its command table and configuration
    /// into --trace, its SSP archive into --ssp) and run nothing; the archives take the FMUs
    /// packaged in target/fmu (or $MEERKAT_FMU_DIR) as they are.
    #[arg(long, requires = "exports")]
    export_only: bool,
    /// Threads one coupled run uses, 1 or 2 (with 2 the azimuth lane runs on a second thread,
    /// bit for bit as on one; docs/performance.md). Default: 2 when a single scenario runs on a
    /// machine of two cores or more, else 1 (several scenarios keep the cores busy with whole
    /// runs).
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u8).range(1..=2))]
    threads: Option<u8>,
    /// Apply this pointing-model table (written by `antenna pointing-model`) as the antenna
    /// control unit would: every jitter scenario runs again with each command corrected by the
    /// table's predicted error, and the report adds the figures after the pointing model.
    /// Another master does not apply it: not with --trace or --ssp.
    #[arg(long, value_name = "TABLE.csv", conflicts_with = "exports")]
    pointing_model: Option<PathBuf>,
}

/// The antenna configurations of docs/parameters.csv.
#[derive(Clone, Copy, PartialEq, Eq, ValueEnum)]
enum ConfigurationName {
    /// The realistic antenna (the default column).
    Realistic,
    /// The seed paper's drive-only model (the paper column): reproduces its report.
    Paper,
}

impl ConfigurationName {
    fn configuration(self) -> Configuration {
        match self {
            ConfigurationName::Realistic => Configuration::Realistic,
            ConfigurationName::Paper => Configuration::Paper,
        }
    }
}

/// The wind conditions a pointing table of one's own can run in.
#[derive(Clone, Copy, PartialEq, Eq, ValueEnum)]
enum Wind {
    /// No wind.
    Calm,
    /// The specification's optimal wind (Req. 1).
    Optimal,
    /// The specification's normal wind (Req. 5).
    Normal,
}

fn main() -> ExitCode {
    let mut cli = Cli::parse();
    let result = match cli.command.take() {
        Some(Command::Sweep(args)) => sweep(*args),
        Some(Command::PointingModel(args)) => pointing_model(args),
        None => run(cli),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("antenna: error: {e:#}");
            ExitCode::from(2)
        }
    }
}

fn run(cli: Cli) -> anyhow::Result<()> {
    let out_dir = cli.out.clone().unwrap_or_else(|| antenna_fmus::workspace_root().join("out").join("antenna"));
    let configuration = cli.config.configuration();
    // A structure whose modes a --set changes is written beside what it is for: the traces
    // another master reads, or the report.
    let modes_folder = cli.trace.clone().unwrap_or_else(|| out_dir.clone());
    std::fs::create_dir_all(&modes_folder).with_context(|| format!("cannot create {}", modes_folder.display()))?;
    // The FMU looks a relative name up in its resources folder: hand it the whole path.
    let modes_folder = modes_folder.canonicalize()?;
    let values = configuration.values_with(&cli.set).context("--set")?;
    let setup = AntennaSetup::from_values(&values, Some(&modes_folder)).context("--set")?;
    let settings = setup.scenario;
    let scenarios: Vec<Scenario> = match &cli.commands {
        Some(path) => vec![user_scenario(path, cli.wind, cli.seed)?],
        None => selected_scenarios(cli.only.as_deref())?,
    }
    .iter()
    .map(|s| settings.apply(s))
    .collect();
    let pointing_model = match &cli.pointing_model {
        Some(path) => Some(Arc::new(PointingModel::from_csv(path).context("--pointing-model")?)),
        None => None,
    };
    let mut config = AntennaConfig { structure_feedback: !cli.one_way_structure, pointing_model, ..setup.config };
    if let Some(modes) = &cli.modes {
        let Some(structure) = config.structure.as_mut() else {
            bail!("--modes: this configuration (--config paper) has no structure");
        };
        let path = modes.canonicalize().with_context(|| format!("--modes {}", modes.display()))?;
        structure.push(("modes_file".into(), antenna_sim::ParameterValue::Text(path.display().to_string())));
    }
    if !cli.export_only && !cli.no_build {
        eprintln!("building and packaging the FMUs ...");
        xtask::build_and_package(xtask::Pgo::Off).context("packaging failed")?;
    }
    if let (true, Some(dir)) = (cli.export_only, cli.trace.as_deref()) {
        for scenario in &scenarios {
            write_inputs(dir, &config, scenario)
                .with_context(|| format!("cannot write {}'s files into {}", scenario.name, dir.display()))?;
        }
    }
    let open_fmus = || {
        FmuSet::open(&antenna_fmus::fmu_directory())
            .with_context(|| format!("cannot open the FMUs in {}", antenna_fmus::fmu_directory().display()))
    };
    if let Some(dir) = &cli.ssp {
        write_ssp(&open_fmus()?, dir, &config, &scenarios)
            .with_context(|| format!("--ssp: cannot write the archives into {}", dir.display()))?;
    }
    if cli.export_only {
        return Ok(());
    }
    let fmus = open_fmus()?;
    let started = Instant::now();
    // One scenario alone would leave every core but one idle: its azimuth lane takes a second
    // while that is faster on this machine (the same results bit for bit; many scenarios keep
    // the cores busy with whole runs).
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    let threads = cli.threads.unwrap_or(if scenarios.len() == 1 && cores > 1 { 2 } else { 1 });
    let lanes = if threads == 2 { Lanes::Two } else { Lanes::One };
    let outcomes = run_all(&fmus, &AntennaConfig { lanes, ..config.clone() }, &scenarios, cli.trace.as_deref())?;
    // Each windy jitter scenario also ran in calm air for its budget.
    let calm_twins: f64 = outcomes
        .iter()
        .filter(|o| o.budget.is_some() && o.scenario.wind.mean_speed_m_s > 0.0)
        .map(|o| o.scenario.end_s)
        .sum();
    // And, with a pointing model, once more with it applied.
    let model_reruns: f64 =
        outcomes.iter().filter(|o| o.after_pointing_model.is_some()).map(|o| o.scenario.end_s).sum();
    let total_sim: f64 = scenarios.iter().map(|s| s.end_s).sum::<f64>() + calm_twins + model_reruns;
    let wall = started.elapsed().as_secs_f64();
    // The seeds' spread is that of the figures without a pointing model, as the rows are.
    let without_model = AntennaConfig { pointing_model: None, ..config.clone() };
    let spreads =
        if cli.seeds > 1 { seed_spreads(&fmus, &without_model, &scenarios, cli.seeds.into())? } else { Vec::new() };
    write_report(&outcomes, &spreads, &config, &out_dir, total_sim, wall)
}

/// The requirement scenarios whose name contains `only` (all without it); none is bad usage,
/// answered with the names there are.
fn selected_scenarios(only: Option<&str>) -> anyhow::Result<Vec<Scenario>> {
    let all = requirement_scenarios();
    let names: Vec<String> = all.iter().map(|s| s.name.clone()).collect();
    let selected: Vec<Scenario> = all.into_iter().filter(|s| only.is_none_or(|f| s.name.contains(f))).collect();
    if selected.is_empty() {
        bail!("--only {}: no scenario name contains it; the scenarios are: {}", only.unwrap_or(""), names.join(", "));
    }
    Ok(selected)
}

/// Runs the scenarios in parallel (each on its own FMU instances, so the results do not depend
/// on the thread count), in input order, with one progress bar over the simulated time.
fn run_all(
    fmus: &FmuSet,
    config: &AntennaConfig,
    scenarios: &[Scenario],
    trace_dir: Option<&Path>,
) -> anyhow::Result<Vec<Outcome>> {
    let total_ms: u64 = scenarios.iter().map(|s| (s.end_s * 1e3).round() as u64).sum();
    let bar = ProgressBar::new(total_ms).with_style(
        ProgressStyle::with_template("[{bar:30}] {percent:>3} %  {elapsed} elapsed, {eta} left")
            .expect("the template is valid")
            .progress_chars("#>-"),
    );
    // A scenario's command table caches its last look-up (it is not Sync), so each thread gets
    // its own copy.
    let outcomes = scenarios
        .to_vec()
        .into_par_iter()
        .map(|scenario| {
            let mut reported_ms = 0;
            let mut progress = |fraction: f64| {
                let done_ms = (fraction * scenario.end_s * 1e3).round() as u64;
                bar.inc(done_ms.saturating_sub(reported_ms));
                reported_ms = reported_ms.max(done_ms);
            };
            let outcome = run_with_budget(fmus, config, &scenario, &mut progress)?;
            if let Some(dir) = trace_dir {
                write_trace(dir, config, &outcome)
                    .with_context(|| format!("cannot write the trace into {}", dir.display()))?;
            }
            Ok(outcome)
        })
        .collect::<anyhow::Result<Vec<Outcome>>>();
    bar.finish_and_clear();
    outcomes
}

/// Prints the requirement table and writes report.md, report.csv and the figures.
/// Runs every jitter scenario again with more gust seeds, in parallel, in input order.
fn seed_spreads(
    fmus: &FmuSet,
    config: &AntennaConfig,
    scenarios: &[Scenario],
    count: usize,
) -> anyhow::Result<Vec<SeedSpread>> {
    let jitter: Vec<&Scenario> = scenarios
        .iter()
        .filter(|s| matches!(s.analysis, Analysis::Jitter { .. }) && s.wind.mean_speed_m_s > 0.0)
        .collect();
    // A command table caches its last look-up (it is not Sync): each run gets its own copy.
    let runs: Vec<(usize, Scenario)> = jitter
        .iter()
        .enumerate()
        .flat_map(|(i, s)| {
            spread_seeds(s, count).into_iter().map(move |seed| {
                let mut scenario = (*s).clone();
                scenario.wind.seed = seed;
                (i, scenario)
            })
        })
        .collect();
    let bar = ProgressBar::new(runs.len() as u64);
    let figures = runs
        .into_par_iter()
        .map(|(i, scenario)| {
            let outcome = run_scenario(fmus, config, &scenario, &mut |_| {})?;
            let from_s = match scenario.analysis {
                Analysis::Jitter { from_s } => from_s,
                Analysis::Settling { jump_s, .. } => jump_s,
            };
            let windows = antenna_sim::metrics::centred_jitter_windows_arcsec(&outcome.trace, from_s, 1.0);
            bar.inc(1);
            Ok((i, outcome.figure, windows))
        })
        .collect::<anyhow::Result<Vec<(usize, f64, Vec<f64>)>>>()?;
    bar.finish_and_clear();
    Ok(jitter
        .iter()
        .enumerate()
        .map(|(i, s)| SeedSpread {
            scenario: s.name.clone(),
            requirement: s.requirement,
            seeds: spread_seeds(s, count),
            figures: figures.iter().filter(|(j, _, _)| *j == i).map(|(_, f, _)| *f).collect(),
            windows: figures.iter().filter(|(j, _, _)| *j == i).flat_map(|(_, _, w)| w.iter().copied()).collect(),
        })
        .collect())
}

/// Prints the requirement table and writes report.md, report.csv and the figures.
fn write_report(
    outcomes: &[Outcome],
    spreads: &[SeedSpread],
    config: &AntennaConfig,
    out_dir: &Path,
    total_sim: f64,
    wall: f64,
) -> anyhow::Result<()> {
    let table = markdown(outcomes);
    println!(
        "\nRequirement report: {} scenarios, {:.0} s simulated in {:.1} s wall-clock ({:.0} x real time)\n",
        outcomes.len(),
        total_sim,
        wall,
        total_sim / wall
    );
    println!("{table}");
    let definitions = antenna_sim::report::definitions(config);
    println!("{definitions}");
    std::fs::create_dir_all(out_dir).with_context(|| format!("cannot create {}", out_dir.display()))?;
    let sections = antenna_sim::report::sections(outcomes, spreads, config, out_dir)?;
    println!("{sections}");
    let header = format!("# Requirement report\n\n{}\n\n", definitions.replace('\n', "\n\n"));
    let report = out_dir.join("report.md");
    std::fs::write(&report, format!("{header}{table}{sections}"))
        .with_context(|| format!("cannot write {}", report.display()))?;
    let report_csv = out_dir.join("report.csv");
    std::fs::write(&report_csv, csv(outcomes)).with_context(|| format!("cannot write {}", report_csv.display()))?;
    for path in plot(outcomes, out_dir).context("plotting failed")? {
        println!("wrote {}", path.display());
    }
    println!("wrote {} and report.csv", report.display());
    Ok(())
}

/// A scenario from a pointing table of the user's: run from its first to its last time stamp
/// and judged by the worst 10 s RMS pointing error after the first 10 s.
/// The longest pointing table `--commands` runs, s (two hours: a trace of 7.2 million steps,
/// about 1.5 GB in memory).
const MAX_COMMAND_SPAN_S: f64 = 7200.0;

fn user_scenario(path: &Path, wind: Wind, seed: i32) -> anyhow::Result<Scenario> {
    let table = CommandTable::from_csv(path)?;
    let (start, end) = table.time_span();
    // The run keeps a trace of every 1 ms step (about 200 bytes each): a day is 17 GB.
    if end - start > MAX_COMMAND_SPAN_S || start.abs() > MAX_COMMAND_SPAN_S {
        bail!(
            "{}: the table runs from {start:e} s to {end:e} s; a run spans at most {MAX_COMMAND_SPAN_S} s (its trace is kept in memory) and starts within {MAX_COMMAND_SPAN_S} s of 0",
            path.display()
        );
    }
    if end - start < 2.0 * JITTER_WINDOW_S {
        bail!(
            "{}: the table spans {:.1} s; at least {:.0} s are needed for a jitter window after the first {:.0} s",
            path.display(),
            end - start,
            2.0 * JITTER_WINDOW_S,
            JITTER_WINDOW_S
        );
    }
    let azimuth = table.at(start).azimuth_deg;
    let (wind, label, requirement) = match wind {
        Wind::Calm => (WindCondition::CALM, "calm", Requirement::TrackingJitter),
        Wind::Optimal => (optimal_wind(azimuth, seed), "optimal", Requirement::TrackingJitter),
        Wind::Normal => (normal_wind(azimuth, seed), "normal", Requirement::TrackingNormalWind),
    };
    Ok(Scenario {
        name: path.file_stem().map_or("commands".into(), |s| s.to_string_lossy().into_owned()),
        requirement,
        elevation_deg: table.at(start).elevation_deg,
        wind_label: label,
        wind,
        end_s: end,
        analysis: Analysis::Jitter { from_s: start + JITTER_WINDOW_S },
        table,
    })
}

/// Writes what another master needs to rerun a scenario, and the trace to compare with.
fn write_trace(dir: &Path, config: &AntennaConfig, outcome: &Outcome) -> std::io::Result<()> {
    let s = &outcome.scenario;
    write_inputs(dir, config, s)?;
    std::fs::write(dir.join(format!("{}.trace.csv", s.name)), outcome.trace.to_csv())
}

/// Writes each scenario's SSP archive (`<name>.ssp`) and the first one's antenna without its
/// controllers (`plant.ssp`) into `dir`.
fn write_ssp(fmus: &FmuSet, dir: &Path, config: &AntennaConfig, scenarios: &[Scenario]) -> anyhow::Result<()> {
    std::fs::create_dir_all(dir)?;
    let fmu_dir = antenna_fmus::fmu_directory();
    for scenario in scenarios {
        let bytes = ssp::archive(fmus, &fmu_dir, config, scenario, ssp::Extent::Antenna)
            .with_context(|| format!("scenario {}", scenario.name))?;
        std::fs::write(dir.join(format!("{}.ssp", scenario.name)), bytes)?;
    }
    if let Some(first) = scenarios.first() {
        let bytes = ssp::archive(fmus, &fmu_dir, config, first, ssp::Extent::Plant)
            .with_context(|| format!("the plant of scenario {}", first.name))?;
        std::fs::write(dir.join("plant.ssp"), bytes)?;
    }
    Ok(())
}

/// Writes a scenario's command table and configuration, what another master needs to run it.
fn write_inputs(dir: &Path, config: &AntennaConfig, s: &Scenario) -> std::io::Result<()> {
    std::fs::create_dir_all(dir)?;
    std::fs::write(dir.join(format!("{}.commands.csv", s.name)), s.table.to_csv())?;
    std::fs::write(dir.join(format!("{}.config", s.name)), config.master_config_text(&s.wind, s.end_s))
}

/// The subcommands besides the requirement report.
#[derive(Subcommand)]
enum Command {
    /// Draws samples over the parameter ranges of docs/parameters.csv, runs the requirement
    /// scenarios for each (all cores, or a distributed engine) and writes sweep.csv (one row per
    /// sample and scenario) and sweep.md (pass probabilities, worst samples, sensitivity).
    Sweep(Box<SweepArgs>),
    /// Derives a pointing-model table from the model itself (calm scans for the encoders'
    /// repeatable errors, holds in a steady wind for the static flexure; docs/requirement-report.md,
    /// "Pointing model") and writes it as CSV with a figure beside it; `antenna --pointing-model
    /// FILE` applies it.
    PointingModel(PointingModelArgs),
}

/// The options of `antenna pointing-model`.
#[derive(Args)]
struct PointingModelArgs {
    /// The table to write [default: out/pointing-model/pointing-model.csv]; its figure goes
    /// beside it with the extension .png.
    #[arg(long, value_name = "FILE.csv")]
    out: Option<PathBuf>,
    /// Which antenna the table is derived for.
    #[arg(long, value_enum, default_value_t = ConfigurationName::Realistic)]
    config: ConfigurationName,
    /// Hold a parameter of docs/parameters.csv at this value (repeatable).
    #[arg(long, value_name = "NAME=VALUE", value_parser = parse_fix)]
    set: Vec<(String, f64)>,
    /// Use the FMUs already packaged instead of building and packaging them first.
    #[arg(long)]
    no_build: bool,
}

/// `antenna pointing-model`: derives the table on all cores and writes it and its figure.
fn pointing_model(args: PointingModelArgs) -> anyhow::Result<()> {
    let out = args.out.unwrap_or_else(|| {
        antenna_fmus::workspace_root().join("out").join("pointing-model").join("pointing-model.csv")
    });
    let folder = out.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new(".")).to_path_buf();
    std::fs::create_dir_all(&folder).with_context(|| format!("cannot create {}", folder.display()))?;
    let values = args.config.configuration().values_with(&args.set).context("--set")?;
    let setup = AntennaSetup::from_values(&values, Some(&folder.canonicalize()?)).context("--set")?;
    if !args.no_build {
        eprintln!("building and packaging the FMUs ...");
        xtask::build_and_package(xtask::Pgo::Off).context("packaging failed")?;
    }
    let fmus = FmuSet::open(&antenna_fmus::fmu_directory())
        .with_context(|| format!("cannot open the FMUs in {}", antenna_fmus::fmu_directory().display()))?;
    let grid = DerivationGrid::standard();
    let started = Instant::now();
    eprintln!("deriving the pointing model: calm scans and steady-wind holds on all cores ...");
    let model = pointing_model_fit::derive(&fmus, &setup.config, &grid)?;
    std::fs::write(&out, model.to_csv(&pointing_model_fit::table_comment(&grid)))
        .with_context(|| format!("cannot write {}", out.display()))?;
    let figure = out.with_extension("png");
    pointing_model_fit::plot(&model, &figure).context("plotting failed")?;
    println!("wrote {} and {} in {:.0} s", out.display(), figure.display(), started.elapsed().as_secs_f64());
    Ok(())
}

/// The options of `antenna sweep`.
#[derive(Args)]
struct SweepArgs {
    /// Samples to draw (for --method grid: points per axis).
    #[arg(long, default_value_t = 100)]
    samples: u64,
    /// The seed every sample's values derive from (with its index).
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// How the samples spread over the ranges.
    #[arg(long, value_enum, default_value_t = MethodName::Lhs)]
    method: MethodName,
    /// Run the requirement scenarios whose name contains any of these [default: all 21].
    #[arg(long, value_name = "NAME PART", num_args = 1..)]
    scenarios: Vec<String>,
    /// Vary only these parameters (names, or groups such as `wind`, `encoder`) [default: every row].
    #[arg(long, value_name = "NAME", num_args = 1.., value_delimiter = ',')]
    vary: Vec<String>,
    /// Hold a parameter at a value (repeatable).
    #[arg(long, value_name = "NAME=VALUE", value_parser = parse_fix)]
    fix: Vec<(String, f64)>,
    /// A table in the format of docs/parameters.csv whose rows replace (or add to) the committed ones.
    #[arg(long, value_name = "FILE.csv")]
    sweep_file: Option<PathBuf>,
    /// Worker threads [default: 0 = one per core].
    #[arg(long, default_value_t = 0)]
    threads: usize,
    /// Folder for sweep.csv, sweep.md and the figures [default: out/sweep].
    #[arg(long, value_name = "DIR")]
    out: Option<PathBuf>,
    /// Use the FMUs already packaged instead of building and packaging them first.
    #[arg(long)]
    no_build: bool,
    /// Run only batch I of N (consecutive samples) into DIR/batch-I-of-N.csv, without a report.
    #[arg(long, value_name = "I/N", conflicts_with_all = ["only_sample", "report_only", "engine"])]
    batch: Option<String>,
    /// Rerun sample K alone with every scenario's trace and plots (into --trace).
    #[arg(long, value_name = "K", requires = "trace", conflicts_with = "report_only")]
    only_sample: Option<u64>,
    /// Folder for the traces of --only-sample.
    #[arg(long, value_name = "DIR", requires = "only_sample")]
    trace: Option<PathBuf>,
    /// Write the report from DIR/sweep.csv without running anything (after a distributed sweep).
    #[arg(long)]
    report_only: bool,
    /// Where the samples run: this machine's cores, or a Dask cluster (through tools/sweep_distributed/).
    #[arg(long, value_enum, default_value_t = EngineName::Local)]
    engine: EngineName,
    /// The engine's scheduler (`tcp://host:8786`), or `local` for a cluster on this machine.
    #[arg(long, required_if_eq("engine", "dask"))]
    address: Option<String>,
    /// Batches for --engine dask [default: 0 = four per worker thread].
    #[arg(long, default_value_t = 0)]
    batches: u64,
}

/// The sampling methods.
#[derive(Clone, Copy, PartialEq, Eq, ValueEnum)]
enum MethodName {
    /// Latin hypercube.
    Lhs,
    /// Owen-scrambled Sobol sequence.
    Sobol,
    /// Independent uniform draws.
    Random,
    /// A grid over one or two parameters (--vary), --samples points per axis.
    Grid,
}

/// Where a sweep runs.
#[derive(Clone, Copy, PartialEq, Eq, ValueEnum)]
enum EngineName {
    /// All cores of this machine (rayon).
    Local,
    /// Dask distributed.
    Dask,
}

fn parse_fix(text: &str) -> Result<(String, f64), String> {
    let (name, value) = text.split_once('=').ok_or_else(|| format!("`{text}` is not NAME=VALUE"))?;
    let value: f64 = value.trim().parse().map_err(|_| format!("`{value}` is not a number"))?;
    if !value.is_finite() {
        return Err(format!("`{text}`: the value is not finite"));
    }
    Ok((name.trim().to_string(), value))
}

impl SweepArgs {
    fn spec(&self) -> sweep::SweepSpec {
        sweep::SweepSpec {
            samples: self.samples,
            seed: self.seed,
            method: match self.method {
                MethodName::Lhs => sweep::Method::Lhs,
                MethodName::Sobol => sweep::Method::Sobol,
                MethodName::Random => sweep::Method::Random,
                MethodName::Grid => sweep::Method::Grid,
            },
            scenarios: self.scenarios.clone(),
            vary: self.vary.clone(),
            fix: self.fix.clone(),
            sweep_file: self.sweep_file.clone(),
        }
    }
}

/// `antenna sweep`: runs (or hands off, or reports) a sweep.
fn sweep(args: SweepArgs) -> anyhow::Result<()> {
    let out_dir = args.out.clone().unwrap_or_else(|| antenna_fmus::workspace_root().join("out").join("sweep"));
    let sweep = sweep::Sweep::new(args.spec())?;
    std::fs::create_dir_all(&out_dir).with_context(|| format!("cannot create {}", out_dir.display()))?;
    if args.report_only {
        return sweep_report(&sweep, &out_dir, None);
    }
    if !args.no_build {
        eprintln!("building and packaging the FMUs ...");
        xtask::build_and_package(xtask::Pgo::Off).context("packaging failed")?;
    }
    if args.engine == EngineName::Dask {
        let hand_off = sweep::distributed::HandOff {
            engine: sweep::distributed::Engine::Dask,
            address: args.address.clone().unwrap_or_default(),
            batches: args.batches,
            out: out_dir,
            antenna: std::env::current_exe().context("cannot find this program's path")?,
            python: sweep::distributed::default_python(),
        };
        let status = sweep::distributed::hand_off(&sweep.spec, &hand_off)
            .with_context(|| format!("cannot start {}", hand_off.python.display()))?;
        if !status.success() {
            bail!("the distributed driver failed ({status})");
        }
        return Ok(());
    }
    let fmus = FmuSet::open(&antenna_fmus::fmu_directory())
        .with_context(|| format!("cannot open the FMUs in {}", antenna_fmus::fmu_directory().display()))?;
    if let (Some(sample), Some(trace_dir)) = (args.only_sample, &args.trace) {
        let (config, outcomes) = sweep::run::run_one_sample(&sweep, &fmus, sample, trace_dir)?;
        for outcome in &outcomes {
            write_trace(trace_dir, &config, outcome)
                .with_context(|| format!("cannot write the trace into {}", trace_dir.display()))?;
        }
        let simulated: f64 = outcomes.iter().map(|o| o.scenario.end_s).sum();
        let wall: f64 = outcomes.iter().map(|o| o.wall_s).sum();
        return write_report(&outcomes, &[], &config, trace_dir, simulated, wall);
    }
    let (samples, file) = match &args.batch {
        Some(batch) => {
            let range = sweep.batch(batch)?;
            (range, out_dir.join(format!("batch-{}.csv", batch.replace('/', "-of-"))))
        }
        None => (0..sweep.len(), out_dir.join("sweep.csv")),
    };
    let bar = ProgressBar::new(0).with_style(
        ProgressStyle::with_template("[{bar:30}] {pos}/{len} runs  {elapsed} elapsed, {eta} left")
            .expect("the template is valid")
            .progress_chars("#>-"),
    );
    let summary = sweep::run::write_rows_file(&sweep, &fmus, samples, args.threads, &file, &mut |done, total| {
        bar.set_length(total);
        bar.set_position(done);
    })?;
    bar.finish_and_clear();
    eprintln!(
        "{} samples, {} runs, {:.0} s simulated in {:.1} s on {} threads ({:.2} samples/s); peak memory {:.0} MB; wrote {}",
        summary.samples,
        summary.rows,
        summary.simulated_s,
        summary.wall_s,
        summary.threads,
        summary.samples as f64 / summary.wall_s,
        sweep::run::peak_resident_bytes().unwrap_or(0) as f64 / 1e6,
        file.display()
    );
    if args.batch.is_some() {
        return Ok(());
    }
    let timing =
        sweep::report::Timing { wall_s: summary.wall_s, threads: summary.threads, simulated_s: summary.simulated_s };
    sweep_report(&sweep, &out_dir, Some(timing))
}

/// Reads DIR/sweep.csv, writes sweep.md and the figures, prints the pass probabilities. A file
/// with fewer samples than the command line plans (cut short, or written by another command
/// line) is refused, and a sweep in which runs failed ends in an error saying how many, after
/// the report that names the first failure.
fn sweep_report(sweep: &sweep::Sweep, out_dir: &Path, timing: Option<sweep::report::Timing>) -> anyhow::Result<()> {
    let path = out_dir.join("sweep.csv");
    if !path.is_file() {
        bail!("{} is not a regular file", path.display());
    }
    let file = std::fs::File::open(&path).with_context(|| format!("cannot read {}", path.display()))?;
    let data = sweep::analysis::SweepData::read(std::io::BufReader::new(file), &path.display().to_string())?;
    let read = data.samples.len() as u64 + data.failed_samples;
    if read != sweep.len() {
        bail!(
            "{} holds {read} samples where this command line plans {}: it was cut short or written by another command line; run the sweep again, or give the command line that wrote it",
            path.display(),
            sweep.len()
        );
    }
    let report = sweep::report::write_report(&data, sweep, timing, out_dir).context("cannot write the report")?;
    println!("{}", sweep::report::requirement_table(&data));
    println!("wrote {}", report.display());
    if data.failed_samples > 0 {
        bail!(
            "{} of {read} samples had a run that failed (the first: {}); the report leaves them out",
            data.failed_samples,
            data.first_failure.as_deref().unwrap_or("no message")
        );
    }
    Ok(())
}
