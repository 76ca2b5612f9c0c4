//! Speed benchmark of the coupled antenna through the C ABI: simulated seconds per wall-clock
//! second of the Rust master (and, with `--fmpy`, of the fmpy master), and the cost of one
//! fmi2DoStep of each FMU and of one fmi2GetReal/fmi2SetReal call. Figures go into the README.
//!
//! Usage: `cargo run --release -p antenna-cli --bin bench [-- --seconds 300] [--fmpy]`.

use std::process::ExitCode;
use std::time::Instant;

use antenna_sim::scenario::{optimal_wind, tracking_table};
use antenna_sim::{AntennaConfig, CoupledAntenna, FmuSet};
use fmu_import::Fmu;

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let seconds: f64 = args
        .iter()
        .position(|a| a == "--seconds")
        .and_then(|i| args.get(i + 1))
        .and_then(|s| s.parse().ok())
        .unwrap_or(300.0);
    let fmus = match FmuSet::open(&antenna_fmus::fmu_directory()) {
        Ok(f) => f,
        Err(e) => {
            eprintln!("cannot open the FMUs (package them first): {e}");
            return ExitCode::FAILURE;
        }
    };
    match run(&fmus, seconds, args.iter().any(|a| a == "--fmpy")) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("{e}");
            ExitCode::FAILURE
        }
    }
}

fn run(fmus: &FmuSet, seconds: f64, fmpy: bool) -> Result<(), String> {
    println!("## Coupled antenna, Rust master through the C ABI");
    let table = tracking_table((30.0, 45.0), (0.004, 0.004), seconds + 1.0);
    let config = AntennaConfig { wind: optimal_wind(30.0, 7), ..AntennaConfig::default() };
    let mut best = f64::INFINITY;
    for _ in 0..3 {
        let mut antenna = CoupledAntenna::new(fmus, &config, &table).map_err(|e| e.to_string())?;
        let steps = (seconds / config.step_s).round() as u64;
        let started = Instant::now();
        for _ in 0..steps {
            antenna.step(&table, None).map_err(|e| e.to_string())?;
        }
        best = best.min(started.elapsed().as_secs_f64());
    }
    println!(
        "sidereal tracking at 45 deg, optimal wind, 1 kHz, 5 FMUs: {seconds:.0} s simulated in {best:.3} s = {:.0} x real time ({:.0} ns per 1 ms communication step, best of 3)",
        seconds / best,
        best / seconds * 1e-3 * 1e9 * 1e3 / 1e3
    );

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

    if fmpy {
        println!("\n## Coupled antenna, fmpy master (tests/python/coupled_master.py)");
        let root = antenna_fmus::workspace_root();
        let output = std::process::Command::new(root.join(".venv/bin/python"))
            .arg(root.join("tests/python/coupled_master.py"))
            .args(["--bench", &format!("{seconds}")])
            .output()
            .map_err(|e| format!("cannot run the fmpy master (set up .venv first): {e}"))?;
        print!("{}", String::from_utf8_lossy(&output.stdout));
        if !output.status.success() {
            return Err(format!("fmpy master failed: {}", String::from_utf8_lossy(&output.stderr)));
        }
    }
    Ok(())
}

fn do_step_cost(fmu: &Fmu, inputs: &[(&str, f64)]) -> Result<f64, String> {
    let mut best = f64::INFINITY;
    for _ in 0..3 {
        let mut instance = fmu.instantiate("bench", false).map_err(|e| e.to_string())?;
        instance.setup_experiment(0.0, None).map_err(|e| e.to_string())?;
        instance.enter_initialization_mode().map_err(|e| e.to_string())?;
        for (name, value) in inputs {
            let vr = fmu.description.vr(name).map_err(|e| e.to_string())?;
            instance.set_real(&[vr], &[*value]).map_err(|e| e.to_string())?;
        }
        instance.exit_initialization_mode().map_err(|e| e.to_string())?;
        let n = 200_000u64;
        // Warm the caches first: the plants discretise lazily.
        for k in 0..1000 {
            instance.do_step(k as f64 * 1e-3, 1e-3).map_err(|e| e.to_string())?;
        }
        let started = Instant::now();
        for k in 1000..1000 + n {
            instance.do_step(k as f64 * 1e-3, 1e-3).map_err(|e| e.to_string())?;
        }
        best = best.min(started.elapsed().as_secs_f64() / n as f64 * 1e9);
    }
    Ok(best)
}

fn get_real_cost(fmu: &Fmu) -> Result<f64, String> {
    let mut instance = fmu.instantiate("bench", false).map_err(|e| e.to_string())?;
    instance.initialize(0.0, &[]).map_err(|e| e.to_string())?;
    let vrs = fmu
        .description
        .vrs(&[
            "axis.encoder_position",
            "axis.position",
            "motor1.speed",
            "motor2.speed",
            "motor1.current",
            "motor2.current",
        ])
        .map_err(|e| e.to_string())?;
    let mut out = [0.0; 6];
    let n = 1_000_000;
    let started = Instant::now();
    for _ in 0..n {
        instance.get_real(&vrs, &mut out).map_err(|e| e.to_string())?;
    }
    Ok(started.elapsed().as_secs_f64() / n as f64 * 1e9)
}
