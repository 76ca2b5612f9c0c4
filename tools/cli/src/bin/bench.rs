//! Speed benchmark of the coupled antenna through the C ABI: simulated seconds per wall-clock
//! second of the Rust master (and, with `--fmpy`, of the fmpy master), and the cost of one
//! fmi2DoStep of each FMU and of one fmi2GetReal/fmi2SetReal call. Figures go into the README.
//!
//! With `--sweep N`, also the parameter sweeps: samples per second of `antenna sweep` on one and
//! on two threads in the same run (and that both give the same rows), the peak memory of a
//! one-thread sweep process (what one worker of the distributed engine holds), and with
//! `--distributed` the Dask engine against the local pool for the same sweep.
//!
//! With `--series N`, only the coupled run, timed as the README's speed figures are: `N` rounds
//! spread over minutes (`--pause`), each timing one thread, two threads and the automatic choice
//! (best of `--runs` each), then the distribution of those calls. This machine's speed changes
//! in phases of minutes, so one call's figure says little about the next.
//!
//! Usage: `cargo run --release -p antenna-cli --bin bench -- [--seconds 300] [--fmpy] [--sweep 32
//! [--sweep-scenarios el45] [--distributed]]`, or `-- --series 40 --pause 12 --seconds 20`.

use std::process::ExitCode;
use std::time::Instant;

use anyhow::{bail, Context};
use clap::Parser;

use antenna_sim::command::CommandTable;
use antenna_sim::scenario::{optimal_wind, tracking_table};
use antenna_sim::sweep::rows::RowWriter;
use antenna_sim::sweep::run::run_samples;
use antenna_sim::sweep::{Method, Sweep, SweepSpec};
use antenna_sim::{AntennaConfig, CoupledAntenna, FmuSet, Lanes};
use fmu_import::Fmu;

/// Speed benchmark of the coupled antenna through the C ABI, and of single FMI calls.
#[derive(Parser)]
// `about` is left to this doc comment: the crate description is that of all the commands.
#[command(version, long_about = None)]
struct Cli {
    /// Simulated seconds of the coupled run.
    #[arg(long, default_value_t = 300.0, value_parser = positive_seconds, allow_hyphen_values = true)]
    seconds: f64,
    /// Also time the fmpy master (tools/fmpy_master/coupled_master.py, in .venv).
    #[arg(long)]
    fmpy: bool,
    /// Also time parameter sweeps of this many samples (Latin hypercube, seed 1).
    #[arg(long, value_name = "SAMPLES")]
    sweep: Option<u64>,
    /// The scenarios of the sweeps (name parts) [default: all 21].
    #[arg(long, value_name = "NAME PART", num_args = 1.., requires = "sweep")]
    sweep_scenarios: Vec<String>,
    /// Also time the sweep on a local Dask cluster (two workers) against the local pool.
    #[arg(long, requires = "sweep")]
    distributed: bool,
    /// Run only the sweep benchmarks.
    #[arg(long, requires = "sweep")]
    only_sweep: bool,
    /// Run only the coupled antenna (one run, no best of 3, no single calls): for profilers
    /// such as `valgrind --tool=callgrind`, whose counts do not depend on the machine's load.
    #[arg(long, conflicts_with_all = ["fmpy", "sweep"])]
    only_coupled: bool,
    /// Runs of the coupled antenna; the best counts, the median is printed beside it (1 with
    /// `--only-coupled` unless given, for profilers; 3 otherwise).
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..))]
    runs: Option<u32>,
    /// With `--only-coupled`: the threads that step the run (1, or 2 for the azimuth lane on a
    /// second thread).
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u8).range(1..=2), requires = "only_coupled")]
    threads: u8,
    /// Only the coupled run, in this many rounds of one thread, two threads and the automatic
    /// choice (best of `--runs`, 3 unless given, each), then their distribution.
    #[arg(long, value_name = "ROUNDS", value_parser = clap::value_parser!(u32).range(1..), conflicts_with_all = ["only_coupled", "fmpy", "sweep"])]
    series: Option<u32>,
    /// Seconds between the rounds of `--series`.
    #[arg(long, default_value_t = 10.0, requires = "series")]
    pause: f64,
}

/// A finite, positive number of seconds.
fn positive_seconds(text: &str) -> Result<f64, String> {
    match text.parse::<f64>() {
        Ok(s) if s.is_finite() && s > 0.0 => Ok(s),
        _ => Err(format!("`{text}` is not a positive number of seconds")),
    }
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    match run(cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("bench: error: {e:#}");
            ExitCode::from(2)
        }
    }
}

fn run(cli: Cli) -> anyhow::Result<()> {
    let fmus = FmuSet::open(&antenna_fmus::fmu_directory())
        .context("cannot open the FMUs (package them first: cargo xtask package)")?;
    if let Some(rounds) = cli.series {
        return coupled_series(&fmus, cli.seconds, cli.runs.unwrap_or(3) as usize, rounds, cli.pause);
    }
    if cli.only_coupled {
        let lanes = if cli.threads == 2 { Lanes::Two } else { Lanes::One };
        return coupled(&fmus, cli.seconds, cli.runs.unwrap_or(1) as usize, &[lanes]);
    }
    if !cli.only_sweep {
        coupled(&fmus, cli.seconds, cli.runs.unwrap_or(3) as usize, &[Lanes::One, Lanes::Two])?;
        single_calls(&fmus)?;
        if cli.fmpy {
            fmpy_master(cli.seconds)?;
        }
    }
    if let Some(samples) = cli.sweep {
        let spec = sweep_spec(samples, &cli.sweep_scenarios);
        sweep_threads(&fmus, &spec)?;
        sweep_memory(&spec)?;
        if cli.distributed {
            sweep_distributed(&spec)?;
        }
    }
    Ok(())
}

/// The coupled antenna, Rust master: simulated seconds per wall-clock second, best of `runs`,
/// for each of `lanes` (one thread, or the azimuth lane on a second one).
fn coupled(fmus: &FmuSet, seconds: f64, runs: usize, lanes: &[Lanes]) -> anyhow::Result<()> {
    println!("## Coupled antenna, Rust master through the C ABI");
    let (config, table) = benchmark_run(seconds);
    let steps = (seconds / config.step_s).round() as u64;
    for &lane_count in lanes {
        let times = coupled_times(fmus, &config, &table, steps, lane_count, runs)?;
        // The best run is what the code can do; the median says how often the machine lets it.
        let (best, median) = (times[0], times[times.len() / 2]);
        let threads = lanes_name(lane_count);
        println!(
            "sidereal tracking at 45 deg, optimal wind, 1 kHz, 6 FMUs, {threads}: {seconds:.0} s simulated in {best:.3} s = {:.0} x real time ({:.0} ns per 1 ms communication step, best of {runs}; median {:.0} x)",
            seconds / best,
            best / steps as f64 * 1e9,
            seconds / median
        );
    }
    Ok(())
}

/// The wall-clock seconds of `runs` runs of `steps` steps on `lanes`, sorted.
fn coupled_times(
    fmus: &FmuSet,
    config: &AntennaConfig,
    table: &CommandTable,
    steps: u64,
    lanes: Lanes,
    runs: usize,
) -> anyhow::Result<Vec<f64>> {
    let mut times = Vec::with_capacity(runs);
    for _ in 0..runs {
        let mut antenna = CoupledAntenna::new(fmus, config, table)?;
        antenna.set_lanes(lanes);
        let started = Instant::now();
        antenna.run_steps(table, steps, None, &mut |_| {})?;
        times.push(started.elapsed().as_secs_f64());
    }
    times.sort_by(f64::total_cmp);
    Ok(times)
}

/// How the figures name a choice of lanes.
fn lanes_name(lanes: Lanes) -> &'static str {
    match lanes {
        Lanes::One => "one thread",
        Lanes::Two => "two threads",
    }
}

/// The coupled run timed in `rounds` rounds, `pause_s` apart, of each lane choice (best of
/// `runs` per call), and the distribution of the calls' real-time factors: what the README's
/// speed figures are.
fn coupled_series(fmus: &FmuSet, seconds: f64, runs: usize, rounds: u32, pause_s: f64) -> anyhow::Result<()> {
    if !(pause_s.is_finite() && pause_s >= 0.0) {
        bail!("--pause must be a finite, non-negative number of seconds, not {pause_s}");
    }
    println!("## Coupled antenna, Rust master through the C ABI: {rounds} rounds, {pause_s} s apart");
    let (config, table) = benchmark_run(seconds);
    let steps = (seconds / config.step_s).round() as u64;
    let choices = [Lanes::One, Lanes::Two];
    let mut factors: Vec<Vec<f64>> = vec![Vec::new(); choices.len()];
    for round in 0..rounds {
        if round > 0 {
            std::thread::sleep(std::time::Duration::from_secs_f64(pause_s));
        }
        for (lanes, factors) in choices.iter().zip(&mut factors) {
            let best = coupled_times(fmus, &config, &table, steps, *lanes, runs)?[0];
            factors.push(seconds / best);
        }
    }
    for (lanes, factors) in choices.iter().zip(&mut factors) {
        factors.sort_by(f64::total_cmp);
        let quantile = |q: f64| antenna_sim::sweep::analysis::percentile(factors, q);
        let fast_enough = factors.iter().filter(|&&f| f >= 1000.0).count();
        println!(
            "{}: {rounds} calls of {seconds:.0} s simulated, each the best of {runs}: best {:.0} x ({:.0} ns a step), median {:.0} x ({:.0} ns), quartiles {:.0}-{:.0} x, worst {:.0} x; at least 1,000 x in {fast_enough} of {rounds}",
            lanes_name(*lanes),
            quantile(1.0),
            1e9 * config.step_s / quantile(1.0),
            quantile(0.5),
            1e9 * config.step_s / quantile(0.5),
            quantile(0.25),
            quantile(0.75),
            quantile(0.0)
        );
    }
    Ok(())
}

/// One fmi2DoStep of each FMU alone, and one fmi2GetReal.
fn single_calls(fmus: &FmuSet) -> anyhow::Result<()> {
    println!("\n## One fmi2DoStep of 1 ms, each FMU alone (ns per call, best of 3 runs of 200000)");
    for (name, fmu, inputs) in [
        (
            "AzimuthPlant",
            &fmus.azimuth_plant,
            vec![("motor1.current_command", 2.0), ("motor2.current_command", -1.0), ("elevation", 45.0)],
        ),
        ("ElevationPlant", &fmus.elevation_plant, vec![("motor.current_command", 1.0)]),
        ("AzimuthController", &fmus.azimuth_controller, vec![("command.velocity", 0.004)]),
        ("ElevationController", &fmus.elevation_controller, vec![("command.velocity", 0.004)]),
        ("Wind", &fmus.wind, vec![("antenna.azimuth", 10.0)]),
    ] {
        let ns = do_step_cost(fmu, &inputs)?;
        println!("{name:<22} {ns:8.0} ns");
    }
    let ns = get_real_cost(&fmus.azimuth_plant)?;
    println!("\nfmi2GetReal of 6 values from AzimuthPlant: {ns:.0} ns per call");
    Ok(())
}

/// The run both masters are timed on: the realistic antenna (the default configuration, six
/// FMUs) tracking at the sidereal rate at 45 deg elevation in optimal wind, and its commands.
fn benchmark_run(seconds: f64) -> (AntennaConfig, CommandTable) {
    let table = tracking_table((30.0, 45.0), (0.004, 0.004), seconds + 1.0);
    let config = AntennaConfig { wind: optimal_wind(30.0, 7), ..AntennaConfig::default() };
    (config, table)
}

/// The coupled antenna, fmpy master, on the same run as the Rust master's, handed over as the
/// files `antenna --trace` writes for another master.
fn fmpy_master(seconds: f64) -> anyhow::Result<()> {
    println!("\n## Coupled antenna, fmpy master (tools/fmpy_master/coupled_master.py)");
    let root = antenna_fmus::workspace_root();
    let (config, table) = benchmark_run(seconds);
    let directory = std::env::temp_dir().join(format!("meerkat-bench-fmpy-{}", std::process::id()));
    std::fs::create_dir_all(&directory).with_context(|| format!("cannot create {}", directory.display()))?;
    let (config_path, commands_path) = (directory.join("bench.config"), directory.join("bench.commands.csv"));
    std::fs::write(&config_path, config.master_config_text(&config.wind, seconds))?;
    std::fs::write(&commands_path, table.to_csv())?;
    let output = std::process::Command::new(root.join(".venv/bin/python"))
        .arg(root.join("tools/fmpy_master/coupled_master.py"))
        .arg("--config")
        .arg(&config_path)
        .arg("--commands")
        .arg(&commands_path)
        .args(["--bench", &format!("{seconds}")])
        .output();
    let _ = std::fs::remove_dir_all(&directory);
    let output = output.context("cannot run the fmpy master (set up .venv first)")?;
    print!("{}", String::from_utf8_lossy(&output.stdout));
    if !output.status.success() {
        bail!("fmpy master failed: {}", String::from_utf8_lossy(&output.stderr));
    }
    Ok(())
}

fn do_step_cost(fmu: &Fmu, inputs: &[(&str, f64)]) -> anyhow::Result<f64> {
    let mut best = f64::INFINITY;
    for _ in 0..3 {
        let mut instance = fmu.instantiate("bench", false)?;
        instance.setup_experiment(0.0, None)?;
        instance.enter_initialization_mode()?;
        for (name, value) in inputs {
            let vr = fmu.description.vr(name)?;
            instance.set_real(&[vr], &[*value])?;
        }
        instance.exit_initialization_mode()?;
        let n = 200_000u64;
        // Warm the caches first: the plants discretise lazily.
        for k in 0..1000 {
            instance.do_step(k as f64 * 1e-3, 1e-3)?;
        }
        let started = Instant::now();
        for k in 1000..1000 + n {
            instance.do_step(k as f64 * 1e-3, 1e-3)?;
        }
        best = best.min(started.elapsed().as_secs_f64() / n as f64 * 1e9);
    }
    Ok(best)
}

fn get_real_cost(fmu: &Fmu) -> anyhow::Result<f64> {
    let mut instance = fmu.instantiate("bench", false)?;
    instance.initialize(0.0, &[])?;
    let vrs = fmu.description.vrs(&[
        "axis.encoder_position",
        "axis.position",
        "motor1.speed",
        "motor2.speed",
        "motor1.current",
        "motor2.current",
    ])?;
    let mut out = [0.0; 6];
    let n = 1_000_000;
    let started = Instant::now();
    for _ in 0..n {
        instance.get_real(&vrs, &mut out)?;
    }
    Ok(started.elapsed().as_secs_f64() / n as f64 * 1e9)
}

/// The benchmark's sweep: every parameter of the table over its documented range.
fn sweep_spec(samples: u64, scenarios: &[String]) -> SweepSpec {
    SweepSpec {
        samples,
        seed: 1,
        method: Method::Lhs,
        scenarios: scenarios.to_vec(),
        vary: Vec::new(),
        fix: Vec::new(),
        sweep_file: None,
    }
}

/// Samples per second on one and on two threads, measured one after the other in this run, and
/// whether both gave the same rows.
fn sweep_threads(fmus: &FmuSet, spec: &SweepSpec) -> anyhow::Result<()> {
    let sweep = Sweep::new(spec.clone())?;
    println!(
        "\n## Sweep: {} samples x {} scenarios, all parameters varied (antenna sweep {})",
        sweep.len(),
        sweep.scenarios.len(),
        spec.command_line()
    );
    let mut rates = Vec::new();
    let mut outputs = Vec::new();
    for threads in [1, 2] {
        let mut writer = RowWriter::new(Vec::new(), &sweep.parameters)?;
        let cpu_before = process_cpu_seconds();
        let summary =
            run_samples(&sweep, fmus, 0..sweep.len(), threads, &mut |row| writer.write(&row), &mut |_, _| {})?;
        let cpu = process_cpu_seconds().zip(cpu_before).map(|(after, before)| after - before);
        let rate = summary.samples as f64 / summary.wall_s;
        println!(
            "{threads} thread(s): {:.1} s wall-clock, {rate:.3} samples/s ({:.0} x real time); CPU {} s per sample",
            summary.wall_s,
            summary.simulated_s / summary.wall_s,
            cpu.map_or("?".to_string(), |c| format!("{:.3}", c / summary.samples as f64))
        );
        rates.push(rate);
        outputs.push(writer.into_inner()?);
    }
    println!(
        "2 threads / 1 thread: {:.2} x; rows identical: {}",
        rates[1] / rates[0],
        if outputs[0] == outputs[1] { "yes" } else { "NO" }
    );
    if outputs[0] != outputs[1] {
        bail!("one and two threads gave different rows");
    }
    Ok(())
}

/// The CPU time this process has used, user and system, s (Linux; `None` elsewhere). With the
/// wall-clock time it tells whether a shared machine gave the threads their cores: the CPU time
/// per sample is what the work costs, whoever else runs.
fn process_cpu_seconds() -> Option<f64> {
    let stat = std::fs::read_to_string("/proc/self/stat").ok()?;
    // The fields after the command name, which is in parentheses and may hold spaces.
    let fields: Vec<&str> = stat.rsplit_once(')')?.1.split_whitespace().collect();
    let ticks: f64 = fields.get(11)?.parse::<f64>().ok()? + fields.get(12)?.parse::<f64>().ok()?;
    // The kernel's USER_HZ is 100 on every Linux architecture the project builds for.
    Some(ticks / 100.0)
}

/// The `antenna` binary beside this one.
fn antenna_binary() -> anyhow::Result<std::path::PathBuf> {
    let path = std::env::current_exe()?.with_file_name("antenna");
    if !path.is_file() {
        bail!("{} is missing: cargo build --release -p antenna-cli --bin antenna", path.display());
    }
    Ok(path)
}

/// Runs `antenna sweep <spec> <extra>` and returns its wall-clock time and its stderr.
fn sweep_process(spec: &SweepSpec, extra: &[&str], out: &std::path::Path) -> anyhow::Result<(f64, String)> {
    let started = Instant::now();
    let output = std::process::Command::new(antenna_binary()?)
        .arg("sweep")
        .args(spec.to_args())
        .args(extra)
        .args(["--no-build", "--out"])
        .arg(out)
        .output()?;
    let wall = started.elapsed().as_secs_f64();
    let stderr = String::from_utf8_lossy(&output.stderr).into_owned();
    if !output.status.success() {
        bail!("antenna sweep failed: {stderr}");
    }
    Ok((wall, stderr + &String::from_utf8_lossy(&output.stdout)))
}

/// The peak resident memory of a one-thread sweep process: what each worker of the distributed
/// engine runs (its batch's rows stream to disk, so it does not grow with the samples).
fn sweep_memory(spec: &SweepSpec) -> anyhow::Result<()> {
    let out = std::env::temp_dir().join(format!("antenna-bench-sweep-{}", std::process::id()));
    let (_, log) = sweep_process(spec, &["--threads", "1", "--batch", "0/1"], &out)?;
    let _ = std::fs::remove_dir_all(&out);
    let memory = log.split("peak memory ").nth(1).and_then(|rest| rest.split(' ').next()).unwrap_or("?");
    println!("peak memory of a one-thread sweep process (one worker's batch): {memory} MB");
    Ok(())
}

/// The same sweep through the local pool (two threads) and through a local Dask cluster of two
/// workers (one thread each), both as processes started from here.
fn sweep_distributed(spec: &SweepSpec) -> anyhow::Result<()> {
    let base = std::env::temp_dir().join(format!("antenna-bench-distributed-{}", std::process::id()));
    let (local, _) = sweep_process(spec, &["--threads", "2"], &base.join("local"))?;
    let (distributed, log) = sweep_process(spec, &["--engine", "dask", "--address", "local"], &base.join("dask"))?;
    let same =
        std::fs::read(base.join("local").join("sweep.csv"))? == std::fs::read(base.join("dask").join("sweep.csv"))?;
    let _ = std::fs::remove_dir_all(&base);
    println!(
        "local pool, 2 threads: {local:.1} s; Dask, local cluster of 2 workers: {distributed:.1} s in all ({:+.1} %), rows identical: {}",
        100.0 * (distributed / local - 1.0),
        if same { "yes" } else { "NO" }
    );
    if let Some(line) = log.lines().find(|l| l.contains("batches on")) {
        println!("  the driver: {line}");
    }
    Ok(())
}
