"""Locates the packaged FMUs for the Python tests, and runs a scenario with the Rust master for
the tests that compare another master with it.

The FMUs are in target/fmu/ relative to the repository (written by
`cargo xtask package`), or in the folder that the environment
variable MEERKAT_FMU_DIR names (as for the Rust tools). The Rust master is the binary that the
environment variable ANTENNA_BIN names when it is set (the test command sets it to the binary it
has just built, so that these tests run beside the Rust tests without waiting for cargo's lock),
and otherwise `cargo run`, which builds it when it is stale. Tests that take the fixture `fmu_path`
run once for every .fmu found there, so FMUs added later are covered without editing the tests;
a missing folder or a missing plant FMU is a test failure with the instruction to package,
never a silent skip.
"""

import os
import pathlib
import subprocess

import pytest

REPOSITORY = pathlib.Path(__file__).resolve().parents[2]
FMU_DIRECTORY = pathlib.Path(os.environ.get("MEERKAT_FMU_DIR", REPOSITORY / "target" / "fmu"))
PLANTS = ("AzimuthPlant", "ElevationPlant")
PACKAGE_HINT = "package the FMUs first: cargo xtask package"


def antenna_binary():
    """The Rust master (`antenna`): ANTENNA_BIN when set, else target/release/antenna, built by
    cargo first if it is stale (cargo answers at once when it is not)."""
    binary = os.environ.get("ANTENNA_BIN")
    if binary:
        if not pathlib.Path(binary).is_file():
            pytest.fail(f"ANTENNA_BIN names {binary}, which is not a file")
        return pathlib.Path(binary)
    subprocess.run(["cargo", "build", "--release", "--quiet", "-p", "antenna-cli", "--bin", "antenna"],
                   cwd=REPOSITORY, check=True)
    return REPOSITORY / "target" / "release" / "antenna"


def antenna_command():
    """The command that starts the Rust master, before its arguments."""
    return [str(antenna_binary())]


def rust_scenario(folder, name, configuration="realistic", modes=None):
    """Runs one requirement scenario with the Rust master, with its own gust seed only (and the
    structure's modes from the modes file `modes`, if given), and returns `folder`, which then
    holds the scenario's command table, configuration, trace and report."""
    subprocess.run(
        antenna_command() + ["--no-build", "--only", name, "--seeds", "1", "--trace", str(folder),
                             "--out", str(folder / "report"), "--config", configuration]
        + (["--modes", str(modes)] if modes else []),
        cwd=REPOSITORY, check=True, capture_output=True,
    )
    return folder


def rust_scenario_inputs(folder, name, configuration="realistic"):
    """Writes one requirement scenario's command table and configuration, as the Rust master
    would run them, into `folder` without running it (`--export-only`), and returns `folder`."""
    subprocess.run(
        antenna_command() + ["--no-build", "--export-only", "--only", name, "--trace", str(folder),
                             "--config", configuration],
        cwd=REPOSITORY, check=True, capture_output=True,
    )
    return folder


def packaged_fmus():
    """Every .fmu in the packaging folder, sorted."""
    return sorted(FMU_DIRECTORY.glob("*.fmu"))


def plant_path(model_identifier):
    """The packaged plant FMU with this model identifier; fails the test if it is missing."""
    path = FMU_DIRECTORY / f"{model_identifier}.fmu"
    if not path.is_file():
        pytest.fail(f"{path} is missing: {PACKAGE_HINT}")
    return path


def pytest_generate_tests(metafunc):
    if "fmu_path" in metafunc.fixturenames:
        paths = packaged_fmus()
        # An empty folder still yields one test, which fails with the instruction.
        metafunc.parametrize("fmu_path", paths or [None], ids=[p.stem for p in paths] or ["no-fmu"], indirect=True)


@pytest.fixture
def fmu_path(request):
    if request.param is None:
        pytest.fail(f"no .fmu in {FMU_DIRECTORY}: {PACKAGE_HINT}")
    return request.param


@pytest.fixture(params=PLANTS)
def plant(request):
    """The model identifier and path of each plant FMU."""
    return request.param, plant_path(request.param)


def pytest_configure(config):
    """The long tier: tests that `tools/test-all.sh --long` adds to the test command (the test
    command deselects them with `-m "not long"`)."""
    config.addinivalue_line("markers", "long: a long check, run by tools/test-all.sh --long")
