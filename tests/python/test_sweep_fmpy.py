"""The fmpy sweep example (tools/sweep_distributed/fmpy_sweep.py): a small sweep over the packaged
FMUs coupled by the fmpy master, on a two-worker Dask cluster, draws its values inside the
ranges of docs/parameters.csv and gives each sample the figure the same run gives without the
engine."""

import math
import sys

import pytest

from conftest import FMU_DIRECTORY, PACKAGE_HINT, REPOSITORY

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
    names = ["azimuth.pinion_stiffness", "wind.mean_speed_factor", "wind.seed"]
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
    table_rows = {name: table[name] for name in names}
    assert fmpy_sweep.run_sample(values, 21.0, table_rows, fmpy_sweep.fmu_directory()) == figure
    assert (tmp_path / "rows.csv").read_text().count("\n") == 4


def test_parameters_the_fmpy_master_does_not_couple_are_refused():
    with pytest.raises(ValueError, match="does not couple"):
        fmpy_sweep.points(fmpy_sweep.read_table(), ["structure.damping"], 2, 1)
