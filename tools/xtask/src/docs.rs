//! `cargo xtask docs`: regenerates the generated parts of `docs/` (the requirement report, the
//! figures, the validation results) by running the project's own commands with `docs/` as their
//! output. The user commands never write into `docs/` by themselves; this task is the one place
//! that does, so that what a document shows is what the committed code produces.

use std::path::{Path, PathBuf};
use std::process::Command;

use anyhow::{bail, Context};

/// A generated part of `docs/`, regenerated as a whole.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum DocsPart {
    /// docs/results/requirement-report/: the main job's report, CSV and figures, with the
    /// pointing-model table derived from the model and applied (about 6 min).
    Report,
    /// The Bode plots of the plants and velocity loops, the wind filters and admittance.
    Figures,
    /// The servo figures with the structure in the loops (the margins' Bode and Nichols plots,
    /// the wind-to-beam responses), from the tests that check them.
    Servo,
    /// The measured wind record's spectrum against Eq. 2 (docs/figures/measured-wind-psd.png).
    MeasuredWind,
    /// docs/results/validation-*.md and their figures: the validation suite, the holdout suites
    /// and the KUKA axes (long: 20-40 min on two cores).
    Validation,
    /// docs/results/validation-limits.md and .csv: the detection limits checked by injection
    /// (`validate limits` with the equation error alone, on the suite's sensors and the sensor
    /// variants whose errors are taken out before the search, the offset, the unbalance, the
    /// Coulomb level and the backlash, each into the clean log's excitation and into other
    /// excitations; about 30 min on two idle cores).
    Limits,
    /// docs/results/validation-second-generator.md: the suite of the second, separately
    /// written generator (`secondgen --suite`, four seeds), scored by `validate suite` as the
    /// holdouts are (about 5 min on two idle cores).
    SecondGenerator,
}

/// The arguments of `validate limits` that docs/results/validation-limits.md is written with.
/// The sensor variants are the holdout suites' sensor variants (issue 16's coarse load encoder
/// and noiseless current, issue 34's encoder error, skews, drifting tacho and 2 kHz noiseless
/// current); on the equation error alone the encoder skew is found after the search with the
/// equation-error model, as the current skew before it.
pub const LIMITS_ARGS: [&str; 8] = [
    "limits",
    "--variants",
    "suite,load-encoder-error,skews,drifting-tacho,coarse-load-encoder,noiseless-current,2khz-noiseless-current",
    "--kinds",
    "torque_offset,unbalance,coulomb,backlash",
    "--injections",
    "10",
    "--no-fmu",
];

impl DocsPart {
    /// Every part, in the order they run.
    pub const ALL: [DocsPart; 7] = [
        DocsPart::Report,
        DocsPart::Figures,
        DocsPart::Servo,
        DocsPart::MeasuredWind,
        DocsPart::Validation,
        DocsPart::Limits,
        DocsPart::SecondGenerator,
    ];
}

/// `cargo run --release -p PACKAGE --bin BIN -- ARGS` (or `--example`), from the workspace root.
fn run_cargo(root: &Path, what: &[&str], args: &[&str]) -> anyhow::Result<()> {
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".to_string());
    let mut command = Command::new(cargo);
    command.current_dir(root).args(["run", "--release", "--quiet"]).args(what);
    if !args.is_empty() {
        command.arg("--").args(args);
    }
    let shown = format!("cargo run --release {} -- {}", what.join(" "), args.join(" "));
    println!("xtask docs: {shown}");
    let status = command.status().with_context(|| format!("cannot start {shown}"))?;
    if !status.success() {
        bail!("{shown} failed ({status})");
    }
    Ok(())
}

/// Runs the named modules of `antenna-tests`'s integration tests, which write their figures into
/// `out/`.
fn run_tests(root: &Path, modules: &[&str]) -> anyhow::Result<()> {
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".to_string());
    let filters: Vec<String> = modules.iter().map(|m| format!("{m}::")).collect();
    let mut command = Command::new(cargo);
    command
        .current_dir(root)
        .args(["test", "--release", "--quiet", "-p", "antenna-tests", "--test", "integration", "--"])
        .args(&filters);
    println!("xtask docs: cargo test --release -p antenna-tests --test integration -- {}", filters.join(" "));
    let status = command.status().context("cannot start cargo test")?;
    if !status.success() {
        bail!("the tests that draw the servo figures failed ({status})");
    }
    Ok(())
}

/// Copies `from` (relative to the root) to `to` (relative to the root).
fn copy(root: &Path, from: &str, to: &str) -> anyhow::Result<()> {
    let (from, to): (PathBuf, PathBuf) = (root.join(from), root.join(to));
    std::fs::copy(&from, &to).with_context(|| format!("cannot copy {} to {}", from.display(), to.display()))?;
    println!("xtask docs: {}", to.display());
    Ok(())
}

/// Regenerates `parts` of `docs/` under the workspace `root`. The FMUs are packaged first by
/// the caller (the commands run the packaged units).
pub fn regenerate(root: &Path, parts: &[DocsPart]) -> anyhow::Result<()> {
    let figures = "docs/figures";
    for part in parts {
        match part {
            DocsPart::Report => {
                // The pointing-model table from its own calm and steady-wind runs, then the
                // report with it applied beside the rows without it.
                let table = "docs/results/requirement-report/pointing-model.csv";
                run_cargo(root, &["-p", "antenna-cli", "--bin", "antenna"], &["pointing-model", "--out", table])?;
                run_cargo(
                    root,
                    &["-p", "antenna-cli", "--bin", "antenna"],
                    &["--out", "docs/results/requirement-report", "--pointing-model", table],
                )?;
            }
            DocsPart::Figures => {
                for bin in ["plant-bode", "velocity-bode", "wind-spectra"] {
                    run_cargo(root, &["-p", "antenna-cli", "--bin", bin], &[figures])?;
                }
                run_cargo(root, &["-p", "antenna-cli", "--bin", "plant-bode"], &[figures, "--structure"])?;
                run_cargo(
                    root,
                    &["-p", "fmu-wind", "--example", "admittance_figure"],
                    &["docs/figures/wind-admittance.png"],
                )?;
            }
            DocsPart::Servo => {
                run_tests(root, &["loop_margins", "structure_servo"])?;
                for name in [
                    "servo-open-loops-azimuth-bode.png",
                    "servo-open-loops-azimuth-nichols.png",
                    "servo-open-loops-elevation-bode.png",
                    "servo-open-loops-elevation-nichols.png",
                    "structure-servo-45deg.png",
                    "structure-servo-elevation.png",
                ] {
                    copy(root, &format!("out/{name}"), &format!("{figures}/{name}"))?;
                }
            }
            DocsPart::MeasuredWind => {
                run_cargo(
                    root,
                    &["-p", "antenna-cli", "--bin", "windfit"],
                    &[
                        "tests/data/measured/sonic-anemometer-20hz/wind_20hz.csv",
                        "--height-m",
                        "7.11",
                        "--out-dir",
                        "out/windfit",
                    ],
                )?;
                copy(root, "out/windfit/psd.png", "docs/figures/measured-wind-psd.png")?;
            }
            DocsPart::Validation => {
                run_cargo(
                    root,
                    &["-p", "antenna-cli", "--bin", "validate"],
                    &["suite", "--generate", "--docs", "docs"],
                )?;
                run_cargo(root, &["-p", "antenna-cli", "--bin", "validate"], &["holdout", "--docs", "docs"])?;
            }
            DocsPart::Limits => limits(root)?,
            DocsPart::SecondGenerator => second_generator(root)?,
        }
    }
    Ok(())
}

/// The commit the documents are written from (`git rev-parse --short HEAD`), or "unknown"
/// outside a git checkout.
fn commit(root: &Path) -> String {
    Command::new("git")
        .current_dir(root)
        .args(["rev-parse", "--short", "HEAD"])
        .output()
        .ok()
        .filter(|o| o.status.success())
        .map(|o| String::from_utf8_lossy(&o.stdout).trim().to_string())
        .unwrap_or_else(|| "unknown".to_string())
}

/// `validate limits` into out/validation-limits/, its table and CSV copied under
/// docs/results/ with a header naming the command and the commit.
fn limits(root: &Path) -> anyhow::Result<()> {
    let header = format!(
        "Regenerated by `cargo xtask docs --only limits`: `validate {}` at commit {}.",
        LIMITS_ARGS.join(" "),
        commit(root)
    );
    let mut args: Vec<&str> = LIMITS_ARGS.to_vec();
    args.extend(["--out", "out/validation-limits", "--header", &header]);
    run_cargo(root, &["-p", "antenna-cli", "--bin", "validate"], &args)?;
    copy(root, "out/validation-limits/limits.md", "docs/results/validation-limits.md")?;
    copy(root, "out/validation-limits/limits.csv", "docs/results/validation-limits.csv")
}

/// The seeds of the second generator's suite in docs/results/.
const SECOND_GENERATOR_SEEDS: &str = "11,12,13,14";

/// `secondgen --suite` into out/second-generator/ and `validate suite` on it; its results go
/// to docs/results/validation-second-generator.md under a header naming the commands and the
/// commit.
fn second_generator(root: &Path) -> anyhow::Result<()> {
    let dir = "out/second-generator";
    let results = format!("{dir}/results");
    run_cargo(
        root,
        &["-p", "antenna-truth", "--bin", "secondgen"],
        &["--suite", dir, "--seeds", SECOND_GENERATOR_SEEDS],
    )?;
    run_cargo(root, &["-p", "antenna-cli", "--bin", "validate"], &["suite", dir, "--out", &results])?;
    let path = root.join(&results).join("results.md");
    let body = std::fs::read_to_string(&path).with_context(|| format!("cannot read {}", path.display()))?;
    let text = format!(
        "# The second generator's suite (generated)\n\nRegenerated by `cargo xtask docs --only second-generator` at commit {}: `secondgen --suite {dir} --seeds {SECOND_GENERATOR_SEEDS}` (`tools/truth/src/second.rs`, a generator written apart from the truth generator: its own controller, excitation, motion, LuGre bristles and plant numbers) and `validate suite {dir}`, scored as the holdouts are. Reading: docs/validation.md, \"A second, separately written generator\".\n\n{body}",
        commit(root)
    );
    let target = root.join("docs/results/validation-second-generator.md");
    std::fs::write(&target, text).with_context(|| format!("cannot write {}", target.display()))
}
