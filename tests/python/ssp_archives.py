"""The SSP archives of `antenna --ssp` for the tests, and two third-party engines that run them:
OSP's libcosim (`libcosimpy`) and Vico's ecos (`ecospy`), both from the Python registry.

Each runner returns the values of WATCHED at the communication points t_k = k h the engine
reports, as {k: row}, so that they line up with the Rust master's trace row for row."""

import ctypes
import os
import subprocess
import sys

import numpy as np

from conftest import REPOSITORY, antenna_command

# The variables compared with the Rust master's trace, with the trace's column of each
# (coupled_master.COLUMNS): the axes, the encoders and the beam offsets.
WATCHED = (("AzimuthPlant", "axis.position", 3), ("ElevationPlant", "axis.position", 4),
           ("AzimuthPlant", "axis.encoder_position", 5), ("ElevationPlant", "axis.encoder_position", 6),
           ("Structure", "beam.azimuth_offset", 15), ("Structure", "beam.elevation_offset", 16))
TRACE_COLUMNS = [column for _, _, column in WATCHED]


def export(folder, only, settings=()):
    """Writes the archives of the requirement scenarios whose names contain `only` (and
    plant.ssp) into `folder` with `antenna --ssp --export-only`, each `settings` a NAME=VALUE for
    `--set`; returns `folder`."""
    command = antenna_command() + ["--ssp", str(folder), "--export-only", "--only", only]
    for setting in settings:
        command += ["--set", setting]
    subprocess.run(command, cwd=REPOSITORY, check=True, capture_output=True)
    return folder


def run_libcosim(archive, step_s, end_s):
    """Runs `archive` in libcosim with its fixed-step algorithm. libcosim counts time in
    nanoseconds, so its steps are exactly `step_s` and its times k h to the nanosecond."""
    from libcosimpy.CosimEnums import CosimExecutionState
    from libcosimpy.CosimExecution import CosimExecution
    from libcosimpy.CosimLogging import CosimLogLevel, log_output_level
    from libcosimpy.CosimObserver import CosimObserver

    log_output_level(CosimLogLevel.ERROR)
    step_ns = int(round(step_s * 1e9))
    execution = CosimExecution.from_ssp_file(str(archive), step_size=step_ns)
    slaves = {info.name.decode(): info.index for info in execution.slave_infos()}
    observer = CosimObserver.create_last_value()
    execution.add_observer(observer)

    def reference(slave, name):
        return next(v.reference for v in execution.slave_variables(slaves[slave]) if v.name.decode() == name)

    watched = [(slaves[slave], reference(slave, name)) for slave, name, _ in WATCHED]
    rows = {}
    for _ in range(int(round(end_s / step_s))):
        assert execution.step(1)
        status = execution.status()
        assert status.state != CosimExecutionState.ERROR.value
        k = status.current_time // step_ns
        rows[k] = [observer.last_real_values(slave, [vr])[0] for slave, vr in watched]
    return rows


def load_ecos():
    """Imports ecospy, whose library needs the `tbb` wheel's libtbb: pip puts it in the
    environment's lib folder, which is not on the library path; loaded first and globally, it is
    the one the loader hands ecos."""
    ctypes.CDLL(os.path.join(sys.prefix, "lib", "libtbb.so.12"), mode=ctypes.RTLD_GLOBAL)
    from ecospy.EcosSimulation import EcosSimulation
    return EcosSimulation


# The controllers' command inputs, in the order of coupled_master.CommandTable.at's values.
COMMAND_INPUTS = ("AzimuthController::command.position", "AzimuthController::command.velocity",
                  "ElevationController::command.position", "ElevationController::command.velocity")


def run_ecos(archive, set_name, step_s, end_s, commands=None):
    """Runs `archive` in ecos, which applies the parameter sets named `set_name` (all of the
    archive's) at its initialisation. ecos adds its step to a floating-point time. With
    `commands` (a coupled_master.CommandTable: the archive's resources/commands.csv), the
    controllers are given the command at every point, as docs/ssp.md tells a user to."""
    EcosSimulation = load_ecos()
    simulation = EcosSimulation(ssp_path=str(archive), step_size=step_s)
    assert simulation.init(parameter_set=set_name)
    names = [f"{slave}::{name}" for slave, name, _ in WATCHED]
    rows = {}
    for k in range(int(round(end_s / step_s)) + 1):
        rows[k] = [simulation.get_real(name) for name in names]
        if commands is not None:
            for name, value in zip(COMMAND_INPUTS, commands.at(simulation.get_time())):
                simulation.set_real(name, value)
        simulation.step(1)
    simulation.terminate()
    return rows


def aligned(rows, trace):
    """The engine's rows and the trace's compared columns at the points both have."""
    steps = sorted(k for k in rows if k < len(trace))
    return np.array([rows[k] for k in steps]), trace[steps][:, TRACE_COLUMNS], np.array(steps)


def rust_trace(folder, scenario, settings=()):
    """Runs `scenario` with the Rust master (its own gust seed only, each of `settings` a
    NAME=VALUE for `--set`) and returns its trace; `folder` then also holds its command table."""
    command = antenna_command() + ["--no-build", "--only", scenario, "--seeds", "1", "--trace", str(folder),
                                   "--out", str(folder / "report")]
    for setting in settings:
        command += ["--set", setting]
    subprocess.run(command, cwd=REPOSITORY, check=True, capture_output=True)
    return np.loadtxt(folder / f"{scenario}.trace.csv", delimiter=",", skiprows=1)


def jitter_arcsec(values, steps, step_s, commands_path):
    """The requirement report's jitter figure (the worst 10 s RMS of the beam's pointing error
    after the first 10 s) of the compared columns `values` at the points `steps`."""
    sys.path.insert(0, str(REPOSITORY / "tools" / "fmu_container"))
    import antenna_container

    names = [f"{slave}.{name}" for slave, name, _ in WATCHED]
    result = np.zeros(len(steps), dtype=[("time", float)] + [(name, float) for name in names])
    result["time"] = steps * step_s
    for i, name in enumerate(names):
        result[name] = values[:, i]
    return antenna_container.jitter_arcsec(result, commands_path)
