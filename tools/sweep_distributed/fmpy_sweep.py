"""A small parameter sweep over the packaged FMUs from Python, for people whose master is fmpy:
the same Dask engine as the Rust sweeps, each task coupling the five FMUs with the project's fmpy
master (tests/python/coupled_master.py). The ranges come from the one parameter table,
docs/parameters.csv, like `antenna sweep`'s.

Each sample tracks at the sidereal rate at 45 deg elevation in the specification's normal wind
(the Req. 5 condition) and is judged by the worst RMS pointing error over 10 s windows after the
first 10 s, against the 15 arcsec limit. The fmpy master couples the drives, controllers and
wind (not the structure), so only parameters that set a variable of those FMUs or the wind
condition can be varied here.

    fmpy_sweep.py --address local --samples 8 --seconds 30 --out rows.csv
    fmpy_sweep.py --address tcp://SCHEDULER:8786 --vary azimuth.pinion_stiffness wind.mean_speed_factor ...
"""

import argparse
import csv
import math
import os
import pathlib
import site
import sys
import threading

import numpy as np

ROOT = pathlib.Path(__file__).resolve().parents[2]
MASTER = ROOT / "tests" / "python" / "coupled_master.py"
TABLE = ROOT / "docs" / "parameters.csv"
COUPLED_UNITS = ("AzimuthPlant", "ElevationPlant", "AzimuthController", "ElevationController", "Wind")
WIND_SETTINGS = ("wind.mean_speed_factor", "wind.roughness_factor", "wind.yaw", "wind.seed")
DEFAULT_VARY = ("azimuth.pinion_stiffness", "azimuth.bearing_coulomb_friction", "elevation.load_inertia",
                "wind.mean_speed_factor", "wind.seed")
# The Req. 5 condition of the Rust scenarios (tools/sim/src/scenario.rs): normal wind from 130 deg
# relative to the antenna, tracking from (30, 45) deg.
NORMAL_WIND = {"mean_speed": 9.8, "roughness_length": 0.0105, "yaw": 130.0}
START = (30.0, 45.0)
SIDEREAL_DEG_PER_S = 0.004
LIMIT_ARCSEC = 15.0
WINDOW_S = 10.0


def read_table(path=TABLE):
    """The parameter table: name -> row (floats for the numbers, targets split)."""
    with open(path) as f:
        rows = csv.DictReader(line for line in f if not line.startswith("#"))
        table = {}
        for row in rows:
            row = {k.strip(): v.strip() for k, v in row.items()}
            for key in ("default", "low", "high"):
                row[key] = float(row[key])
            row["targets"] = row["targets"].split()
            table[row["name"]] = row
        return table


def value_at(row, u):
    """The value at u in [0, 1] of a row's range, spread as its scale says (as the Rust sweep)."""
    low, high = row["low"], row["high"]
    if row["scale"] == "log":
        return math.exp(math.log(low) + u * (math.log(high) - math.log(low)))
    if row["scale"] == "integer":
        return min(low + math.floor(u * (high - low + 1.0)), high)
    return low + u * (high - low)


def latin_hypercube(samples, dimensions, seed):
    """A Latin hypercube in [0, 1)^d from numpy's PCG64 generator: drawn once by the driver, so the
    points do not depend on which worker runs them."""
    rng = np.random.Generator(np.random.PCG64(seed))
    strata = np.array([rng.permutation(samples) for _ in range(dimensions)]).T
    return (strata + rng.random((samples, dimensions))) / samples


def points(table, names, samples, seed):
    """Every sample's values of the varied parameters: a list of {name: value}."""
    for name in names:
        targets = table[name]["targets"]
        usable = all(t.split(":")[0] in COUPLED_UNITS or t in (f"scenario:{w}" for w in WIND_SETTINGS)
                     for t in targets)
        if not usable:
            raise ValueError(f"{name} sets {' '.join(targets)}, which the fmpy master does not couple")
    cube = latin_hypercube(samples, len(names), seed)
    return [{name: value_at(table[name], float(u)) for name, u in zip(names, row)} for row in cube]


_PATCH = threading.Lock()


def fmu_directory():
    """Where the driver finds the packaged FMUs (the workers are told the same path)."""
    return os.environ.get("MEERKAT_FMU_DIR", str(ROOT / "target" / "fmu"))


def run_sample(values, seconds, table_rows, fmu_dir):
    """One coupled run with fmpy: the worst 10 s RMS pointing error (arcsec) after the first 10 s."""
    if str(MASTER.parent) not in sys.path:
        sys.path.insert(0, str(MASTER.parent))
    import coupled_master

    # The master's own default is relative to where its file is, which on a worker is a copy.
    coupled_master.FMU_DIR = fmu_dir

    overrides = {}
    wind = dict(NORMAL_WIND, factor=1.0, roughness=1.0, seed=100)
    for name, value in values.items():
        for target in table_rows[name]["targets"]:
            unit, variable = target.split(":", 1)
            if unit == "scenario":
                key = {"wind.mean_speed_factor": "factor", "wind.roughness_factor": "roughness",
                       "wind.yaw": "yaw", "wind.seed": "seed"}[variable]
                wind[key] = value
            else:
                overrides.setdefault(unit, []).append((variable, value))
    rows = int(round((seconds + 1.0) / 0.1))
    table = coupled_master.CommandTable([(k * 0.1, START[0] + SIDEREAL_DEG_PER_S * k * 0.1,
                                          START[1] + SIDEREAL_DEG_PER_S * k * 0.1) for k in range(rows + 1)])
    config = {"step_s": 1e-3, "wind.mean_speed": wind["mean_speed"] * wind["factor"],
              "wind.roughness_length": wind["roughness_length"] * wind["roughness"],
              "wind.direction": (START[0] + wind["yaw"]) % 360.0, "seed": int(wind["seed"]), "end_s": seconds}

    class Unit(coupled_master.Unit):
        """The master's unit with this sample's parameter values set before initialisation."""

        def __init__(self, name, instance_name, start_time, unit_overrides, carried=None):
            super().__init__(name, instance_name, start_time, list(unit_overrides) + overrides.get(name, []),
                             carried=carried)

    with _PATCH:
        original, coupled_master.Unit = coupled_master.Unit, Unit
        try:
            antenna = coupled_master.CoupledAntenna(config, table)
        finally:
            coupled_master.Unit = original
    trace = []
    for _ in range(int(round(seconds / antenna.step_s))):
        antenna.step(table, trace)
    antenna.close()
    record = np.array(trace)
    cross = (record[:, 1] - record[:, 3]) * np.cos(np.radians(record[:, 4]))
    error = np.hypot(cross, record[:, 2] - record[:, 4]) * 3600.0
    return worst_window_rms(error[int(round(WINDOW_S / antenna.step_s)):], int(round(WINDOW_S / antenna.step_s)))


def worst_window_rms(error, window):
    """The largest RMS over every window of `window` consecutive samples."""
    if len(error) < window:
        raise ValueError("the run is shorter than a jitter window after the first 10 s")
    energy = np.concatenate(([0.0], np.cumsum(error * error)))
    return float(np.sqrt((energy[window:] - energy[:-window]).max() / window))


def run(address, samples, seed, seconds, names=DEFAULT_VARY, out=None, workers=None):
    """Runs the sweep on the Dask cluster at `address` (`local`: one on this machine); returns the
    rows [(sample, values, figure)] in sample order and writes them as CSV to `out` if given."""
    from dask.distributed import Client, LocalCluster

    table = read_table()
    fmu_dir = fmu_directory()
    names = list(names)
    sample_values = points(table, names, samples, seed)
    table_rows = {name: table[name] for name in names}
    cluster = None
    if address == "local":
        cluster = LocalCluster(n_workers=workers or os.cpu_count(), threads_per_worker=1, processes=True,
                               dashboard_address=None)
        address = cluster.scheduler_address
    try:
        with Client(address) as client:
            # The workers and the scheduler import this file, and through it the fmpy master, from
            # this checkout, which must be at the same path on every machine (as the FMUs).
            here = str(pathlib.Path(__file__).resolve().parent)
            client.run(site.addsitedir, here)
            # The scheduler unpickles the task graph too.
            client.run_on_scheduler(site.addsitedir, here)
            futures = [client.submit(run_sample, values, seconds, table_rows, fmu_dir, pure=False) for values in sample_values]
            figures = client.gather(futures)
    finally:
        if cluster is not None:
            cluster.close()
    rows = [(i, values, figure) for i, (values, figure) in enumerate(zip(sample_values, figures))]
    if out:
        with open(out, "w", newline="") as f:
            writer = csv.writer(f)
            writer.writerow(["sample", *names, "jitter_arcsec", "passed"])
            for i, values, figure in rows:
                writer.writerow([i, *(repr(values[n]) for n in names), repr(figure), figure < LIMIT_ARCSEC])
    return rows


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--address", default="local", help="the Dask scheduler (tcp://host:8786), or `local`")
    parser.add_argument("--workers", type=int, help="workers of a local cluster [default: one per core]")
    parser.add_argument("--samples", type=int, default=8)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--seconds", type=float, default=30.0, help="simulated seconds per sample (>= 20)")
    parser.add_argument("--vary", nargs="+", default=list(DEFAULT_VARY), help="names of docs/parameters.csv")
    parser.add_argument("--out", help="CSV of the rows")
    args = parser.parse_args()
    rows = run(args.address, args.samples, args.seed, args.seconds, args.vary, args.out, args.workers)
    passed = sum(figure < LIMIT_ARCSEC for _, _, figure in rows)
    figures = sorted(figure for _, _, figure in rows)
    print(f"{len(rows)} samples: {passed} within {LIMIT_ARCSEC} arcsec RMS; jitter median "
          f"{figures[len(figures) // 2]:.3f}, worst {figures[-1]:.3f} arcsec")
    return 0


if __name__ == "__main__":
    # Run as the module the workers import, so that its functions travel by name.
    sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))
    import fmpy_sweep

    sys.exit(fmpy_sweep.main())
