"""The whole antenna as one FMU: fmpy's FMU container (`fmpy.container_fmu`, a co-simulation master
written in C by fmpy's authors) around the six packaged FMUs, connected as the Rust master
connects them, with a scenario's settings as start values. Any FMI 2.0 master then loads one FMU
with four inputs (the pointing command) and the antenna's positions, encoder readings and beam
offsets as outputs; composed with other models, it is one block. Without its controllers
(`--without-controllers`) it is the plant of a controller of one's own: the motors' current
commands in, what a controller reads (encoders, motor speeds) and the beam out.

The scenario comes from the files the Rust master writes for another master (`antenna --trace DIR`
or `antenna --export-only --trace DIR`): DIR/<scenario>.config gives the wind and every parameter
override, DIR/<scenario>.commands.csv the commands (the first point sets where the axes start).
The container holds what the Rust master computes once before it steps: the load inertias the
plants keep once the structure's modes carry their share, and the start values of every unit.
It cannot scale the wind's loads on their way (`wind_load_scale`) or zero them (calm air), so
such scenarios are refused.

    antenna_container.py --config DIR/S.config --commands DIR/S.commands.csv --out Antenna.fmu
    antenna_container.py ... --simulate        # also run it with fmpy and print the Req. figure
    antenna_container.py ... --without-controllers   # the plant of a controller of one's own

fmpy 0.3.32 writes two things its own container binary reads otherwise, mended here after it has
written the archive: connections of FMI 2.0 units typed `Real` (the binary expects `Float64`), and
value references from 0 in the container's model description, where the binary counts from 1.
It also zips the folder into a file inside it, which can put part of the archive into itself;
the archive is written again without it, deterministically.
"""

import argparse
import json
import re
import sys
import tempfile
import uuid
import zipfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
try:
    import coupled_master  # installed from tools/fmpy_master (the test command does it in .venv)
except ImportError:
    sys.path.insert(0, str(ROOT / "tools" / "fmpy_master"))
    import coupled_master  # noqa: E402

from fmpy import read_model_description, simulate_fmu  # noqa: E402
from fmpy.container_fmu import Configuration  # noqa: E402
from fmpy.container_fmu.cli import create_container_fmu  # noqa: E402
from fmpy.container_fmu.config import Component, Connection  # noqa: E402
from fmpy.model_description import CoSimulation, DefaultExperiment, ModelDescription, ModelVariable, Unknown  # noqa: E402

UNITS = ("AzimuthPlant", "ElevationPlant", "AzimuthController", "ElevationController", "Wind", "Structure")

# The container's inputs: the pointing command, each to both of a controller's command inputs.
COMMAND_INPUTS = (("command.azimuth", "AzimuthController", "command.position", "deg"),
                  ("command.azimuth_rate", "AzimuthController", "command.velocity", "deg/s"),
                  ("command.elevation", "ElevationController", "command.position", "deg"),
                  ("command.elevation_rate", "ElevationController", "command.velocity", "deg/s"))

# Without the controllers (a user's own drive the antenna): the current commands are the inputs,
# and what a controller reads is among the outputs.
CURRENT_INPUTS = (("AzimuthPlant", "motor1.current_command"), ("AzimuthPlant", "motor2.current_command"),
                  ("ElevationPlant", "motor.current_command"))
MEASURED_OUTPUTS = (("AzimuthPlant", "motor1.speed"), ("AzimuthPlant", "motor2.speed"),
                    ("ElevationPlant", "motor.speed"))
CONTROLLERS = ("AzimuthController", "ElevationController")

# The container's outputs, named after the unit and variable they show.
OUTPUTS = (("AzimuthPlant", "axis.position"), ("ElevationPlant", "axis.position"),
           ("AzimuthPlant", "axis.encoder_position"), ("ElevationPlant", "axis.encoder_position"),
           ("Structure", "beam.azimuth_offset"), ("Structure", "beam.elevation_offset"),
           ("Wind", "wind.speed"))

# Unit to unit, as tools/sim/src/coupled.rs and tests/python/coupled_master.py connect them.
CONNECTIONS = (
    ("AzimuthPlant", "axis.encoder_position", "AzimuthController", "measured.position"),
    ("AzimuthPlant", "motor1.speed", "AzimuthController", "measured.motor1_speed"),
    ("AzimuthPlant", "motor2.speed", "AzimuthController", "measured.motor2_speed"),
    ("ElevationPlant", "axis.encoder_position", "ElevationController", "measured.position"),
    ("ElevationPlant", "motor.speed", "ElevationController", "measured.motor_speed"),
    ("AzimuthController", "motor1.current_command", "AzimuthPlant", "motor1.current_command"),
    ("AzimuthController", "motor2.current_command", "AzimuthPlant", "motor2.current_command"),
    ("ElevationController", "motor.current_command", "ElevationPlant", "motor.current_command"),
    ("AzimuthPlant", "axis.position", "Wind", "antenna.azimuth"),
    ("ElevationPlant", "axis.position", "Wind", "antenna.elevation"),
    ("ElevationPlant", "axis.position", "AzimuthPlant", "elevation"),
)
# With the structure: the wind's loads to it, the axes' motion to it, its modes back on the drives.
STRUCTURE_CONNECTIONS = (
    ("Wind", "torque.azimuth", "Structure", "torque.azimuth"),
    ("Wind", "torque.elevation", "Structure", "torque.elevation"),
    ("AzimuthPlant", "axis.speed", "Structure", "axis.azimuth_speed"),
    ("ElevationPlant", "axis.speed", "Structure", "axis.elevation_speed"),
    ("ElevationPlant", "axis.position", "Structure", "axis.elevation"),
) + tuple(("Wind", force, "Structure", load) for force, load in coupled_master.WIND_FORCES)
FEEDBACK_CONNECTIONS = (("Structure", "drive_torque.azimuth", "AzimuthPlant", "load.disturbance_torque"),
                        ("Structure", "drive_torque.elevation", "ElevationPlant", "load.disturbance_torque"))
RIGID_CONNECTIONS = (("Wind", "torque.azimuth", "AzimuthPlant", "load.disturbance_torque"),
                     ("Wind", "torque.elevation", "ElevationPlant", "load.disturbance_torque"))


class Refused(ValueError):
    """A scenario the container cannot hold."""


def start_values(config, table, fmu_dir):
    """Each unit's start values: the scenario's overrides, the wind condition, where the axes
    start, and the load inertias the plants keep once the structure's modes carry theirs."""
    if config["wind.mean_speed"] <= 0.0:
        raise Refused("calm air: the Rust master zeroes the wind unit's loads, which a container cannot")
    if config.get("wind_load_scale", 1.0) != 1.0:
        raise Refused(f"wind_load_scale = {config['wind_load_scale']}: a container passes the wind's loads unscaled")
    t0 = table.span()[0]
    az0, _, el0, _ = table.at(t0)
    values = {unit: dict(config["overrides"].get(unit, [])) for unit in UNITS}
    values["Wind"].update({"wind.mean_speed": config["wind.mean_speed"],
                           "wind.roughness_length": config["wind.roughness_length"],
                           "wind.direction": config["wind.direction"], "seed": int(config["seed"]), "spectrum": 1,
                           "antenna.azimuth": az0, "antenna.elevation": el0})
    values["AzimuthPlant"].update({"initial_position": az0, "elevation": el0})
    values["ElevationPlant"]["initial_position"] = el0
    values["AzimuthController"]["measured.position"] = az0
    values["ElevationController"]["measured.position"] = el0
    if config.get("structure", False) and config.get("structure_feedback", True):
        coupled_master.FMU_DIR = str(fmu_dir)
        probe = coupled_master.Unit("Structure", "probe", t0, list(values["Structure"].items()))
        carried = coupled_master.modal_inertias(probe)
        probe.close()
        try:
            split = coupled_master.carried_inertia_split(carried["zenith"], carried["horizon"])
        except ValueError as refusal:
            raise Refused(str(refusal)) from refusal
        for plant, amounts in split.items():
            for name, amount in amounts:
                values[plant][name] = values[plant][name] - amount
    return values


def build(config_path, commands_path, output, fmu_dir=None, controllers=True):
    """Writes the container FMU for a scenario's files to `output` and returns its path. Without
    `controllers`, the antenna is the plant of a controller of one's own: its inputs are the
    motors' current commands, and the encoders and motor speeds are among its outputs."""
    fmu_dir = Path(fmu_dir or coupled_master.FMU_DIR)
    config = coupled_master.read_config(config_path)
    table = coupled_master.CommandTable.read(commands_path)
    structure = config.get("structure", False)
    units = [u for u in UNITS if (u != "Structure" or structure) and (controllers or u not in CONTROLLERS)]
    values = start_values(config, table, fmu_dir)
    components = {u: Component(name=u, filename=fmu_dir / f"{u}.fmu",
                               modelDescription=read_model_description(fmu_dir / f"{u}.fmu")) for u in units}
    variables = {u: {v.name: v for v in components[u].modelDescription.modelVariables} for u in units}

    description = ModelDescription(
        fmiVersion="2.0", modelName="MeerKATAntenna",
        description=("The MeerKAT antenna positioner: two drives, " + ("their controllers, " if controllers else "")
                     + "the wind and the structure between encoders and beam, in fmpy's FMU container"),
        instantiationToken="{" + str(uuid.uuid5(uuid.NAMESPACE_URL, Path(config_path).read_text())) + "}",
        coSimulation=CoSimulation(modelIdentifier="container_fmu", fixedInternalStepSize=config["step_s"]),
        defaultExperiment=DefaultExperiment(startTime=table.span()[0], stopTime=config["end_s"],
                                            stepSize=config["step_s"]))
    # The units the variables name, as the units define them (each once).
    for component in components.values():
        for definition in component.modelDescription.unitDefinitions:
            if all(d.name != definition.name for d in description.unitDefinitions):
                description.unitDefinitions.append(definition)
    mappings = {}

    def declare(name, unit, variable, causality, start=None, unit_text=None):
        target = variables[unit][variable]
        kind = "Integer" if target.type == "Enumeration" else target.type
        parameter = causality == "parameter"
        declared = ModelVariable(name=name, type=kind, causality=causality,
                                 variability=("fixed" if parameter else "continuous" if kind == "Real" else "discrete"),
                                 initial="exact" if parameter else None,
                                 description=target.description)
        declared.unit = unit_text or target.unit
        if start is not None:
            declared.start = repr(float(start)) if kind == "Real" else str(int(start)) if kind == "Integer" else str(start)
        description.modelVariables.append(declared)
        mappings[declared] = [(components[unit], target)]

    t0 = table.span()[0]
    if controllers:
        for (name, unit, variable, unit_text), start in zip(COMMAND_INPUTS, table.at(t0)):
            declare(name, unit, variable, "input", start, unit_text)
    else:
        for unit, variable in CURRENT_INPUTS:
            declare(f"{unit}.{variable}", unit, variable, "input", 0.0)
    # Every start value is a parameter of the container, those of the units' inputs too: the
    # container sets them before initialisation, and the connections take those inputs over.
    for unit in units:
        for variable, value in values[unit].items():
            declare(f"{unit}.{variable}", unit, variable, "parameter", value)
    for unit, variable in OUTPUTS + (() if controllers else MEASURED_OUTPUTS):
        if unit in components:
            declare(f"{unit}.{variable}", unit, variable, "output")
    # Every output, computed at initialisation too; no dependencies given (each may depend on
    # every input, as FMI 2.0 reads a missing list).
    outputs = [v for v in description.modelVariables if v.causality == "output"]
    description.outputs = [Unknown(variable=v) for v in outputs]
    description.initialUnknowns = [Unknown(variable=v) for v in outputs]

    wiring = CONNECTIONS
    if structure:
        wiring += STRUCTURE_CONNECTIONS
        wiring += FEEDBACK_CONNECTIONS if config.get("structure_feedback", True) else RIGID_CONNECTIONS
    else:
        wiring += RIGID_CONNECTIONS
    connections = [Connection(startElement=components[a], startConnectors=[variables[a][x]],
                              endElement=components[b], endConnectors=[variables[b][y]])
                   for a, x, b, y in wiring
                   if a in variables and b in variables and x in variables[a] and y in variables[b]]
    configuration = Configuration(parallelDoStep=False, modelDescription=description,
                                  components=list(components.values()), connections=connections,
                                  variableMappings=mappings)
    output = Path(output)
    with tempfile.TemporaryDirectory() as scratch:
        create_container_fmu(configuration, Path(scratch), output)
    mend_fmpy_archive(output)
    return output


def mend_fmpy_archive(path):
    """The two mends of the module documentation, applied to the archive in place. The archive is
    written again with its files in name order, fixed timestamps and modes, and no folder
    entries, so that the same scenario and FMUs give the same bytes, as `cargo xtask package`
    does for the FMUs themselves."""
    types = {"Real": "Float64", "Integer": "Int32", "Enumeration": "Int32"}
    mended = path.with_suffix(".mending")
    with zipfile.ZipFile(path) as source, zipfile.ZipFile(mended, "w") as target:
        # fmpy zips the folder into a file inside that folder, which may sweep in a part of
        # itself as Container.zip: that is not the FMU's.
        for name in sorted(n for n in source.namelist() if not n.endswith("/") and n != "Container.zip"):
            data = source.read(name)
            if name == "resources/container.json":
                layout = json.loads(data)
                for entry in layout["connections"] + layout["variables"]:
                    entry["variableType"] = types.get(entry["variableType"], entry["variableType"])
                data = json.dumps(layout, indent=1).encode()
            elif name == "modelDescription.xml":
                data = re.sub(rb'valueReference="(\d+)"', lambda m: b'valueReference="%d"' % (int(m.group(1)) + 1), data)
            entry = zipfile.ZipInfo(name, date_time=FIXED_TIMESTAMP)
            entry.compress_type = zipfile.ZIP_DEFLATED
            entry.external_attr = (0o755 if name.endswith((".so", ".dylib", ".dll")) else 0o644) << 16
            target.writestr(entry, data)
    mended.replace(path)


# The earliest time a zip entry can hold, for every entry.
FIXED_TIMESTAMP = (1980, 1, 1, 0, 0, 0)


def simulate(container, commands_path, end_s, step_s=1e-3):
    """Runs the container with fmpy, the commands sampled at every communication point, and
    returns the trace: time, the command, the axes, the encoders, the beam offsets."""
    table = coupled_master.CommandTable.read(commands_path)
    t0 = table.span()[0]
    steps = int(round((end_s - t0) / step_s))
    times = [t0 + k * step_s for k in range(steps + 1)]
    signals = np.array([(t,) + tuple(table.at(t)) for t in times],
                       dtype=[("time", np.float64)] + [(name, np.float64) for name, *_ in COMMAND_INPUTS])
    declared = {v.name for v in read_model_description(str(container)).modelVariables}
    outputs = [name for name, *_ in COMMAND_INPUTS] + [f"{u}.{v}" for u, v in OUTPUTS if f"{u}.{v}" in declared]
    return simulate_fmu(str(container), start_time=t0, stop_time=t0 + steps * step_s, step_size=step_s,
                        output_interval=step_s, input=signals, output=outputs)


def jitter_arcsec(result, commands_path, window_s=10.0, after_s=10.0):
    """The worst jitter after centring over `window_s` windows after the first `after_s`, as the
    requirement report judges it: the RMS of the beam's on-sky error vector about its own mean in
    each window, against the commands as the table gives them (fmpy feeds the container its
    samples interpolated at its own times)."""
    table = coupled_master.CommandTable.read(commands_path)
    command = np.array([table.at(t) for t in result["time"]])
    az, el = result["AzimuthPlant.axis.position"], result["ElevationPlant.axis.position"]
    # Without the structure (the paper's antenna) the beam is the load-side axes.
    names = result.dtype.names
    offsets = [result[n] if n in names else 0.0 for n in ("Structure.beam.azimuth_offset", "Structure.beam.elevation_offset")]
    cross = (command[:, 0] - az) * np.cos(np.radians(el)) * 3600.0 - offsets[0]
    elevation = (command[:, 2] - el) * 3600.0 - offsets[1]
    dt = result["time"][1] - result["time"][0]
    window, skip = int(round(window_s / dt)), int(round(after_s / dt))
    return coupled_master.worst_centred_rms(cross[skip:], elevation[skip:], window)


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--config", required=True, help="DIR/<scenario>.config from `antenna --trace DIR`")
    parser.add_argument("--commands", required=True, help="DIR/<scenario>.commands.csv")
    parser.add_argument("--out", required=True, help="the container FMU to write")
    parser.add_argument("--simulate", action="store_true", help="also run it with fmpy and print the jitter")
    parser.add_argument("--without-controllers", action="store_true",
                        help="leave the controllers out: the motors' current commands are the inputs")
    args = parser.parse_args()
    if args.simulate and args.without_controllers:
        parser.error("--simulate needs the controllers (without them, couple your own)")
    try:
        container = build(args.config, args.commands, args.out, controllers=not args.without_controllers)
    except Refused as refusal:
        parser.error(str(refusal))
    print(f"wrote {container}")
    if args.simulate:
        end_s = coupled_master.read_config(args.config)["end_s"]
        result = simulate(container, args.commands, end_s)
        print(f"jitter after the first 10 s: {jitter_arcsec(result, args.commands):.3f} arcsec RMS (worst 10 s window)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
