"""The exchange of libcosim and ecos, written on top of the fmpy master's units
(coupled_master.py): at every communication point, read every connection's output from the units
as the last step left them, then set every input, then step every unit. The connections are the
archive's (its SystemStructure.ssd), the units are initialised as the Rust master initialises them,
and the clock is the engine's: with it, this master reproduces each engine bit for bit, which
shows that the engines differ from the Rust master by their exchange and clock alone."""

import io
import zipfile

import numpy as np
from lxml import etree

import coupled_master

SSD = {"ssd": "http://ssp-standard.org/SSP1/SystemStructureDescription",
       "ssc": "http://ssp-standard.org/SSP1/SystemStructureCommon"}


def libcosim_clock(step_s):
    """libcosim counts time in whole nanoseconds: t_k = k h_ns / 1e9, and each step is the
    difference of two such times, not h itself."""
    step_ns = int(round(step_s * 1e9))
    return lambda k: ((k * step_ns) / 1e9, ((k + 1) * step_ns) / 1e9 - (k * step_ns) / 1e9)


def ecos_clock(step_s):
    """ecos adds the step to a floating-point time."""
    times = [0.0]

    def clock(k):
        while len(times) <= k:
            times.append(times[-1] + step_s)
        return times[k], step_s

    return clock


def connections(archive):
    """The archive's connections between components: ((from element, connector), (to element,
    connector), factor or None)."""
    with zipfile.ZipFile(archive) as zipped:
        ssd = etree.parse(io.BytesIO(zipped.read("SystemStructure.ssd")))
    out = []
    for c in ssd.findall(".//ssd:Connection", SSD):
        transformation = c.find("ssc:LinearTransformation", SSD)
        factor = None if transformation is None else float(transformation.get("factor"))
        out.append(((c.get("startElement"), c.get("startConnector")), (c.get("endElement"), c.get("endConnector")),
                    factor))
    return out


def run(archive, config_path, commands_path, clock, steps, watched):
    """Runs the archive's antenna for `steps` steps and returns the `watched` (element, variable)
    values at every point, t_0 to t_steps."""
    antenna = coupled_master.CoupledAntenna(coupled_master.read_config(config_path),
                                            coupled_master.CommandTable.read(commands_path))
    units = {"AzimuthPlant": antenna.az_plant, "ElevationPlant": antenna.el_plant, "Wind": antenna.wind,
             "AzimuthController": antenna.az_ctrl, "ElevationController": antenna.el_ctrl,
             "Structure": antenna.structure}

    def vr(element, name):
        return units[element].variables[name].valueReference

    links = [(units[a], vr(a, x), units[b], vr(b, y), factor) for (a, x), (b, y), factor in connections(archive)]
    shown = [(units[element], vr(element, name)) for element, name in watched]
    rows = np.zeros((steps + 1, len(watched)))
    for k in range(steps + 1):
        rows[k] = [unit.fmu.getReal([ref])[0] for unit, ref in shown]
        if k == steps:
            break
        values = [source.fmu.getReal([ref])[0] for source, ref, _, _, _ in links]
        # A linear transformation as the engines apply it: offset added after the factor.
        values = [v if link[4] is None else v * link[4] + 0.0 for v, link in zip(values, links)]
        for (_, _, sink, ref, _), value in zip(links, values):
            sink.fmu.setReal([ref], [value])
        t, h = clock(k)
        for unit in antenna.units:
            unit.fmu.doStep(currentCommunicationPoint=t, communicationStepSize=h)
    antenna.close()
    return rows
