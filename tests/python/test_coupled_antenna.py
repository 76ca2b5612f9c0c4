"""The coupled antenna under fmpy agrees with the Rust master.

The Rust main job writes each scenario's command table, configuration and trace
(`antenna --trace DIR`); the fmpy master (coupled_master.py) runs the same scenario from those
files through fmpy and the same packaged FMUs. Both use the same fixed-step Jacobi scheme, so
the traces must agree to 1e-9 of each signal's scale. (Speed is measured by the benchmark,
`cargo run --release -p antenna-tools --bin bench -- --fmpy`, not by a timed test.)"""

import os
import subprocess
import sys

import numpy as np
import pytest

sys.path.insert(0, os.path.dirname(__file__))
import coupled_master  # noqa: E402

ROOT = coupled_master.ROOT


def rust_scenario(tmp_path, name):
    """Runs one scenario with the Rust master and returns the folder with its files."""
    subprocess.run(
        ["cargo", "run", "--release", "--quiet", "-p", "antenna-tools", "--bin", "antenna", "--",
         "--no-build", "--only", name, "--trace", str(tmp_path), "--out", str(tmp_path / "report")],
        cwd=ROOT, check=True, capture_output=True,
    )
    return tmp_path


@pytest.mark.parametrize("scenario", ["track-sidereal-el45", "step-30arcmin-el15"])
def test_fmpy_master_agrees_with_the_rust_master(tmp_path, scenario):
    folder = rust_scenario(tmp_path, scenario)
    rust = np.loadtxt(folder / f"{scenario}.trace.csv", delimiter=",", skiprows=1)
    config = coupled_master.read_config(folder / f"{scenario}.config")
    table = coupled_master.CommandTable.read(folder / f"{scenario}.commands.csv")
    python = np.array(coupled_master.run(config, table, config["end_s"]))
    assert python.shape == rust.shape
    scale = np.maximum(np.abs(rust).max(axis=0), 1e-300)
    relative = (np.abs(python - rust) / scale).max(axis=0)
    assert relative.max() <= 1e-9, dict(zip(coupled_master.COLUMNS.split(","), relative))
    # The run did something: the axes moved and the wind pushed.
    assert np.ptp(rust[:, 3]) > 0.0 and np.abs(rust[:, 10]).max() > 0.0
