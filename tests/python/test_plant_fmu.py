"""The packaged FMUs under fmpy, an FMI master written independently of this project.

Every .fmu in target/fmu/ must pass `fmpy validate` and run under `simulate_fmu`; the plant
FMUs must reproduce their linear configuration (both ways of choosing it); every FMU (plants,
controllers, wind) must refuse misuse with fmi2Error and a logged message without crashing; the
plants must restore and transfer FMU states bitwise, their sensor noise must follow its seed
and not the communication step, a rounding encoder count must have zero mean error, and they
must never write to stdout or stderr. The Rust integration tests in tests/rust/ check the same FMUs
against the analytic solution of Eq. 1; these tests make sure a foreign master sees the same.
"""

import math
import pathlib
import subprocess
import sys
import time

import numpy as np
import pytest
from fmpy import read_model_description, simulate_fmu
from fmpy.fmi1 import FMICallException
from fmpy.validation import validate_fmu

from conftest import PLANTS, plant_path
from fmu_slave import FMI2_ERROR, Packaged

HERE = pathlib.Path(__file__).resolve().parent


@pytest.fixture(scope="module")
def packaged():
    """Each plant FMU unpacked once per module, by model identifier."""
    unpacked = {}

    def get(model_identifier):
        if model_identifier not in unpacked:
            unpacked[model_identifier] = Packaged(plant_path(model_identifier))
        return unpacked[model_identifier]

    yield get
    for p in unpacked.values():
        p.close()


def current_inputs(model_identifier):
    """The current-command inputs of a plant."""
    return ["motor1.current_command", "motor2.current_command"] if model_identifier == "AzimuthPlant" else ["motor.current_command"]


# One Real input of every FMU, for the misuse tests, which every FMU must pass alike.
A_REAL_INPUT = {
    "AzimuthPlant": "motor1.current_command",
    "ElevationPlant": "motor.current_command",
    "AzimuthController": "command.position",
    "ElevationController": "command.position",
    "Wind": "antenna.azimuth",
}
ALL_FMUS = tuple(A_REAL_INPUT)


def step_input(model_identifier, amplitude, at=0.05, stop=0.5):
    """A structured array for simulate_fmu: every current command steps from 0 to `amplitude`
    at `at` seconds (the repeated time marks the discontinuity)."""
    names = current_inputs(model_identifier)
    dtype = [("time", np.float64)] + [(n, np.float64) for n in names]
    rows = [(0.0,) + (0.0,) * len(names), (at,) + (0.0,) * len(names), (at,) + (amplitude,) * len(names), (stop,) + (amplitude,) * len(names)]
    return np.array(rows, dtype=dtype)


def relative_to_range(a, b):
    span = np.max(b) - np.min(b)
    assert span > 0, "the reference does not move: a range-relative difference means nothing"
    return float(np.max(np.abs(a - b)) / span)


# --- Every packaged FMU -------------------------------------------------------------------


def test_fmpy_validate_reports_no_problem(fmu_path):
    problems = validate_fmu(str(fmu_path))
    assert problems == [], f"{fmu_path.name}: {problems}"


def test_simulate_fmu_runs_the_default_experiment(fmu_path):
    # Warnings and errors would reach fmpy's logger; a run that ends at the stop time with
    # finite outputs is what a user of simulate_fmu needs.
    result = simulate_fmu(str(fmu_path))
    assert len(result) > 10
    for name in result.dtype.names:
        if np.issubdtype(result[name].dtype, np.floating):
            assert np.all(np.isfinite(result[name])), f"{fmu_path.name}: {name} is not finite"
    experiment = read_model_description(str(fmu_path)).defaultExperiment
    assert math.isclose(result["time"][-1], float(experiment.stopTime)), f"{fmu_path.name} stopped at {result['time'][-1]}"


# --- The plant FMUs under simulate_fmu ------------------------------------------------------


@pytest.mark.parametrize("model_identifier", PLANTS)
def test_simulate_fmu_drives_each_plant_with_a_current_step(model_identifier):
    path = plant_path(model_identifier)
    result = simulate_fmu(str(path), stop_time=0.5, output_interval=1e-3, input=step_input(model_identifier, 2.0), output=["axis.position", "axis.speed"])
    before = result["time"] <= 0.05
    assert np.all(result["axis.speed"][before] == 0.0), "the axis moved before the step"
    assert result["axis.speed"][-1] > 0.0 and result["axis.position"][-1] > result["axis.position"][0], "a positive current did not move the axis positively"


@pytest.mark.parametrize("model_identifier", PLANTS)
def test_linear_configuration_by_parameter_file_and_by_flag_agree(model_identifier):
    path = str(plant_path(model_identifier))
    signal = step_input(model_identifier, 1.5)
    outputs = ["axis.position", "axis.speed", "motor.speed" if model_identifier == "ElevationPlant" else "motor1.speed"]
    by_file = simulate_fmu(path, stop_time=0.5, output_interval=1e-3, input=signal, output=outputs, start_values={"parameter_file": "linear.params"})
    by_flag = simulate_fmu(path, stop_time=0.5, output_interval=1e-3, input=signal, output=outputs, start_values={"linear_configuration": True})
    default = simulate_fmu(path, stop_time=0.5, output_interval=1e-3, input=signal, output=outputs)
    for name in outputs:
        assert np.array_equal(by_file[name], by_flag[name]), f"{model_identifier}: {name} differs between the two linear configurations"
    # And it is a different plant from the default one (friction, saturation are gone).
    assert not np.array_equal(by_file["axis.speed"], default["axis.speed"])


@pytest.mark.parametrize("model_identifier", PLANTS)
def test_linear_configuration_is_linear_and_the_default_is_not(model_identifier):
    # Homogeneity: twice the current gives exactly twice the response in the linear
    # configuration; with friction (the default) it does not.
    path = str(plant_path(model_identifier))
    outputs = ["axis.speed"]

    def run(amplitude, start_values):
        return simulate_fmu(path, stop_time=0.5, output_interval=1e-3, input=step_input(model_identifier, amplitude), output=outputs, start_values=start_values)["axis.speed"]

    linear = {"linear_configuration": True}
    assert relative_to_range(2.0 * run(1.0, linear), run(2.0, linear)) < 1e-12
    assert relative_to_range(2.0 * run(1.0, {}), run(2.0, {})) > 1e-3


@pytest.mark.parametrize("model_identifier", PLANTS)
def test_linear_configuration_does_not_depend_on_the_communication_step(model_identifier):
    path = str(plant_path(model_identifier))
    outputs = ["axis.position", "axis.speed", "motor.current" if model_identifier == "ElevationPlant" else "motor1.current"]
    signal = step_input(model_identifier, 1.0, at=0.1)
    coarse = simulate_fmu(path, stop_time=0.5, output_interval=1e-3, input=signal, output=outputs, start_values={"parameter_file": "linear.params"})
    fine = simulate_fmu(path, stop_time=0.5, output_interval=1e-4, input=signal, output=outputs, start_values={"parameter_file": "linear.params"})
    common = fine[::10]
    assert np.allclose(common["time"], coarse["time"], rtol=0, atol=1e-12)
    for name in outputs:
        assert relative_to_range(coarse[name], common[name]) < 1e-10, f"{model_identifier}: {name} depends on the step"


# --- Misuse through FMU2Slave -------------------------------------------------------------


def assert_error(call, logger, what):
    """The call raises fmpy's FMICallException with fmi2Error, and the FMU logged why."""
    with pytest.raises(FMICallException) as caught:
        call()
    assert caught.value.status == FMI2_ERROR, f"{what}: status {caught.value.status}, expected fmi2Error"
    assert logger.errors(), f"{what}: no error message through the logger"
    return logger.errors()


@pytest.mark.parametrize("model_identifier", ALL_FMUS)
def test_a_wrong_guid_raises_with_a_logged_message_and_does_not_crash(packaged, model_identifier):
    p = packaged(model_identifier)
    with pytest.raises(Exception, match="Failed to instantiate"):
        p.slave(guid="{00000000-0000-0000-0000-000000000000}")
    # The library still serves correct instances afterwards.
    fmu, _ = p.initialized()
    fmu.doStep(0.0, 1e-3)
    fmu.freeInstance()


@pytest.mark.parametrize("model_identifier", ALL_FMUS)
@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf])
def test_a_non_finite_input_is_an_error(packaged, model_identifier, bad):
    p = packaged(model_identifier)
    fmu, logger = p.initialized()
    name = A_REAL_INPUT[model_identifier]
    before = fmu.getReal([p.vr[name]])
    messages = assert_error(lambda: fmu.setReal([p.vr[name]], [bad]), logger, f"{name} = {bad}")
    assert any(name in m[2] for m in messages)
    assert fmu.getReal([p.vr[name]]) == before, "the rejected value was stored"
    fmu.freeInstance()


@pytest.mark.parametrize("model_identifier", ALL_FMUS)
def test_do_step_before_initialisation_is_an_error(packaged, model_identifier):
    fmu, logger = packaged(model_identifier).slave()
    assert_error(lambda: fmu.doStep(0.0, 1e-3), logger, "DoStep before initialisation")
    fmu.freeInstance()


@pytest.mark.parametrize("model_identifier", ALL_FMUS)
def test_do_step_after_terminate_and_a_second_terminate_are_errors(packaged, model_identifier):
    p = packaged(model_identifier)
    fmu, logger = p.initialized()
    fmu.doStep(0.0, 1e-3)
    fmu.terminate()
    assert_error(lambda: fmu.doStep(1e-3, 1e-3), logger, "DoStep after Terminate")
    fmu.freeInstance()
    fmu, logger = p.initialized()
    fmu.terminate()
    assert_error(fmu.terminate, logger, "second Terminate")
    fmu.freeInstance()


@pytest.mark.parametrize("model_identifier", ALL_FMUS)
def test_an_unknown_value_reference_is_an_error(packaged, model_identifier):
    p = packaged(model_identifier)
    unknown = max(p.vr.values()) + 1
    fmu, logger = p.initialized()
    assert_error(lambda: fmu.getReal([unknown]), logger, "GetReal of an unknown reference")
    fmu.freeInstance()
    fmu, logger = p.initialized()
    assert_error(lambda: fmu.setReal([unknown], [1.0]), logger, "SetReal of an unknown reference")
    fmu.freeInstance()


@pytest.mark.parametrize("model_identifier", ALL_FMUS)
@pytest.mark.parametrize("step", [-1e-3, 0.0])
def test_a_negative_or_zero_step_is_an_error(packaged, model_identifier, step):
    fmu, logger = packaged(model_identifier).initialized()
    assert_error(lambda: fmu.doStep(0.0, step), logger, f"step {step}")
    fmu.freeInstance()


@pytest.mark.parametrize("model_identifier", ALL_FMUS)
@pytest.mark.parametrize("step", [1e300, 2 * 86400.0])
def test_a_step_longer_than_a_day_is_an_error_at_once(packaged, model_identifier, step):
    # The audit's doStep(0, 1e300) ran for minutes: steps are computed in ~1 ms pieces.
    fmu, logger = packaged(model_identifier).initialized()
    started = time.monotonic()
    messages = assert_error(lambda: fmu.doStep(0.0, step), logger, f"step {step}")
    # A rejection takes microseconds; computing even a little of such a step takes seconds.
    assert time.monotonic() - started < 1.0
    assert any("longer than the longest step" in m[2] for m in messages)
    fmu.freeInstance()


@pytest.mark.parametrize("model_identifier", ALL_FMUS)
def test_a_wrong_communication_point_is_an_error(packaged, model_identifier):
    fmu, logger = packaged(model_identifier).initialized()
    fmu.doStep(0.0, 1e-3)
    messages = assert_error(lambda: fmu.doStep(0.5, 1e-3), logger, "DoStep at 0.5 when at 0.001")
    assert any("currentCommunicationPoint" in m[2] for m in messages)
    fmu.freeInstance()


# --- FMU states -----------------------------------------------------------------------------


def drive(p, model_identifier, fmu, start_ms, stop_ms):
    """Steps 1 ms at a time with commands that reverse the drive every second and returns
    every Real output at every step, as float64 bit patterns."""
    outputs = [p.vr[n] for n in p.names("output", "Real")]
    inputs = [p.vr[n] for n in current_inputs(model_identifier)]
    record = []
    for ms in range(start_ms, stop_ms):
        command = 1.5 * math.sin(2 * math.pi * ms * 1e-3) + 0.2 * math.sin(0.37 * ms)
        fmu.setReal(inputs, [command] * len(inputs))
        fmu.doStep(ms * 1e-3, 1e-3)
        record.append(fmu.getReal(outputs))
    return np.array(record).view(np.uint64)


@pytest.mark.parametrize("model_identifier", PLANTS)
def test_get_run_set_run_again_is_bitwise_identical(packaged, model_identifier):
    p = packaged(model_identifier)
    fmu, _ = p.initialized()
    drive(p, model_identifier, fmu, 0, 500)
    state = fmu.getFMUstate()
    first = drive(p, model_identifier, fmu, 500, 1500)
    fmu.setFMUstate(state)
    second = drive(p, model_identifier, fmu, 500, 1500)
    assert np.array_equal(first, second)
    assert not np.array_equal(first[0], first[-1]), "the outputs did not change"
    fmu.freeFMUstate(state)
    fmu.freeInstance()


@pytest.mark.parametrize("model_identifier", PLANTS)
def test_a_serialized_state_continues_identically_in_another_instance(packaged, model_identifier):
    p = packaged(model_identifier)
    original, _ = p.initialized("original")
    drive(p, model_identifier, original, 0, 500)
    state = original.getFMUstate()
    serialized = original.serializeFMUstate(state)
    other, _ = p.initialized("other")
    drive(p, model_identifier, other, 0, 123)
    restored = other.deSerializeFMUstate(serialized)
    other.setFMUstate(restored)
    assert np.array_equal(drive(p, model_identifier, original, 500, 1500), drive(p, model_identifier, other, 500, 1500))
    for fmu, s in ((original, state), (other, restored)):
        fmu.freeFMUstate(s)
        fmu.freeInstance()


# --- Sensors --------------------------------------------------------------------------------


def speed_output(model_identifier):
    return "motor.speed" if model_identifier == "ElevationPlant" else "motor1.speed"


def noise_record(model_identifier, seed, step):
    """Encoder error and motor speed signal of a plant at rest with noise on, from simulate_fmu
    with communication steps of `step` seconds over 2 s."""
    speed = speed_output(model_identifier)
    start_values = {"encoder.noise_rms": 0.5, f"{speed}_noise_rms": 0.05, "sensors.seed": seed, "encoder.bits": 0}
    return simulate_fmu(str(plant_path(model_identifier)), stop_time=2.0, step_size=step, output_interval=step, start_values=start_values, output=["axis.encoder_error", speed])


@pytest.mark.parametrize("model_identifier", PLANTS)
def test_sensor_noise_under_fmpy_has_its_rms_follows_its_seed_and_not_the_communication_step(model_identifier):
    speed = speed_output(model_identifier)
    millisecond = noise_record(model_identifier, 3, 1e-3)
    n = len(millisecond)
    # Relative standard error of a sample RMS: 1/sqrt(2 n); the bound is four of them.
    bound = 4.0 / math.sqrt(2.0 * n)
    rms = math.sqrt(np.mean(millisecond["axis.encoder_error"] ** 2))
    speed_rms = math.sqrt(np.mean(millisecond[speed] ** 2))
    assert abs(rms / 0.5 - 1.0) < bound, rms
    assert abs(speed_rms / 0.05 - 1.0) < bound, speed_rms
    assert np.array_equal(millisecond["axis.encoder_error"], noise_record(model_identifier, 3, 1e-3)["axis.encoder_error"])
    assert np.all(millisecond["axis.encoder_error"] != noise_record(model_identifier, 4, 1e-3)["axis.encoder_error"])
    # The same samples at the common instants for 0.5 ms and 2 ms steps: the noise is drawn per
    # sensor sample period, not per communication step.
    half = noise_record(model_identifier, 3, 0.5e-3)[::2]
    double = noise_record(model_identifier, 3, 2e-3)
    assert np.allclose(half["time"], millisecond["time"], rtol=0, atol=1e-9)
    assert np.allclose(half["axis.encoder_error"], millisecond["axis.encoder_error"], rtol=0, atol=1e-9)
    assert np.array_equal(half[speed], millisecond[speed])
    assert np.allclose(double["axis.encoder_error"], millisecond["axis.encoder_error"][::2], rtol=0, atol=1e-9)
    assert np.array_equal(double[speed], millisecond[speed][::2])


@pytest.mark.parametrize("model_identifier", PLANTS)
def test_a_rounding_count_has_zero_mean_error_where_truncation_has_minus_half_a_count(model_identifier):
    # A 14-bit encoder (79 arcsec counts) on an axis driven through many counts.
    count_arcsec = 360.0 * 3600.0 / 2**14
    means = {}
    description = read_model_description(str(plant_path(model_identifier)))
    count_mode = next(t for t in description.typeDefinitions if t.name == "EncoderCountMode")
    for mode in ("truncate", "round"):
        # fmpy takes an enumeration's start value as the item's integer value.
        value = next(int(item.value) for item in count_mode.items if item.name == mode)
        result = simulate_fmu(str(plant_path(model_identifier)), stop_time=2.0, output_interval=1e-3, input=step_input(model_identifier, 8.0, at=0.01, stop=2.0), start_values={"encoder.bits": 14, "encoder.count_mode": value}, output=["axis.encoder_error", "axis.position"])
        travelled = (result["axis.position"].max() - result["axis.position"].min()) * 3600.0 / count_arcsec
        assert travelled > 50, f"{model_identifier} moved only {travelled} counts"
        means[mode] = float(np.mean(result["axis.encoder_error"])) / count_arcsec
    assert abs(means["truncate"] + 0.5) < 0.05, means
    assert abs(means["round"]) < 0.05, means


# --- Silence --------------------------------------------------------------------------------


def test_the_fmus_write_nothing_to_stdout_or_stderr_even_when_misused(tmp_path):
    # The misuse script runs in its own interpreter so that its file descriptors 1 and 2 can be
    # captured whole, including anything the native code might write around Python.
    paths = [str(plant_path(p)) for p in PLANTS]
    report = tmp_path / "report.txt"
    completed = subprocess.run(
        [sys.executable, str(HERE / "silent_misuse.py"), str(report), *paths],
        capture_output=True,
        cwd=HERE,
        timeout=300,
    )
    summary = report.read_text() if report.exists() else "(no report)"
    assert completed.returncode == 0, f"the misuse script failed: {summary}"
    assert completed.stdout == b"", f"stdout: {completed.stdout!r}"
    assert completed.stderr == b"", f"stderr: {completed.stderr!r}"
    assert "deliberate errors" in summary
