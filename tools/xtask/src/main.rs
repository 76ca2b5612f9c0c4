//! The project's build tasks as one command, `cargo xtask <task>` (the alias is in
//! `.cargo/config.toml`): `package` builds and packages the FMUs into `target/fmu/`,
//! `package-into` into another folder, `codegen` regenerates or checks `modelDescription/`,
//! `pgo` records the profile the libraries are optimised with, `docs` regenerates the generated
//! parts of `docs/` (the only way they are written).
//!
//! Exit codes: 0 done; 1 a check that ran and failed (stale generated files, packages that
//! differ between two builds); 2 bad usage or a task that could not be carried out (with
//! `--pgo`, a profile that is missing or that another compiler recorded).

mod docs;

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::Context;
use clap::{Parser, Subcommand};

#[derive(Parser)]
#[command(version, about, long_about = None)]
struct Cli {
    #[command(subcommand)]
    task: Task,
}

#[derive(Subcommand)]
enum Task {
    /// Build the FMUs' shared libraries and write every .fmu into target/fmu/ (or $MEERKAT_FMU_DIR).
    Package {
        /// Also build from a copy of the sources at another path and check that every .fmu is
        /// byte-identical.
        #[arg(long)]
        reproducibility_check: bool,
        /// Optimise the libraries with the committed PGO profile (a release build on the
        /// compiler that recorded it: another compiler is refused, exit 2; a profile older than
        /// the code gives a warning). Off by default: the numbers are the same either way.
        #[arg(long)]
        pgo: bool,
        /// Also build win64 libraries (with Debian's rustc-web and rust-web-src, and mingw-w64)
        /// and write FMUs with both platforms' binaries into target/fmu-linux64-win64/.
        #[arg(long)]
        win64: bool,
    },
    /// Build the shared libraries in $CARGO_TARGET_DIR (or target/) and write every .fmu into DIR.
    PackageInto {
        /// The folder to write the .fmu files into.
        dir: PathBuf,
        /// As for `package`.
        #[arg(long)]
        pgo: bool,
    },
    /// Record the PGO profile of the FMUs' libraries (an instrumented build running the main
    /// job) into tools/xtask/pgo/fmus.profdata.zip. Needs `rustup component add llvm-tools`.
    Pgo,
    /// Package the FMUs and regenerate the generated parts of docs/ (the requirement report,
    /// the figures, the validation results) with the project's own commands.
    Docs {
        /// Only these parts (comma-separated); every part by default.
        #[arg(long, value_delimiter = ',', value_name = "PARTS")]
        only: Vec<docs::DocsPart>,
    },
    /// Regenerate modelDescription/*.xml from the variable tables.
    Codegen {
        /// Only check: list the stale files and exit 1 if there are any, writing nothing.
        #[arg(long)]
        check: bool,
    },
}

/// A task that ran to its end: either all was well, or a check found something.
enum Outcome {
    Done,
    CheckFailed,
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    match run(cli) {
        Ok(Outcome::Done) => ExitCode::SUCCESS,
        Ok(Outcome::CheckFailed) => ExitCode::from(1),
        Err(e) => {
            eprintln!("xtask: error: {e:#}");
            ExitCode::from(2)
        }
    }
}

fn run(cli: Cli) -> anyhow::Result<Outcome> {
    match cli.task {
        Task::Package { reproducibility_check, pgo, win64 } => {
            let outcome = package(reproducibility_check, pgo_choice(pgo))?;
            if win64 && matches!(outcome, Outcome::Done) {
                for path in xtask::package_win64().context("win64 packaging failed")? {
                    let size = std::fs::metadata(&path).map(|m| m.len()).unwrap_or(0);
                    println!("{} ({} bytes, linux64 and win64)", path.display(), size);
                }
            }
            Ok(outcome)
        }
        Task::PackageInto { dir, pgo } => {
            let target = std::env::var("CARGO_TARGET_DIR")
                .map(PathBuf::from)
                .unwrap_or_else(|_| antenna_fmus::workspace_root().join("target"));
            if let Some(problem) = xtask::build_libraries(&target, pgo_choice(pgo))?.profile_problem() {
                eprintln!("{problem}");
            }
            for path in xtask::package_all(&target, &dir)? {
                println!("{}", path.display());
            }
            Ok(Outcome::Done)
        }
        Task::Codegen { check } => codegen(check),
        Task::Docs { only } => {
            xtask::build_and_package(xtask::Pgo::Off).context("packaging failed")?;
            let parts = if only.is_empty() { docs::DocsPart::ALL.to_vec() } else { only };
            docs::regenerate(&antenna_fmus::workspace_root(), &parts)?;
            Ok(Outcome::Done)
        }
        Task::Pgo => {
            let archive = xtask::record_pgo_profile().context("recording the PGO profile failed")?;
            let size = std::fs::metadata(&archive).map(|m| m.len()).unwrap_or(0);
            println!("{} ({} bytes)", archive.display(), size);
            Ok(Outcome::Done)
        }
    }
}

fn pgo_choice(pgo: bool) -> xtask::Pgo {
    if pgo {
        xtask::Pgo::On
    } else {
        xtask::Pgo::Off
    }
}

fn package(reproducibility_check: bool, pgo: xtask::Pgo) -> anyhow::Result<Outcome> {
    let stale = xtask::codegen(true)?;
    if !stale.is_empty() {
        eprintln!("xtask: stale generated files (run `cargo xtask codegen`):");
        for s in stale {
            eprintln!("  {s}");
        }
        return Ok(Outcome::CheckFailed);
    }
    let packaged = xtask::build_and_package(pgo).context("packaging failed")?;
    let written = &packaged.files;
    for path in written {
        let size = std::fs::metadata(path).map(|m| m.len()).unwrap_or(0);
        println!("{} ({} bytes)", path.display(), size);
    }
    if reproducibility_check {
        let differing = xtask::reproducibility_differences(written, pgo).context("reproducibility check")?;
        if !differing.is_empty() {
            eprintln!("xtask: not reproducible: {} differ between the two builds", differing.join(", "));
            return Ok(Outcome::CheckFailed);
        }
        println!("reproducible: a build from another checkout path gives byte-identical .fmu files");
    }
    if let Some(problem) = packaged.build.profile_problem() {
        eprintln!("{problem}");
    } else if packaged.build.profile == xtask::ProfileUse::Used {
        println!("optimised with the committed PGO profile ({})", xtask::PGO_PROFILE_ARCHIVE);
    }
    Ok(Outcome::Done)
}

fn codegen(check: bool) -> anyhow::Result<Outcome> {
    let stale = xtask::codegen(check)?;
    if stale.is_empty() {
        println!("modelDescription/ is up to date");
        Ok(Outcome::Done)
    } else if check {
        eprintln!("xtask: stale generated files (run `cargo xtask codegen`):");
        for s in stale {
            eprintln!("  {s}");
        }
        Ok(Outcome::CheckFailed)
    } else {
        for s in stale {
            println!("wrote {s}");
        }
        Ok(Outcome::Done)
    }
}
