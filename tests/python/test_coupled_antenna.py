"""The coupled antenna under fmpy agrees with the Rust master.

The Rust main job writes each scenario's command table, configuration and trace
(`antenna --trace DIR`); the fmpy master (coupled_master.py) runs the same scenario from those
files through fmpy and the same packaged FMUs. Both use the same fixed-step Jacobi scheme, so
the traces must agree to 1e-9 of each signal's scale. (Speed is measured by the benchmark,
`cargo run --release -p antenna-cli --bin bench -- --fmpy`, not by a timed test.)"""

import os
import sys

import numpy as np
import pytest

import coupled_master
from conftest import rust_scenario


def fmpy_run(folder, scenario):
    """The fmpy master's trace of a scenario the Rust master wrote into `folder`."""
    config = coupled_master.read_config(folder / f"{scenario}.config")
    table = coupled_master.CommandTable.read(folder / f"{scenario}.commands.csv")
    return np.array(coupled_master.run(config, table, config["end_s"]))


@pytest.mark.parametrize("scenario,configuration", [
    # The realistic antenna tracking and stepping take 84 s and 25 s under fmpy: long tier.
    pytest.param("track-sidereal-el45", "realistic", marks=pytest.mark.long),
    pytest.param("step-30arcmin-el15", "realistic", marks=pytest.mark.long),
    ("hold-el45-normal-wind", "realistic"),
    ("track-sidereal-el45", "paper"),
])
def test_fmpy_master_agrees_with_the_rust_master(tmp_path, scenario, configuration):
    folder = rust_scenario(tmp_path, scenario, configuration)
    rust = np.loadtxt(folder / f"{scenario}.trace.csv", delimiter=",", skiprows=1)
    config = coupled_master.read_config(folder / f"{scenario}.config")
    table = coupled_master.CommandTable.read(folder / f"{scenario}.commands.csv")
    python = np.array(coupled_master.run(config, table, config["end_s"]))
    assert python.shape == rust.shape
    scale = np.maximum(np.abs(rust).max(axis=0), 1e-300)
    relative = (np.abs(python - rust) / scale).max(axis=0)
    assert relative.max() <= 1e-9, dict(zip(coupled_master.COLUMNS.split(","), relative))
    # The run did something: the axes moved and the wind pushed (and bent the structure).
    assert np.ptp(rust[:, 3]) > 0.0 and np.abs(rust[:, 10]).max() > 0.0
    assert (np.abs(rust[:, 15]).max() > 0.0) == (configuration == "realistic")


# The shipped modes with the azimuth mode changing with elevation: 6 Hz at the zenith as shipped,
# 7 Hz at the horizon (docs/structure-model.md, "Modes that change with elevation").
ELEVATION_MODES = """\
mode1.frequency = 6.0
mode1.horizon_frequency = 7.0
mode1.damping = 0.015
mode1.stiffness = 4e8
mode1.azimuth_torque = 1
mode1.elevation_torque = 0
mode1.dish_force = 0
mode1.beam_azimuth = 1
mode1.beam_elevation = 0
mode2.frequency = 6.0
mode2.damping = 0.015
mode2.stiffness = 4e8
mode2.azimuth_torque = 0
mode2.elevation_torque = 1
mode2.dish_force = 0
mode2.beam_azimuth = 0
mode2.beam_elevation = 1
"""


def test_fmpy_master_agrees_with_the_rust_master_on_modes_that_change_with_elevation(tmp_path):
    """Both masters send the elevation to the structure and split the modes' inertia out of the
    azimuth plant on their own; a 30 arcmin elevation step at 15 deg crosses two cells."""
    modes = tmp_path / "elevation.params"
    modes.write_text(ELEVATION_MODES)
    scenario = "step-30arcmin-el15"
    folder = rust_scenario(tmp_path / "elevation", scenario, modes=modes)
    rust = np.loadtxt(folder / f"{scenario}.trace.csv", delimiter=",", skiprows=1)
    python = fmpy_run(folder, scenario)
    scale = np.maximum(np.abs(rust).max(axis=0), 1e-300)
    relative = (np.abs(python - rust) / scale).max(axis=0)
    assert relative.max() <= 1e-9, dict(zip(coupled_master.COLUMNS.split(","), relative))
    # The modes file made a difference: the shipped modes give another beam offset.
    shipped_folder = rust_scenario(tmp_path / "shipped", scenario)
    shipped = np.loadtxt(shipped_folder / f"{scenario}.trace.csv", delimiter=",", skiprows=1)
    assert np.abs(shipped[:, 15] - rust[:, 15]).max() > 1e-3 * np.abs(rust[:, 15]).max()


def pointing_error_arcsec(trace):
    """On-sky error between the command and the beam, as the requirement report defines it: the
    load-side axes' error minus the structure's beam offsets (columns 15 and 16, arcsec)."""
    trace = np.asarray(trace)
    d_az = trace[:, 1] - trace[:, 3]
    d_el = trace[:, 2] - trace[:, 4]
    cross = d_az * np.cos(np.radians(trace[:, 4])) * 3600.0 - trace[:, 15]
    return np.hypot(cross, d_el * 3600.0 - trace[:, 16])


def test_fmpy_master_meets_the_tracking_jitter_requirement(tmp_path):
    """Req. 1 judged on the fmpy master's own trace: the worst 10 s jitter after centring below
    15 arcsec, and the same figure as the Rust report's to its printed digits; the absolute
    error (offsets included) is larger and matches the report's absolute column."""
    folder = rust_scenario(tmp_path, "track-sidereal-el45")
    config = coupled_master.read_config(folder / "track-sidereal-el45.config")
    table = coupled_master.CommandTable.read(folder / "track-sidereal-el45.commands.csv")
    trace = np.array(coupled_master.run(config, table, config["end_s"]))
    error = pointing_error_arcsec(trace)
    dt = trace[1, 0] - trace[0, 0]
    window = int(round(10.0 / dt))
    # Judge the tracking after the first 10 s in which the axes take up the track.
    tracked = trace[:, 0] >= trace[0, 0] + 10.0
    mean_square = np.convolve(error[tracked] ** 2, np.ones(window) / window, mode="valid")
    absolute = np.sqrt(mean_square.max())
    cross = (trace[:, 1] - trace[:, 3]) * np.cos(np.radians(trace[:, 4])) * 3600.0 - trace[:, 15]
    elevation = (trace[:, 2] - trace[:, 4]) * 3600.0 - trace[:, 16]
    centred = coupled_master.worst_centred_rms(cross[tracked], elevation[tracked], window)
    assert centred < 15.0 and centred < absolute, (centred, absolute)
    header, *rows = (folder / "report" / "report.csv").read_text().splitlines()
    row = dict(zip(header.split(","), next(r for r in rows if ",track-sidereal-el45," in r).split(",")))
    for figure, printed in ((centred, row["centred_jitter_arcsec_rms"]), (absolute, row["absolute_rms_arcsec"])):
        half_digit = 0.5 * 10.0 ** -len(printed.partition(".")[2])
        assert abs(figure - float(printed)) <= half_digit, (figure, printed)
    # The axes did track: they moved by the sidereal rate over the run.
    assert np.ptp(trace[:, 3]) > 1e-3


def test_fmpy_master_settles_a_30_arcmin_step_within_4_s(tmp_path):
    """Req. 4 judged on the fmpy master's own trace as the Rust report judges it: within
    15 arcsec for good less than 4 s after the command (the profile's duration included), and
    the issue's own figure, from the profiled reference's arrival, under 4 s too."""
    folder = rust_scenario(tmp_path, "step-30arcmin-el15")
    config = coupled_master.read_config(folder / "step-30arcmin-el15.config")
    table = coupled_master.CommandTable.read(folder / "step-30arcmin-el15.commands.csv")
    trace = np.array(coupled_master.run(config, table, config["end_s"]))
    error = pointing_error_arcsec(trace)
    time = trace[:, 0]
    target = trace[-1, 1:3]
    jumped = np.abs(trace[:, 1] - target[0]) + np.abs(trace[:, 2] - target[1]) < 1e-9
    jump_index = int(np.argmax(jumped))
    assert jump_index > 0, "the command never stepped"
    arrived = jumped & (np.abs(trace[:, 7] - target[0]) < 1e-5) & (np.abs(trace[:, 8] - target[1]) < 1e-5)
    arrival = int(np.argmax(arrived))
    assert arrived[arrival], "the profiled reference never reached the target"
    hold = int(round(10.0 / (time[1] - time[0])))
    outside = np.flatnonzero(error[arrival:] > 15.0)
    settled = arrival if outside.size == 0 else arrival + outside[-1] + 1
    assert len(error) - settled >= hold, "the run ended before the error had stayed in the band for 10 s"
    assert time[settled] - time[arrival] < 4.0
    outside_after_command = np.flatnonzero(error[jump_index:] > 15.0)
    settled_from_command = jump_index + (outside_after_command[-1] + 1 if outside_after_command.size else 0)
    assert time[settled_from_command] - time[jump_index] < 4.0, time[settled_from_command] - time[jump_index]
    # The command really stepped by 30 arcmin on each axis.
    step = np.abs(trace[jump_index, 1:3] - trace[jump_index - 1, 1:3])
    assert np.allclose(step, 0.5, atol=1e-6), step


def test_fmpy_master_gives_a_lateral_force_mode_the_wind_forces_lateral_part(tmp_path):
    """The fmpy master connects the wind's force.lateral to the structure: a mode that takes only
    the lateral force sees none in a front wind (yaw 0) and -drag sin(yaw) + side cos(yaw) when the
    wind turns by 45 deg either way, with drag and side force by hand (docs/wind-model.md). Steady wind (no gust), the
    paper's drive model holding azimuth 100 deg, elevation 30 deg for 2 s."""
    lever, stiffness = 5.0, 4e8
    modes = tmp_path / "lateral.params"
    modes.write_text(
        f"mode1.frequency = 6.0\nmode1.damping = 0.015\nmode1.stiffness = {stiffness}\nmode1.azimuth_torque = 0\n"
        f"mode1.elevation_torque = 0\nmode1.dish_force = 0\nmode1.lateral_force = {lever}\nmode1.beam_azimuth = 1\n"
        "mode1.beam_elevation = 0\n")
    table = coupled_master.CommandTable([(0.0, 100.0, 30.0), (2.0, 100.0, 30.0)])
    q_a = 0.5 * 1.075 * 9.8**2 * np.pi * 13.5**2 / 4.0
    whole = q_a * 1.3 * np.cos(np.radians(30.0)) * lever / stiffness * 180.0 / np.pi * 3600.0
    side = q_a * 0.3 * np.cos(np.radians(30.0)) ** 2 * lever / stiffness * 180.0 / np.pi * 3600.0
    offsets = {}
    for direction, yaw in ((100.0, 0.0), (55.0, -45.0), (145.0, 45.0)):
        config = {"step_s": 1e-3, "wind.mean_speed": 9.8, "wind.roughness_length": 0.0105, "wind.direction": direction,
                  "seed": 1, "structure": True, "wind_load_scale": 1.0,
                  "overrides": {unit: [] for unit in coupled_master.UNITS}}
        config["overrides"]["Structure"].append(("modes_file", str(modes)))
        config["overrides"]["Wind"].append(("spectrum", 3))
        trace = np.array(coupled_master.run(config, table, 2.0))
        static = trace[-1, 17]
        psi = np.radians(yaw)
        expected = -whole * abs(np.cos(psi)) * np.sin(psi) + side * np.sin(2.0 * psi) * np.cos(psi)
        offsets[yaw] = static
        if yaw == 0.0:
            assert abs(static) < 1e-4 * whole, static
        else:
            assert abs(static / expected - 1.0) < 0.01, (yaw, static, expected)
    assert offsets[-45.0] > 0.0 > offsets[45.0]
