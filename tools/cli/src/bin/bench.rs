//! Speed benchmark of the coupled antenna through the C ABI: simulated seconds per wall-clock
//! second of the Rust master (and, with `--fmpy`, of the fmpy master), and the cost of one
//! fmi2DoStep of each FMU and of one fmi2GetReal/fmi2SetReal call. Figures go into the README.
//!
//! Usage: `cargo run --release -p antenna-cli --bin bench -- [--seconds 300] [--fmpy]`.

use std::process::ExitCode;
use std::time::Instant;

use anyhow::{bail, Context};
use clap::Parser;

use antenna_sim::scenario::{optimal_wind, tracking_table};
use antenna_sim::{AntennaConfig, CoupledAntenna, FmuSet};
use fmu_import::Fmu;

/// Speed benchmark of the coupled antenna through the C ABI, and of single FMI calls.
#[derive(Parser)]
// `about` is left to this doc comment: the crate description is that of all the commands.
#[command(version, long_about = None)]
struct Cli {
    /// Simulated seconds of the coupled run.
    #[arg(long, default_value_t = 300.0, value_parser = positive_seconds, allow_hyphen_values = true)]
    seconds: f64,
    /// Also time the fmpy master (tests/python/coupled_master.py, in .venv).
    #[arg(long)]
    fmpy: bool,
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
    coupled(&fmus, cli.seconds)?;
    single_calls(&fmus)?;
    if cli.fmpy {
        fmpy_master(cli.seconds)?;
    }
    Ok(())
}

/// The coupled antenna, Rust master: simulated seconds per wall-clock second, best of 3.
fn coupled(fmus: &FmuSet, seconds: f64) -> anyhow::Result<()> {
    println!("## Coupled antenna, Rust master through the C ABI");
    let table = tracking_table((30.0, 45.0), (0.004, 0.004), seconds + 1.0);
    let config = AntennaConfig { wind: optimal_wind(30.0, 7), ..AntennaConfig::default() };
    let mut best = f64::INFINITY;
    for _ in 0..3 {
        let mut antenna = CoupledAntenna::new(fmus, &config, &table)?;
        let steps = (seconds / config.step_s).round() as u64;
        let started = Instant::now();
        for _ in 0..steps {
            antenna.step(&table, None)?;
        }
        best = best.min(started.elapsed().as_secs_f64());
    }
    println!(
        "sidereal tracking at 45 deg, optimal wind, 1 kHz, 5 FMUs: {seconds:.0} s simulated in {best:.3} s = {:.0} x real time ({:.0} ns per 1 ms communication step, best of 3)",
        seconds / best,
        best / seconds * 1e-3 * 1e9 * 1e3 / 1e3
    );
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

/// The coupled antenna, fmpy master.
fn fmpy_master(seconds: f64) -> anyhow::Result<()> {
    println!("\n## Coupled antenna, fmpy master (tests/python/coupled_master.py)");
    let root = antenna_fmus::workspace_root();
    let output = std::process::Command::new(root.join(".venv/bin/python"))
        .arg(root.join("tests/python/coupled_master.py"))
        .args(["--bench", &format!("{seconds}")])
        .output()
        .context("cannot run the fmpy master (set up .venv first)")?;
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
