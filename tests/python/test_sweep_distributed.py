"""The distributed sweep engine (tools/sweep_distributed/dask_sweep.py) against the local pool:
a Dask cluster of two workers on this machine, reached through `antenna sweep --engine dask
--address ...` as a user would, gathers the same rows, bit for bit, as `antenna sweep` on one
local thread for the same seed, and writes the report beside them."""

import os
import pathlib
import subprocess
import sys

import pytest

from conftest import FMU_DIRECTORY, PACKAGE_HINT, REPOSITORY, antenna_binary

SWEEP = ["--samples", "5", "--seed", "9", "--method", "lhs", "--scenarios", "step-30arcmin-el45",
         "--sweep-file", str(REPOSITORY / "tools" / "sweep_distributed" / "strong_wind.csv")]


@pytest.fixture(scope="module")
def antenna():
    """The Rust master."""
    if not (FMU_DIRECTORY / "Wind.fmu").is_file():
        pytest.fail(f"no FMUs in {FMU_DIRECTORY}: {PACKAGE_HINT}")
    return antenna_binary()


@pytest.fixture(scope="module")
def cluster():
    from dask.distributed import LocalCluster

    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as local:
        yield local


def test_the_distributed_sweep_gathers_the_rows_of_the_local_pool_bit_for_bit(antenna, cluster, tmp_path):
    local, distributed = tmp_path / "local", tmp_path / "distributed"
    subprocess.run([antenna, "sweep", *SWEEP, "--threads", "1", "--no-build", "--out", local],
                   check=True, capture_output=True)
    environment = {**os.environ, "ANTENNA_PYTHON": sys.executable}
    done = subprocess.run([antenna, "sweep", *SWEEP, "--no-build", "--engine", "dask",
                           "--address", cluster.scheduler_address, "--batches", "3", "--out", distributed],
                          capture_output=True, text=True, env=environment)
    assert done.returncode == 0, done.stderr
    assert "3 batches on 2 worker threads" in done.stdout, done.stdout
    expected = (local / "sweep.csv").read_bytes()
    assert expected.count(b"\n") == 1 + 5
    assert (distributed / "sweep.csv").read_bytes() == expected
    report = (distributed / "sweep.md").read_text()
    assert "| Req. 4 | < 4 s | 5 |" in report, report


def test_a_failing_batch_is_an_error_not_a_short_file(antenna, cluster, tmp_path):
    sys.path.insert(0, str(REPOSITORY / "tools" / "sweep_distributed"))
    import dask_sweep

    with pytest.raises(RuntimeError, match="no scenario name contains it"):
        dask_sweep.run(cluster.scheduler_address, tmp_path, ["--samples", "2", "--scenarios", "no-such-scenario"],
                       antenna, batches=2)
    assert not pathlib.Path(tmp_path, "sweep.md").exists()
