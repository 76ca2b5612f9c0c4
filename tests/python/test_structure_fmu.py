"""The packaged structure FMU (Structure.fmu) under fmpy, an FMI master written independently of
this project.

A step load through fmpy's simulate_fmu with an input signal: the beam offsets settle at load
times the static compliance of the modes file shipped in the FMU (read and summed here, with
no project code), and the transient rings at each mode's damped frequency. The Rust tests in
tests/rust/structure_fmu.rs check the same FMU through the C ABI (FRF, communication steps,
bad modes files, FMU states). A second test drives the wind force resolved in the antenna's
frame (force.axial, force.lateral, force.lift) into a written modes file that takes it.
"""

import math
import zipfile

import numpy as np
from fmpy import simulate_fmu

from conftest import FMU_DIRECTORY, PACKAGE_HINT

ARCSEC_PER_RAD = 180.0 / math.pi * 3600.0
FIELDS = ("frequency", "damping", "stiffness", "azimuth_torque", "elevation_torque", "dish_force", "beam_azimuth", "beam_elevation",
          "axial_force", "lateral_force", "lift_force", "horizon_frequency", "beam_azimuth_rotation")
# The resolved forces' participations and the rotation about the azimuth axis are optional and
# default to zero (the horizon frequency, also optional, defaults to the frequency: filled in by
# parse_modes).
OPTIONAL = ("axial_force", "lateral_force", "lift_force", "beam_azimuth_rotation")
# The Structure FMU's elevation input's start value, deg.
START_ELEVATION_DEG = 45.0


def beam_on_sky(mode, axis, elevation_deg=START_ELEVATION_DEG):
    """A mode's beam offset on the sky per unit coordinate (axis 0 cross-elevation, 1 elevation):
    a rotation about the azimuth axis moves the beam on the sky by the angle times cos(el)."""
    if axis == 1:
        return mode["beam_elevation"]
    return mode["beam_azimuth"] + mode["beam_azimuth_rotation"] * math.cos(math.radians(elevation_deg))


def structure_path():
    path = FMU_DIRECTORY / "Structure.fmu"
    assert path.is_file(), f"{path} is missing: {PACKAGE_HINT}"
    return path


def shipped_modes():
    """The modes file in the FMU's resources as a list of {field: value}, one per mode."""
    with zipfile.ZipFile(structure_path()) as archive:
        text = archive.read("resources/structure_modes.params").decode()
    return parse_modes(text)


def parse_modes(text):
    """A modes file's text as a list of {field: value}, one per mode, optional fields filled."""
    modes = {}
    for line in text.splitlines():
        line = line.split("#", 1)[0].strip()
        if not line:
            continue
        name, value = (part.strip() for part in line.split("=", 1))
        mode, field = name.removeprefix("mode").split(".", 1)
        assert field in FIELDS, name
        modes.setdefault(int(mode), dict.fromkeys(OPTIONAL, 0.0))[field] = float(value)
    for mode in modes.values():
        mode.setdefault("horizon_frequency", mode["frequency"])
    return [modes[k] for k in sorted(modes)]


def ringing_frequency(time, signal):
    """A ringing signal's frequency, Hz, from its downward zero crossings, each interpolated
    linearly between its two samples."""
    crossings = np.nonzero((signal[:-1] > 0.0) & (signal[1:] <= 0.0))[0]
    exact = time[crossings] - signal[crossings] * (time[crossings + 1] - time[crossings]) / (signal[crossings + 1] - signal[crossings])
    return (len(exact) - 1) / (exact[-1] - exact[0])


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
        expected = sum(
            beam_on_sky(m, axis) * np.dot([m["azimuth_torque"], m["elevation_torque"], m["dish_force"]], load_vector)
            / m["stiffness"]
            for m in modes
        ) * ARCSEC_PER_RAD
        offset = result[output]
        assert abs(offset[time < 1.0]).max() == 0.0, f"{output} moved before the load"
        assert abs(offset[-1] / expected - 1.0) < 0.01, f"{output}: {offset[-1]} arcsec against {expected}"
        # The mode this axis's load excites: its damped frequency from the zero crossings of
        # the transient about the static offset over the first 5 s.
        mode = next(m for m in modes if beam_on_sky(m, axis) != 0.0 and m[("azimuth_torque", "elevation_torque")[axis]] != 0.0)
        window = (time > 1.0) & (time < 6.0)
        transient = offset[window] - expected
        t = time[window]
        ringing = ringing_frequency(t, transient)
        damped = mode["frequency"] * math.sqrt(1.0 - mode["damping"] ** 2)
        assert abs(ringing / damped - 1.0) < 0.02, f"{output}: rings at {ringing} Hz, the mode is at {damped} Hz"


# Two modes that take the resolved forces: one per beam axis, physical scaling (lever arms, m).
RESOLVED_MODES = """\
mode1.frequency = 5.0
mode1.damping = 0.02
mode1.stiffness = 3e8
mode1.azimuth_torque = 0
mode1.elevation_torque = 0
mode1.dish_force = 0
mode1.lateral_force = 4.0
mode1.lift_force = 0.5
mode1.beam_azimuth = 1
mode1.beam_elevation = 0
mode2.frequency = 7.0
mode2.damping = 0.015
mode2.stiffness = 5e8
mode2.azimuth_torque = 0
mode2.elevation_torque = 1
mode2.dish_force = 0
mode2.axial_force = 2.5
mode2.lift_force = -1.5
mode2.beam_azimuth = 0
mode2.beam_elevation = 1
"""


def test_constant_axial_lateral_and_lift_forces_settle_at_force_times_participation_over_stiffness(tmp_path):
    path = tmp_path / "resolved.params"
    path.write_text(RESOLVED_MODES)
    modes = parse_modes(RESOLVED_MODES)
    forces = {"force.axial": 9.6e3, "force.lateral": -4.8e3, "force.lift": -2.2e3}
    signal = np.array(
        [(0.0, 0.0, 0.0, 0.0), (1.0, 0.0, 0.0, 0.0), (1.0, *forces.values()), (31.0, *forces.values())],
        dtype=[("time", np.float64)] + [(name, np.float64) for name in forces],
    )
    result = simulate_fmu(
        str(structure_path()),
        stop_time=31.0,
        step_size=1e-3,
        output_interval=1e-3,
        start_values={"modes_file": str(path)},
        input=signal,
        output=["beam.azimuth_offset", "beam.elevation_offset"],
    )
    for axis, output in enumerate(("beam.azimuth_offset", "beam.elevation_offset")):
        beam_field = ("beam_azimuth", "beam_elevation")[axis]
        expected = sum(
            m[beam_field] * np.dot([m["axial_force"], m["lateral_force"], m["lift_force"]], list(forces.values()))
            / m["stiffness"]
            for m in modes
        ) * ARCSEC_PER_RAD
        offset = result[output]
        assert abs(offset[result["time"] < 1.0]).max() == 0.0, f"{output} moved before the forces"
        assert abs(offset[-1] / expected - 1.0) < 0.01, f"{output}: {offset[-1]} arcsec against {expected}"


# One lightly damped azimuth mode that changes with elevation: 6 Hz at the zenith, 7 Hz at the
# horizon (docs/structure-model.md, "Modes that change with elevation").
ELEVATION_MODES = """\
mode1.frequency = 6.0
mode1.horizon_frequency = 7.0
mode1.damping = 0.002
mode1.stiffness = 4e8
mode1.azimuth_torque = 1
mode1.elevation_torque = 0
mode1.dish_force = 0
mode1.beam_azimuth = 1
mode1.beam_elevation = 0
"""


def test_a_mode_with_a_horizon_frequency_rings_at_the_documented_frequency_of_its_elevation(tmp_path):
    modes_file = tmp_path / "elevation.params"
    modes_file.write_text(ELEVATION_MODES)
    mode = parse_modes(ELEVATION_MODES)[0]
    for elevation in (15.0, 60.0):
        # A torque held for the first millisecond, then free ringing.
        signal = np.array([(0.0, 1e5), (1e-3, 1e5), (1e-3, 0.0), (10.0, 0.0)],
                          dtype=[("time", np.float64), ("torque.azimuth", np.float64)])
        result = simulate_fmu(
            str(structure_path()),
            stop_time=10.0,
            step_size=1e-3,
            output_interval=1e-3,
            input=signal,
            start_values={"modes_file": str(modes_file), "axis.elevation": elevation},
            output=["beam.azimuth_offset", "modal_inertia.azimuth", "modal_inertia.azimuth_horizon"],
        )
        ringing = ringing_frequency(result["time"], result["beam.azimuth_offset"])
        c, s = math.cos(math.radians(elevation)), math.sin(math.radians(elevation))
        undamped = 1.0 / math.sqrt(c * c / mode["horizon_frequency"] ** 2 + s * s / mode["frequency"] ** 2)
        damped = undamped * math.sqrt(1.0 - mode["damping"] ** 2)
        assert abs(ringing / damped - 1.0) < 1e-3, f"{elevation} deg: rings at {ringing} Hz, documented {damped} Hz"
        inertia = lambda f: mode["stiffness"] / (2.0 * math.pi * f) ** 2
        assert abs(result["modal_inertia.azimuth"][-1] / inertia(mode["frequency"]) - 1.0) < 1e-12
        assert abs(result["modal_inertia.azimuth_horizon"][-1] / inertia(mode["horizon_frequency"]) - 1.0) < 1e-12
