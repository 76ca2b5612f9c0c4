//! Runs the seed paper's frequency-domain identification (Figs. 6 and 8) on the packaged plant
//! FMUs and writes the Bode figures for the README, measured H1 against the corrected Eq. 1:
//! `docs/figures/plant-bode-azimuth-15deg.png`, `docs/figures/plant-bode-elevation-15deg.png`
//! and the summary `docs/figures/plant-bode.md`.
//!
//! Usage: `cargo run --release -p antenna-cli --bin plant-bode [-- <output folder>]`, after
//! packaging (`cargo run --release -p xtask --bin package`). The excitation is seeded,
//! so the figures are reproducible for a given build.

use std::path::PathBuf;
use std::process::ExitCode;

use antenna_sim::plant_identification::{
    identify, markdown_summary, Axis, IdentificationConfig, FIGURE_MAX_FREQUENCY_HZ,
};

fn main() -> ExitCode {
    let output = std::env::args()
        .nth(1)
        .map(PathBuf::from)
        .unwrap_or_else(|| antenna_fmus::workspace_root().join("docs").join("figures"));
    if let Err(e) = std::fs::create_dir_all(&output) {
        eprintln!("cannot create {}: {e}", output.display());
        return ExitCode::FAILURE;
    }
    let mut results = Vec::new();
    for axis in [Axis::Azimuth, Axis::Elevation] {
        let fmu = antenna_fmus::fmu_path(axis.model_identifier());
        if !fmu.is_file() {
            eprintln!(
                "{} is missing: package the FMUs first (cargo run --release -p xtask --bin package)",
                fmu.display()
            );
            return ExitCode::FAILURE;
        }
        let config = IdentificationConfig::paper(axis);
        let result = match identify(&fmu, &config) {
            Ok(r) => r,
            Err(e) => {
                eprintln!("{} identification failed: {e}", axis.name());
                return ExitCode::FAILURE;
            }
        };
        if !result.linear_regime_held() {
            eprintln!(
                "{}: the experiment left the linear regime (smallest motor speed {:.3} rad/s, {} flank changes); the figure would not show Eq. 1",
                axis.name(),
                result.min_motor_speed_rad_per_s,
                result.flank_changes
            );
            return ExitCode::FAILURE;
        }
        let name = format!("plant-bode-{}-{}deg.png", axis.name(), config.elevation_deg);
        let path = output.join(&name);
        if let Err(e) = result.figure(FIGURE_MAX_FREQUENCY_HZ).save_png(&path) {
            eprintln!("cannot write {}: {e}", path.display());
            return ExitCode::FAILURE;
        }
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
        results.push((result, name));
    }
    let table: Vec<_> = results.iter().map(|(r, name)| (r, name.as_str())).collect();
    let summary = output.join("plant-bode.md");
    if let Err(e) = std::fs::write(&summary, markdown_summary(&table)) {
        eprintln!("cannot write {}: {e}", summary.display());
        return ExitCode::FAILURE;
    }
    println!("wrote {}", summary.display());
    ExitCode::SUCCESS
}
