//! Draws the wind unit's spectra and prints the numbers behind them:
//!
//! * `docs/figures/wind-filters.png`: Eq. 2 at 3 and 9.5 m/s against the paper's H3/H10 and our
//!   filters' exact responses over 0.001-30 rad/s, with the dB errors and the +-0.5 dB goal;
//! * `docs/figures/wind-psd-2h.png`: the Welch spectrum of a 2 h record generated through the
//!   packaged `Wind.fmu` at each speed, with its 95 % band, against Eq. 2 and the exact filter;
//! * the largest error of our filter against Eq. 2 over 0.001-30 rad/s at 0.5-25 m/s, and how
//!   the paper's filters compare.
//!
//! The figures go into `out/wind-spectra/` or the folder given (`cargo xtask docs`: docs/figures). Package the FMUs first (`cargo
//! xtask package`). The records are seeded, so the figures are reproducible for a given build.

use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Instant;

use anyhow::Context;
use clap::Parser;

use antenna_sim::wind_spectra::{
    filter_error, filter_figure, generate_through_fmu, paper_shape, psd_comparison, psd_figure, save, ERROR_SPEEDS_M_S,
    GOAL_DB, OMEGA_RANGE_RAD_S,
};
use fmu_import::Fmu;

/// The generated records: 2 h (the "at least 2 h") at 10 ms steps, whose Nyquist
/// frequency (314 rad/s) is far above the 30 rad/s of interest, so aliasing stays out of the
/// figure's band; Welch segments of 600 s reach down to 0.01 rad/s with 23 averaged segments.
const DURATION_S: f64 = 7200.0;
const STEP_S: f64 = 0.01;
const SEGMENT_S: f64 = 600.0;
/// One seed per speed: the filter is self-similar in v_m, so one seed would give both records
/// the same pattern of slow eddies on a stretched time axis.
const RECORDS: [(f64, i32); 2] = [(3.0, 1), (9.5, 2)];

/// Draws the wind unit's spectra (the filters against Eq. 2, and 2 h records generated through
/// Wind.fmu) and prints the numbers behind them.
#[derive(Parser)]
// `about` is left to this doc comment: the crate description is that of all the commands.
#[command(version, long_about = None)]
struct Cli {
    /// Folder for the figures [default: out/wind-spectra; `cargo xtask docs` writes docs/figures].
    #[arg(value_name = "OUTPUT FOLDER")]
    output: Option<PathBuf>,
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let output = cli.output.unwrap_or_else(|| antenna_fmus::workspace_root().join("out").join("wind-spectra"));
    match run(&output) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("wind-spectra: error: {e:#}");
            ExitCode::from(2)
        }
    }
}

fn run(output: &Path) -> anyhow::Result<()> {
    println!(
        "Our Davenport filter against Eq. 2 over {}-{} rad/s (z = 10 m, z0 = 0.4 m; 4001 log-spaced points):",
        OMEGA_RANGE_RAD_S.0, OMEGA_RANGE_RAD_S.1
    );
    println!("| v_m (m/s) | max |error| (dB) | at omega (rad/s) |");
    println!("| --- | --- | --- |");
    let mut worst: f64 = 0.0;
    for v in ERROR_SPEEDS_M_S {
        let e = filter_error(v, 4001);
        worst = worst.max(e.max_abs_db);
        println!("| {v} | {:.4} | {:.3} |", e.max_abs_db, e.at_omega);
    }
    println!("Largest: {worst:.4} dB (goal {GOAL_DB} dB).\n");
    println!("The paper's filters against Eq. 2:");
    for v in [3.0, 9.5] {
        let s = paper_shape(v)?;
        println!(
            "{} ({v} m/s): variance {:+.2} dB of 6 kappa v^2; mean ratio over 0.01-10 rad/s {:+.2} dB; shape about it {:+.2}/{:+.2} dB; DC gain {:+.1} dB",
            s.name, s.variance_ratio_db, s.mean_db, s.shape_db.0, s.shape_db.1, s.dc_gain_db
        );
    }
    let filters = output.join("wind-filters.png");
    save(&filter_figure()?, &filters)?;
    println!("wrote {}\n", filters.display());

    let path = antenna_fmus::fmu_path("Wind");
    let fmu = Fmu::open(&path)
        .with_context(|| format!("cannot open {} (package the FMUs first: cargo xtask package)", path.display()))?;
    let mut comparisons = Vec::new();
    for (v, seed) in RECORDS {
        let record =
            generate_through_fmu(&fmu, v, seed, STEP_S, DURATION_S).with_context(|| format!("Wind.fmu at {v} m/s"))?;
        let started = Instant::now();
        let c = psd_comparison(&record, SEGMENT_S, 0.95).with_context(|| format!("the spectrum at {v} m/s"))?;
        println!(
            "{v} m/s: {} steps of {} s through Wind.fmu in {:.2} s (sigma {:.4} m/s); record variance {:.4} x 6 kappa v^2 (1 sigma {:.1} % for 2 h); \
             {} of {} bands miss Eq. 2's expected estimate with their 95 % interval; analysis {:.2} s",
            record.gust.len(),
            record.step,
            record.wall_s,
            record.sigma,
            c.variance_ratio,
            100.0 * c.variance_scatter,
            c.outside,
            c.estimate.len(),
            started.elapsed().as_secs_f64()
        );
        comparisons.push(c);
    }
    let psd = output.join("wind-psd-2h.png");
    save(&psd_figure(&comparisons), &psd)?;
    println!("wrote {}", psd.display());
    Ok(())
}
