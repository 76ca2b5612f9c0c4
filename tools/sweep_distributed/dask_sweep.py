"""Runs an `antenna sweep` on a Dask cluster: the sweep is split into batches of consecutive
samples, each batch runs on a worker as the Rust master (`antenna sweep ... --batch i/n
--threads 1`, native code), and the batches' rows are gathered in order into DIR/sweep.csv, the
same bytes a local run writes; then `antenna sweep ... --report-only` writes the report.

Usage (the arguments after `--` are those of `antenna sweep`):

    dask_sweep.py --address tcp://SCHEDULER:8786 --out DIR [--batches B] [--antenna PATH] -- --samples N --seed S ...
    dask_sweep.py --address local [--workers W] --out DIR -- --samples N ...

`antenna sweep ... --engine dask --address ADDRESS` calls this script (docs/sweeps.md). Every
worker needs the `antenna` binary and the packaged FMUs at the same paths as here (a shared
file system, or the same checkout built on each machine); MEERKAT_FMU_DIR is passed on.
"""

import argparse
import os
import pathlib
import re
import site
import subprocess
import sys
import tempfile
import time

ROOT = pathlib.Path(__file__).resolve().parents[2]


def run_batch(antenna, sweep_args, index, batches, environment):
    """On a worker: runs batch `index` of `batches` with the Rust master on one thread and
    returns its CSV bytes, its wall-clock time and its peak memory (bytes, from the master)."""
    with tempfile.TemporaryDirectory(prefix="antenna-batch-") as folder:
        command = [str(antenna), "sweep", *sweep_args, "--batch", f"{index}/{batches}", "--threads", "1",
                   "--no-build", "--out", folder]
        started = time.perf_counter()
        done = subprocess.run(command, capture_output=True, text=True, env={**os.environ, **environment})
        wall = time.perf_counter() - started
        if done.returncode != 0:
            raise RuntimeError(f"batch {index}/{batches} failed ({done.returncode}): {done.stderr.strip()}")
        memory = re.search(r"peak memory (\d+) MB", done.stderr)
        rows = pathlib.Path(folder, f"batch-{index}-of-{batches}.csv").read_bytes()
        return rows, wall, int(memory.group(1)) * 1_000_000 if memory else None


def absolute_paths(sweep_args):
    """The sweep's arguments with the sweep file's path made absolute, so that workers in other
    folders find it."""
    args = list(sweep_args)
    for i, arg in enumerate(args[:-1]):
        if arg == "--sweep-file":
            args[i + 1] = str(pathlib.Path(args[i + 1]).resolve())
    return args


def gather(client, antenna, sweep_args, batches, out):
    """Submits the batches, writes their rows in batch order into out/sweep.csv as each arrives
    in turn (the driver holds only the batches that finished early), and returns the batches'
    wall-clock times and peak memories."""
    environment = {key: os.environ[key] for key in ("MEERKAT_FMU_DIR",) if key in os.environ}
    futures = [client.submit(run_batch, str(antenna), sweep_args, i, batches, environment, pure=False, retries=1)
               for i in range(batches)]
    walls, memories = [], []
    header = None
    with open(out / "sweep.csv", "wb") as target:
        for i, future in enumerate(futures):
            rows, wall, memory = future.result()
            first, _, body = rows.partition(b"\n")
            if header is None:
                header = first
                target.write(first + b"\n")
            elif first != header:
                raise RuntimeError(f"batch {i} has another header than batch 0: the workers run different tables")
            target.write(body)
            walls.append(wall)
            memories.append(memory)
            future.release()
    return walls, memories


def run(address, out, sweep_args, antenna, batches=0, workers=None):
    """Runs the sweep on the cluster at `address` (or a local one for `local`), writes
    out/sweep.csv and the report; returns a summary dictionary."""
    from dask.distributed import Client, LocalCluster

    out = pathlib.Path(out).resolve()
    out.mkdir(parents=True, exist_ok=True)
    sweep_args = absolute_paths(sweep_args)
    cluster = None
    if address == "local":
        cluster = LocalCluster(n_workers=workers or os.cpu_count(), threads_per_worker=1, processes=True,
                               dashboard_address=None)
        address = cluster.scheduler_address
    try:
        with Client(address) as client:
            # The workers and the scheduler import the batch function from this checkout, at the
            # same path on every machine (as the antenna binary and the FMUs).
            here = str(pathlib.Path(__file__).resolve().parent)
            client.run(site.addsitedir, here)
            # The scheduler unpickles the task graph too.
            client.run_on_scheduler(site.addsitedir, here)
            threads = sum(client.nthreads().values())
            batches = batches or 4 * threads
            started = time.perf_counter()
            walls, memories = gather(client, antenna, sweep_args, batches, out)
            wall = time.perf_counter() - started
    finally:
        if cluster is not None:
            cluster.close()
    report = subprocess.run([str(antenna), "sweep", *sweep_args, "--report-only", "--no-build", "--out", str(out)],
                            capture_output=True, text=True)
    if report.returncode != 0:
        raise RuntimeError(f"the report failed: {report.stderr.strip()}")
    known = [m for m in memories if m is not None]
    return {
        "address": address,
        "worker_threads": threads,
        "batches": batches,
        "wall_s": wall,
        "batch_wall_s": sum(walls),
        "peak_memory_per_worker_bytes": max(known) if known else None,
        "report": report.stdout,
    }


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--engine", default="dask", choices=["dask"], help="the distributed engine (Dask only)")
    parser.add_argument("--address", required=True, help="the scheduler (tcp://host:8786), or `local`")
    parser.add_argument("--workers", type=int, help="workers of a local cluster [default: one per core]")
    parser.add_argument("--batches", type=int, default=0, help="batches [default: 0 = four per worker thread]")
    parser.add_argument("--out", required=True, help="folder for sweep.csv and the report")
    parser.add_argument("--antenna", default=str(ROOT / "target" / "release" / "antenna"),
                        help="the antenna binary, at this path on every worker")
    parser.add_argument("sweep_args", nargs=argparse.REMAINDER, help="-- then the arguments of `antenna sweep`")
    args = parser.parse_args()
    sweep_args = args.sweep_args[1:] if args.sweep_args[:1] == ["--"] else args.sweep_args
    try:
        summary = run(args.address, args.out, sweep_args, args.antenna, args.batches, args.workers)
    except Exception as error:  # noqa: BLE001 - every failure ends as one line and exit code 2
        print(f"dask_sweep: error: {error}", file=sys.stderr)
        return 2
    print(summary["report"], end="")
    memory = summary["peak_memory_per_worker_bytes"]
    # What the engine adds: the wall-clock time beyond the batches' own, spread over the workers
    # (scheduling, transfers, gathering, and the last batches waiting for each other).
    busy = summary["batch_wall_s"] / summary["worker_threads"]
    print(f"{summary['batches']} batches on {summary['worker_threads']} worker threads at {summary['address']}: "
          f"{summary['wall_s']:.1f} s wall-clock (batches {summary['batch_wall_s']:.1f} s in all, the engine's "
          f"own time {summary['wall_s'] - busy:.1f} s = {100 * (summary['wall_s'] / busy - 1):.1f} %); "
          f"peak memory per worker {memory / 1e6 if memory else float('nan'):.0f} MB")
    return 0


if __name__ == "__main__":
    # Run as the module the workers import, so that its functions travel by name.
    sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))
    import dask_sweep

    sys.exit(dask_sweep.main())
