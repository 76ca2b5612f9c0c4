//! Identifies the closed velocity loop of each axis like the seed paper's Figs. 7 and 9 (the
//! controller FMU in velocity mode on the plant FMU, white-noise velocity command on a constant
//! speed, H1 and coherence) and draws it against the analytic closed loop:
//! `velocity-loop-bode-azimuth-15deg.png` and `velocity-loop-bode-elevation-15deg.png`, into
//! `out/velocity-bode/` or the folder given (`cargo xtask docs`: docs/figures). Prints the -3 dB bandwidths, measured and analytic (the
//! paper: 10-15 Hz), and the largest magnitude and phase differences.
//!
//! Package the FMUs first (`cargo xtask package`). The excitation is seeded, so the figures
//! are reproducible for a given build.

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::{bail, Context};
use clap::Parser;

use antenna_sim::frequency_response::velocity_loop::{identify_velocity_loop, VelocityBodeConfig};
use antenna_sim::frequency_response::{Axis, MeasuredResponse};

/// Upper end of the figures, Hz: past the drive's anti-resonance (19-22 Hz) and resonance, as
/// the paper's figures.
const FIGURE_MAX_FREQUENCY_HZ: f64 = 100.0;

/// Identifies the closed velocity loop of each axis on the controller and plant FMUs (the seed
/// paper's Figs. 7 and 9) and writes the Bode figures.
#[derive(Parser)]
// `about` is left to this doc comment: the crate description is that of all the commands.
#[command(version, long_about = None)]
struct Cli {
    /// Folder for the figures [default: out/velocity-bode; `cargo xtask docs` writes docs/figures].
    #[arg(value_name = "OUTPUT FOLDER")]
    output: Option<PathBuf>,
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    match run(cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("velocity-bode: error: {e:#}");
            ExitCode::from(2)
        }
    }
}

fn run(cli: Cli) -> anyhow::Result<()> {
    let output = cli.output.unwrap_or_else(|| antenna_fmus::workspace_root().join("out").join("velocity-bode"));
    std::fs::create_dir_all(&output).with_context(|| format!("cannot create {}", output.display()))?;
    for axis in Axis::BOTH {
        let config = VelocityBodeConfig::paper(axis);
        let result = identify_velocity_loop(&antenna_fmus::fmu_directory(), &config)
            .with_context(|| format!("{} (package the FMUs first: cargo xtask package)", axis.name()))?;
        if !result.linear_regime_held() {
            bail!(
                "{}: the run left the linear regime (smallest motor speed {:.3} rad/s, largest torque {:.2} N m against the bias fade start {:.2}, {} flank changes)",
                axis.name(),
                result.min_motor_speed_rad_per_s,
                result.max_torque_nm,
                result.bias_fade_start_nm,
                result.flank_changes
            );
        }
        let path = output.join(format!("velocity-loop-bode-{}-{}deg.png", axis.name(), config.elevation_deg));
        result.figure(FIGURE_MAX_FREQUENCY_HZ).save_png(&path)?;
        let bins = result.coherent_bins(0.9, FIGURE_MAX_FREQUENCY_HZ);
        let (db, at) = result.max_magnitude_error_db(&bins);
        let show = |b: Option<f64>| b.map_or("none".to_string(), |b| format!("{b:.2} Hz"));
        println!(
            "{}: -3 dB bandwidth measured {}, analytic {} (model at {:.2} deg); largest difference {:.3} dB at {:.2} Hz and {:.2} deg over {} bins up to {} Hz with coherence > 0.9 (lowest coherence there {:.4}); smallest motor speed {:.2} rad/s, largest torque {:.2} N m; {} segments, simulation {:.2} s, analysis {:.2} s; wrote {}",
            axis.name(),
            show(result.measured_bandwidth_hz),
            show(result.analytic_bandwidth_hz),
            result.model_elevation_deg,
            db,
            at,
            result.max_phase_error_deg(&bins),
            bins.len(),
            FIGURE_MAX_FREQUENCY_HZ,
            bins.iter().map(|&i| result.coherence[i]).fold(1.0, f64::min),
            result.min_motor_speed_rad_per_s,
            result.max_torque_nm,
            result.segments,
            result.simulation_wall_s,
            result.analysis_wall_s,
            path.display()
        );
    }
    Ok(())
}
