//! Runs the seed paper's frequency-domain identification (Figs. 6 and 8) on the packaged plant
//! FMUs and writes the Bode figures for the README, measured H1 against the corrected Eq. 1:
//! `plant-bode-azimuth-15deg.png`, `plant-bode-elevation-15deg.png` and the summary
//! `plant-bode.md`, into `out/plant-bode/` or the folder given (`cargo xtask docs` regenerates docs/figures).
//!
//! Package the FMUs first (`cargo xtask package`). The excitation is seeded, so the figures
//! are reproducible for a given build.

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::{bail, Context};
use clap::Parser;

use antenna_sim::frequency_response::plant::{
    identify, markdown_summary, IdentificationConfig, FIGURE_MAX_FREQUENCY_HZ,
};
use antenna_sim::frequency_response::Axis;

/// Identifies the plant FMUs' frequency responses (the seed paper's Figs. 6 and 8) and writes
/// the Bode figures and their summary.
#[derive(Parser)]
// `about` is left to this doc comment: the crate description is that of all the commands.
#[command(version, long_about = None)]
struct Cli {
    /// Folder for the figures and plant-bode.md [default: out/plant-bode; `cargo xtask docs` writes docs/figures].
    #[arg(value_name = "OUTPUT FOLDER")]
    output: Option<PathBuf>,
    /// Couple the packaged Structure FMU both ways, as the antenna does: the figures
    /// (`plant-bode-<axis>-15deg-structure.png`) show the structural mode as a second
    /// anti-resonance beside the rigid Eq. 1, and its trough is printed against the prediction.
    #[arg(long)]
    structure: bool,
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    match run(cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("plant-bode: error: {e:#}");
            ExitCode::from(2)
        }
    }
}

fn run(cli: Cli) -> anyhow::Result<()> {
    let output = cli.output.unwrap_or_else(|| antenna_fmus::workspace_root().join("out").join("plant-bode"));
    std::fs::create_dir_all(&output).with_context(|| format!("cannot create {}", output.display()))?;
    let mut results = Vec::new();
    for axis in Axis::BOTH {
        let fmu = antenna_fmus::fmu_path(axis.model_identifier());
        if !fmu.is_file() {
            bail!("{} is missing: package the FMUs first (cargo xtask package)", fmu.display());
        }
        // With the structure, 40 s segments (0.025 Hz bins) resolve its 1.5 %-damped trough.
        let config = if cli.structure {
            IdentificationConfig { structure: true, segment_s: 40.0, ..IdentificationConfig::paper(axis) }
        } else {
            IdentificationConfig::paper(axis)
        };
        let result = identify(&fmu, &config).with_context(|| format!("{} identification failed", axis.name()))?;
        if !result.linear_regime_held() {
            bail!(
                "{}: the experiment left the linear regime (smallest motor speed {:.3} rad/s, {} flank changes); the figure would not show Eq. 1",
                axis.name(),
                result.min_motor_speed_rad_per_s,
                result.flank_changes
            );
        }
        let suffix = if cli.structure { "-structure" } else { "" };
        let name = format!("plant-bode-{}-{}deg{suffix}.png", axis.name(), config.elevation_deg);
        let path = output.join(&name);
        result.figure(FIGURE_MAX_FREQUENCY_HZ).save_png(&path)?;
        let s = result.summary();
        println!(
            "{}: trough {:.3} Hz measured, {:.3} Hz analytic ({:+.2} %); max magnitude error {:.2} dB at {:.1} Hz ({:.2} dB from bin 5) over {} bins with coherence > 0.9; simulation {:.2} s, analysis {:.2} s; wrote {}",
            axis.name(),
            s.measured_trough.frequency_hz,
            s.analytic_trough.frequency_hz,
            100.0 * s.trough_error,
            s.max_db_error,
            s.max_db_error_at_hz,
            s.max_db_error_above_leakage,
            s.coherent_bins,
            result.simulation_wall_s,
            result.analysis_wall_s,
            path.display()
        );
        if let (Some(predicted), Some(trough)) = (result.structural, result.structural_trough()) {
            println!(
                "{}: structural anti-resonance {:.3} Hz measured, {:.3} Hz predicted ({:+.2} %; the mode clamped at the encoder {:.2} Hz)",
                axis.name(),
                trough.frequency_hz,
                predicted.predicted_hz,
                100.0 * (trough.frequency_hz / predicted.predicted_hz - 1.0),
                predicted.clamped_hz
            );
        }
        results.push((result, name));
    }
    let table: Vec<_> = results.iter().map(|(r, name)| (r, name.as_str())).collect();
    let summary = output.join(if cli.structure { "plant-bode-structure.md" } else { "plant-bode.md" });
    std::fs::write(&summary, markdown_summary(&table))
        .with_context(|| format!("cannot write {}", summary.display()))?;
    println!("wrote {}", summary.display());
    Ok(())
}
