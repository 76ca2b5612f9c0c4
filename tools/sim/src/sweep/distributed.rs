//! Hands a sweep to a distributed engine: the Python driver of `tools/sweep_distributed/`
//! splits it into batches, has the engine's workers run each batch with this same binary
//! (`antenna sweep ... --batch i/n`, native code), gathers the rows into `sweep.csv` in sample
//! order and writes the report with `--report-only`. See docs/sweeps.md.

use std::path::{Path, PathBuf};
use std::process::{Command, ExitStatus};

use super::SweepSpec;

/// The engines a sweep can be handed to.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Engine {
    /// Dask distributed: a scheduler at an address, or a local cluster (`local`).
    Dask,
}

/// Where the hand-off goes and how it is split.
#[derive(Debug, Clone, PartialEq)]
pub struct HandOff {
    pub engine: Engine,
    /// The scheduler's address (`tcp://host:8786`), or `local` for a local cluster.
    pub address: String,
    /// Batches to split the sweep into (0: the driver's choice, four per worker thread).
    pub batches: u64,
    /// The folder of `sweep.csv` and the report.
    pub out: PathBuf,
    /// The `antenna` binary the workers run (the same path on every worker).
    pub antenna: PathBuf,
    /// The Python interpreter with the engine installed.
    pub python: PathBuf,
}

/// The driver script, in the repository.
pub fn driver_script() -> PathBuf {
    antenna_fmus::workspace_root().join("tools").join("sweep_distributed").join("dask_sweep.py")
}

/// The Python to run the driver with: `$ANTENNA_PYTHON`, else the repository's `.venv`, else
/// `python3` on the path.
pub fn default_python() -> PathBuf {
    if let Some(python) = std::env::var_os("ANTENNA_PYTHON") {
        return PathBuf::from(python);
    }
    let venv = antenna_fmus::workspace_root().join(".venv").join("bin").join("python");
    if venv.is_file() {
        venv
    } else {
        PathBuf::from("python3")
    }
}

/// The driver's command line for a sweep.
pub fn driver_command(spec: &SweepSpec, hand_off: &HandOff, script: &Path) -> Command {
    let engine = match hand_off.engine {
        Engine::Dask => "dask",
    };
    let mut command = Command::new(&hand_off.python);
    command
        .arg(script)
        .args(["--engine", engine, "--address", &hand_off.address, "--batches"])
        .arg(hand_off.batches.to_string())
        .arg("--out")
        .arg(&hand_off.out)
        .arg("--antenna")
        .arg(&hand_off.antenna)
        .arg("--")
        .args(spec.to_args());
    command
}

/// Runs the driver and waits for it.
pub fn hand_off(spec: &SweepSpec, hand_off: &HandOff) -> std::io::Result<ExitStatus> {
    driver_command(spec, hand_off, &driver_script()).status()
}
