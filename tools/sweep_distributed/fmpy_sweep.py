"""A small parameter sweep over the packaged FMUs from Python, for people whose master is fmpy:
the same Dask engine as the Rust sweeps, each task coupling the realistic antenna's six FMUs with
the project's fmpy master (tools/fmpy_master/coupled_master.py). The ranges come from the one parameter
table, docs/parameters.csv, like `antenna sweep`'s.

Each sample is the antenna `antenna --set NAME=VALUE ...` runs at the sample's values: the driver
has the Rust binary export the sample's configuration (`--export-only`, the files `antenna
--trace` writes for another master: every parameter override, the wind, the structure's modes
file where the values change the modes), so that one piece of code turns a point of the table
into an antenna, and the tasks run it with fmpy. It tracks at the sidereal rate at 45 deg
elevation in the specification's normal wind (the Req. 5 condition) and is judged by the worst
RMS of the beam's pointing error over 10 s windows after the first 10 s, against the 15 arcsec
limit. Every parameter of the table can be varied.

    fmpy_sweep.py --address local --samples 8 --seconds 30 --out rows.csv
    fmpy_sweep.py --address tcp://SCHEDULER:8786 --vary azimuth.pinion_stiffness wind.mean_speed_factor ...
"""

import argparse
import csv
import math
import os
import pathlib
import site
import subprocess
import sys
import tempfile

import numpy as np

ROOT = pathlib.Path(__file__).resolve().parents[2]
MASTER = ROOT / "tools" / "fmpy_master" / "coupled_master.py"
try:
    import coupled_master  # installed from tools/fmpy_master (the test command does it in .venv)
except ImportError:
    sys.path.insert(0, str(MASTER.parent))
    import coupled_master  # noqa: E402
TABLE = ROOT / "docs" / "parameters.csv"
DEFAULT_VARY = ("azimuth.pinion_stiffness", "azimuth.bearing_coulomb_friction", "elevation.load_inertia",
                "structure.stiffness", "wind.mean_speed_factor", "wind.seed")
# The Req. 5 condition of the Rust scenarios (the specification's normal wind, `antenna --wind
# normal`), tracking from (30, 45) deg.
START = (30.0, 45.0)
# The gust seed of every sample, unless `wind.seed` is varied.
SEED = 100
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
    unknown = [name for name in names if name not in table]
    if unknown:
        raise ValueError(f"not parameters of {TABLE}: {', '.join(unknown)}")
    cube = latin_hypercube(samples, len(names), seed)
    return [{name: value_at(table[name], float(u)) for name, u in zip(names, row)} for row in cube]


def fmu_directory():
    """Where the driver finds the packaged FMUs (the workers are told the same path)."""
    return os.environ.get("MEERKAT_FMU_DIR", str(ROOT / "target" / "fmu"))


def antenna_command():
    """The Rust master, before its arguments: the binary ANTENNA_BIN names (the test command
    sets it to the one it built, so that no run waits for cargo's lock), else `cargo run`."""
    binary = os.environ.get("ANTENNA_BIN")
    if binary:
        return [binary]
    return ["cargo", "run", "--release", "--quiet", "-p", "antenna-cli", "--bin", "antenna", "--"]


def commands_text(seconds):
    """The sidereal tracking table of every sample, one row every 0.1 s past the run's end."""
    rows = int(round((seconds + 1.0) / 0.1))
    az, el = START
    return "time_s,azimuth_deg,elevation_deg\n" + "".join(
        f"{k * 0.1!r},{az + SIDEREAL_DEG_PER_S * (k * 0.1)!r},{el + SIDEREAL_DEG_PER_S * (k * 0.1)!r}\n"
        for k in range(rows + 1))


def export_sample(values, seconds, folder):
    """The files of one sample as the Rust master writes them for another master (`antenna
    --export-only`): {"config": text, "commands": text, "modes": text or None}. `folder` is
    left with them."""
    folder = pathlib.Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    commands = folder / "sample.csv"
    commands.write_text(commands_text(seconds))
    settings = [arg for name, value in values.items() for arg in ("--set", f"{name}={value!r}")]
    subprocess.run(
        antenna_command() + ["--no-build", "--commands", str(commands), "--wind", "normal", "--seed", str(SEED),
                             "--export-only", "--trace", str(folder)] + settings,
        cwd=ROOT, check=True, capture_output=True, text=True,
    )
    modes = folder / "structure_modes.params"
    return {"config": (folder / "sample.config").read_text(), "commands": (folder / "sample.commands.csv").read_text(),
            "modes": modes.read_text() if modes.is_file() else None}


def run_sample(files, seconds, fmu_dir):
    """One coupled run with fmpy of a sample's files (`export_sample`): the worst 10 s RMS of
    the beam's pointing error (arcsec) after the first 10 s."""
    # The master's own default is relative to where its file is, which on a worker is a copy.
    coupled_master.FMU_DIR = fmu_dir
    config = coupled_master.parse_config(files["config"])
    with tempfile.TemporaryDirectory() as scratch:
        if files["modes"] is not None:
            # The driver's modes file is on the driver's disk: this task's copy is on its own.
            modes = pathlib.Path(scratch) / "structure_modes.params"
            modes.write_text(files["modes"])
            config["overrides"]["Structure"] = [
                (name, str(modes) if name == "modes_file" else value) for name, value in config["overrides"]["Structure"]]
        table_path = pathlib.Path(scratch) / "commands.csv"
        table_path.write_text(files["commands"])
        table = coupled_master.CommandTable.read(table_path)
        antenna = coupled_master.CoupledAntenna(config, table)
        trace = []
        for _ in range(int(round(seconds / antenna.step_s))):
            antenna.step(table, trace)
        antenna.close()
    return jitter_after_first_window(np.array(trace), antenna.step_s)


def jitter_after_first_window(record, step_s):
    """The worst 10 s jitter after centring (arcsec RMS about each window's mean) after the first
    10 s of a trace in the columns of coupled_master.COLUMNS: command minus axis, less the
    structure's beam offsets, on the sky, as the Rust report judges it."""
    cross = (record[:, 1] - record[:, 3]) * np.cos(np.radians(record[:, 4])) * 3600.0 - record[:, 15]
    elevation = (record[:, 2] - record[:, 4]) * 3600.0 - record[:, 16]
    window = int(round(WINDOW_S / step_s))
    if len(cross) < 2 * window:
        raise ValueError("the run is shorter than a jitter window after the first 10 s")
    return coupled_master.worst_centred_rms(cross[window:], elevation[window:], window)


def run(address, samples, seed, seconds, names=DEFAULT_VARY, out=None, workers=None):
    """Runs the sweep on the Dask cluster at `address` (`local`: one on this machine); returns the
    rows [(sample, values, figure)] in sample order and writes them as CSV to `out` if given."""
    from dask.distributed import Client, LocalCluster

    table = read_table()
    fmu_dir = fmu_directory()
    names = list(names)
    sample_values = points(table, names, samples, seed)
    with tempfile.TemporaryDirectory() as exports:
        sample_files = [export_sample(values, seconds, pathlib.Path(exports) / f"sample-{i}")
                        for i, values in enumerate(sample_values)]
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
            futures = [client.submit(run_sample, files, seconds, fmu_dir, pure=False) for files in sample_files]
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
