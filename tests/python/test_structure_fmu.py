"""The packaged structure FMU (Structure.fmu) under fmpy, an FMI master written independently of
this project.

A step load through fmpy's simulate_fmu with an input signal: the beam offsets settle at load
times the static compliance of the modes file shipped in the FMU (read and summed here, with
no project code), and the transient rings at each mode's damped frequency. The Rust tests in
tests/rust/structure_fmu.rs check the same FMU through the C ABI (FRF, communication steps,
bad modes files, FMU states).
"""

import math
import zipfile

import numpy as np
from fmpy import simulate_fmu

from conftest import FMU_DIRECTORY, PACKAGE_HINT

ARCSEC_PER_RAD = 180.0 / math.pi * 3600.0
FIELDS = ("frequency", "damping", "stiffness", "azimuth_torque", "elevation_torque", "dish_force", "beam_azimuth", "beam_elevation")


def structure_path():
    path = FMU_DIRECTORY / "Structure.fmu"
    assert path.is_file(), f"{path} is missing: {PACKAGE_HINT}"
    return path


def shipped_modes():
    """The modes file in the FMU's resources as a list of {field: value}, one per mode."""
    with zipfile.ZipFile(structure_path()) as archive:
        text = archive.read("resources/structure_modes.params").decode()
    modes = {}
    for line in text.splitlines():
        line = line.split("#", 1)[0].strip()
        if not line:
            continue
        name, value = (part.strip() for part in line.split("=", 1))
        mode, field = name.removeprefix("mode").split(".", 1)
        assert field in FIELDS, name
        modes.setdefault(int(mode), {})[field] = float(value)
    return [modes[k] for k in sorted(modes)]


def test_a_step_load_settles_at_load_times_compliance_and_rings_at_each_mode_frequency():
    modes = shipped_modes()
    loads = {"torque.azimuth": 1.05e4, "torque.elevation": -8.0e3, "force.dish": 0.0}
    # The loads step on at 1 s (a piecewise-constant input: fmpy holds each value).
    signal = np.array(
        [(0.0, 0.0, 0.0, 0.0), (1.0, 0.0, 0.0, 0.0), (1.0, *loads.values()), (41.0, *loads.values())],
        dtype=[("time", np.float64)] + [(name, np.float64) for name in loads],
    )
    result = simulate_fmu(
        str(structure_path()),
        stop_time=41.0,
        step_size=1e-3,
        output_interval=1e-3,
        input=signal,
        output=["beam.azimuth_offset", "beam.elevation_offset"],
    )
    time = result["time"]
    load_vector = np.array(list(loads.values()))
    for axis, output in enumerate(("beam.azimuth_offset", "beam.elevation_offset")):
        beam_field = ("beam_azimuth", "beam_elevation")[axis]
        expected = sum(
            m[beam_field] * np.dot([m["azimuth_torque"], m["elevation_torque"], m["dish_force"]], load_vector) / m["stiffness"]
            for m in modes
        ) * ARCSEC_PER_RAD
        offset = result[output]
        assert abs(offset[time < 1.0]).max() == 0.0, f"{output} moved before the load"
        assert abs(offset[-1] / expected - 1.0) < 0.01, f"{output}: {offset[-1]} arcsec against {expected}"
        # The mode this axis's load excites: its damped frequency from the zero crossings of
        # the transient about the static offset over the first 5 s.
        mode = next(m for m in modes if m[beam_field] != 0.0 and m[("azimuth_torque", "elevation_torque")[axis]] != 0.0)
        window = (time > 1.0) & (time < 6.0)
        transient = offset[window] - expected
        t = time[window]
        crossings = np.nonzero((transient[:-1] > 0.0) & (transient[1:] <= 0.0))[0]
        exact = t[crossings] - transient[crossings] * (t[crossings + 1] - t[crossings]) / (transient[crossings + 1] - transient[crossings])
        ringing = (len(exact) - 1) / (exact[-1] - exact[0])
        damped = mode["frequency"] * math.sqrt(1.0 - mode["damping"] ** 2)
        assert abs(ringing / damped - 1.0) < 0.02, f"{output}: rings at {ringing} Hz, the mode is at {damped} Hz"
