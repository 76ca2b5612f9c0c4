"""The fmpy sweep example (tools/sweep_distributed/fmpy_sweep.py): a small sweep over the packaged
FMUs coupled by the fmpy master, on a two-worker Dask cluster, draws its values inside the
ranges of docs/parameters.csv and gives each sample the figure the same run gives without the
engine; at the table's defaults a sample is the Rust master's realistic antenna."""

import math
import subprocess
import sys

import numpy as np

import pytest

from conftest import FMU_DIRECTORY, PACKAGE_HINT, REPOSITORY, antenna_command

sys.path.insert(0, str(REPOSITORY / "tools" / "sweep_distributed"))
import fmpy_sweep  # noqa: E402


@pytest.fixture(scope="module")
def cluster():
    if not (FMU_DIRECTORY / "Wind.fmu").is_file():
        pytest.fail(f"no FMUs in {FMU_DIRECTORY}: {PACKAGE_HINT}")
    from dask.distributed import LocalCluster

    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as local:
        yield local


def test_a_small_fmpy_sweep_on_dask_matches_the_same_runs_without_it(cluster, tmp_path):
    names = ["azimuth.pinion_stiffness", "structure.stiffness", "wind.seed"]
    rows = fmpy_sweep.run(cluster.scheduler_address, samples=3, seed=4, seconds=21.0, names=names,
                          out=tmp_path / "rows.csv")
    table = fmpy_sweep.read_table()
    assert [i for i, _, _ in rows] == [0, 1, 2]
    for _, values, figure in rows:
        for name in names:
            assert table[name]["low"] <= values[name] <= table[name]["high"], (name, values[name])
        assert math.isfinite(figure) and figure > 0.0
    # The engine adds nothing: sample 1 run here, in this process, gives the same figure.
    _, values, figure = rows[1]
    files = fmpy_sweep.export_sample(values, 21.0, tmp_path / "again")
    assert fmpy_sweep.run_sample(files, 21.0, fmpy_sweep.fmu_directory()) == figure
    assert (tmp_path / "rows.csv").read_text().count("\n") == 4


def test_a_name_outside_the_table_is_refused():
    with pytest.raises(ValueError, match="not parameters"):
        fmpy_sweep.points(fmpy_sweep.read_table(), ["structure.dampng"], 2, 1)


def rust_figure(tmp_path, seconds, settings):
    """The Rust master's run of the sweep's commands in normal wind with these `--set` values,
    judged on its trace as the sweep judges a sample."""
    tmp_path.mkdir(parents=True, exist_ok=True)
    commands = tmp_path / "sidereal.csv"
    commands.write_text(fmpy_sweep.commands_text(seconds))
    subprocess.run(
        antenna_command() + ["--no-build", "--commands", str(commands), "--wind", "normal", "--seed", str(fmpy_sweep.SEED), "--seeds", "1",
         "--trace", str(tmp_path), "--out", str(tmp_path / "report")]
        + [arg for name, value in settings.items() for arg in ("--set", f"{name}={value!r}")],
        cwd=REPOSITORY, check=True, capture_output=True,
    )
    rust = np.loadtxt(tmp_path / "sidereal.trace.csv", delimiter=",", skiprows=1)
    return fmpy_sweep.jitter_after_first_window(rust[:int(round(seconds / 1e-3))], 1e-3)


@pytest.mark.parametrize("settings", [{}, {"structure.stiffness": 2e8, "elevation.load_inertia": 2.6e5}],
                         ids=["defaults", "softer-structure-lighter-elevation"])
def test_a_sample_is_the_rust_masters_antenna_at_the_same_values(tmp_path, settings):
    """At the table's defaults the realistic antenna; with a softer structure the modes file the
    Rust master writes for those values reaches the fmpy task."""
    seconds = 21.0
    expected = rust_figure(tmp_path / "rust", seconds, settings)
    files = fmpy_sweep.export_sample(settings, seconds, tmp_path / "export")
    assert (files["modes"] is None) == (not settings)
    figure = fmpy_sweep.run_sample(files, seconds, fmpy_sweep.fmu_directory())
    assert abs(figure - expected) <= 1e-9 * expected, (figure, expected)
    # The realistic antenna's beam (0.6 arcsec after centring), not the paper's drives alone
    # (0.1 arcsec there, offsets included).
    assert figure > 0.3, figure
