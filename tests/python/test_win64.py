"""The FMUs' win64 binaries, run under wine by a small C master beside their linux64 binaries
run natively by the same master (tools/win64/fmu_master.c): the same calls give the same
outputs, within what the two platforms' mathematics libraries (glibc's and mingw-w64's exp, pow,
sin...) differ by in their last bits, grown over 2,000 steps: measured, 1.6e-9 of an output's
range for the wind, 1.2e-9 for the elevation plant. The plants' sine and cosine come from the
`libm` crate on both platforms; the rest from each platform's own library.

Long tier (`tools/test-all.sh --long`): it needs the FMUs of `cargo xtask package --win64`
(target/fmu-linux64-win64/), which need Debian's rustc-web, rust-web-src and
gcc-mingw-w64-x86-64, and wine64 to run them. Wine 8 has no bcryptprimitives.dll, from which
Rust's standard library takes its random seeds on Windows 10 and later; the test puts a stub
of it (tools/win64/bcryptprimitives_stub.c) beside the master, never into an FMU."""

import os
import re
import shutil
import subprocess
import zipfile

import numpy as np
import pytest

from conftest import REPOSITORY

FOLDER = REPOSITORY / "target" / "fmu-linux64-win64"
WINE = shutil.which("wine64") or "/usr/lib/wine/wine64"
STEPS, STEP_S = 2000, 1e-3

pytestmark = pytest.mark.long


def build(tmp_path):
    """The master for both platforms and the stub, compiled into `tmp_path`."""
    source = REPOSITORY / "tools" / "win64"
    subprocess.run(["gcc", "-std=c99", "-O1", "-o", tmp_path / "fmu_master", source / "fmu_master.c", "-ldl"],
                   check=True)
    subprocess.run(["x86_64-w64-mingw32-gcc", "-std=c99", "-O1", "-o", tmp_path / "fmu_master.exe",
                    source / "fmu_master.c"], check=True)
    subprocess.run(["x86_64-w64-mingw32-gcc", "-shared", "-O1", "-o", tmp_path / "bcryptprimitives.dll",
                    source / "bcryptprimitives_stub.c", "-ladvapi32"], check=True)


def arguments(folder):
    """The master's arguments for an unpacked FMU: every Real input set to 1 (inside every
    input's range), every Real output printed."""
    text = (folder / "modelDescription.xml").read_text()
    name = re.search(r'modelName="([^"]+)"', text).group(1)
    guid = re.search(r'guid="([^"]+)"', text).group(1)
    variables = re.findall(r'<ScalarVariable name="[^"]*" valueReference="(\d+)"[^>]*causality="(\w+)"[^>]*>\s*<Real',
                           text)
    inputs = [f"set:{vr}=1" for vr, causality in variables if causality == "input"]
    outputs = [f"out:{vr}" for vr, causality in variables if causality == "output"]
    return name, guid, inputs + outputs


@pytest.mark.parametrize("model", ["AzimuthPlant", "ElevationPlant", "Wind", "AzimuthController",
                                   "ElevationController", "Structure"])
def test_the_win64_binary_under_wine_computes_what_the_linux64_binary_computes(tmp_path, model):
    archive = FOLDER / f"{model}.fmu"
    assert archive.is_file(), f"{archive} is missing: run `cargo xtask package --win64` first"
    build(tmp_path)
    unpacked = tmp_path / model
    with zipfile.ZipFile(archive) as fmu:
        fmu.extractall(unpacked)
    name, guid, variables = arguments(unpacked)
    resources = (unpacked / "resources").as_uri()
    native = subprocess.run([tmp_path / "fmu_master", unpacked / "binaries" / "linux64" / f"{model}.so", name, guid,
                             resources, str(STEPS), str(STEP_S), *variables],
                            check=True, capture_output=True, text=True).stdout
    shutil.copy(unpacked / "binaries" / "win64" / f"{model}.dll", tmp_path)
    environment = dict(os.environ, WINEPREFIX=str(tmp_path / "wine"), WINEDEBUG="-all")
    windows = subprocess.run([WINE, tmp_path / "fmu_master.exe", f"{model}.dll", name, guid, resources, str(STEPS),
                              str(STEP_S), *variables],
                             cwd=tmp_path, env=environment, check=True, capture_output=True, text=True).stdout
    a = np.loadtxt(native.splitlines(), ndmin=2)
    b = np.loadtxt(windows.splitlines(), ndmin=2)
    assert a.shape == b.shape == (STEPS, a.shape[1]) and a.shape[1] > 0, (a.shape, b.shape)
    scale = np.maximum(np.abs(a).max(axis=0), 1e-300)
    relative = (np.abs(a - b) / scale).max()
    assert relative <= 1e-8, f"{model}: largest difference {relative:.3e} of each output's range"
