"""The hold scenario at 45 deg in normal wind (Req. 5), exported with `antenna --ssp`, run by two
third-party co-simulation engines from the Python registry, OSP's libcosim and Vico's ecos, and
compared with the Rust master's trace of the same scenario.

Both engines step the six FMUs with the same step and the same parameter values as the Rust
master, but exchange values differently: they step every unit, then read all outputs and set all
inputs at once, so an output that depends directly on an input (the wind's torques on the
pointing, the structure's drive torques on the loads) reaches the next unit computed from the
previous point's inputs. The Rust master reads those outputs after setting the inputs of the same
point. That exchange, not the archive, is why they agree closely and not bit for bit; the
tolerances are a little over what was measured (docs/ssp.md)."""

import zipfile

import numpy as np
import pytest

import coupled_master
import jacobi_master
import ssp_archives

SCENARIO = "hold-el45-normal-wind"
STEP_S, END_S = 1e-3, 70.0
# The jitter window's start (Req. 5). Before it, while the antenna settles on its encoders in the
# gusts, the exchange shows most: up to 4.9e-3 arcsec on the beam in the first seconds.
WINDOW_START = 10_000
# One count of the 25-bit encoders, deg.
COUNT_DEG = 360.0 / 2**25
# ecos is covered in the test command by its tracking test below; its runs of the hold archive
# (with libcosim's, the same comparisons) are in the long tier.
ENGINES = ["libcosim", pytest.param("ecos", marks=pytest.mark.long)]

RUNNERS = {
    "libcosim": lambda archive: ssp_archives.run_libcosim(archive, STEP_S, END_S),
    # The archive's parameter sets are named after the scenario, as an identifier.
    "ecos": lambda archive: ssp_archives.run_ecos(archive, SCENARIO.replace("-", "_"), STEP_S, END_S),
}


@pytest.fixture(scope="module")
def scenarios(tmp_path_factory):
    """The archive and the Rust master's trace of the hold scenario, made once when first asked
    for: `realistic`, the realistic antenna, and `truncating`, the same with truncating encoders
    (`encoder.count_mode = 1`), which leaves an engine that ignores enumerations nothing to
    ignore."""
    made = {}

    def get(kind):
        if kind not in made:
            folder = tmp_path_factory.mktemp(kind)
            settings = ["encoder.count_mode=1"] if kind == "truncating" else []
            ssp_archives.export(folder, SCENARIO, settings)
            made[kind] = folder, ssp_archives.rust_trace(folder, SCENARIO, settings)
        return made[kind]

    return get


ENGINE_RUNS = {}


def engine_run(engine, folder, trace):
    """The engine's run of the archive in `folder` (once per archive), lined up with the Rust
    master's `trace`, and the jitter figures of both."""
    if (engine, folder) not in ENGINE_RUNS:
        values, rust, steps = ssp_archives.aligned(RUNNERS[engine](folder / f"{SCENARIO}.ssp"), trace)
        commands = folder / f"{SCENARIO}.commands.csv"
        jitter = [ssp_archives.jitter_arcsec(v, steps, STEP_S, commands) for v in (values, rust)]
        ENGINE_RUNS[engine, folder] = values, rust, steps, jitter
    return ENGINE_RUNS[engine, folder]


@pytest.mark.parametrize("engine", ENGINES)
def test_a_third_party_engine_runs_the_hold_archive_as_the_rust_master_up_to_its_exchange(engine, scenarios):
    """Measured over the jitter window: the axes within 7.5e-7 deg, the encoders within a count
    (a count flips a step earlier or later), the beam within 7.9e-4 arcsec; the jitter figure
    within 4.5e-5 arcsec (8.728636 arcsec in both engines against 8.728593)."""
    values, rust, steps, (engine_jitter, rust_jitter) = engine_run(engine, *scenarios("truncating"))
    window = steps >= WINDOW_START
    difference = np.abs(values - rust)[window].max(axis=0)
    assert np.all(difference[:2] <= 1e-6), (engine, difference)
    assert np.all(difference[2:4] <= COUNT_DEG * 1.001), (engine, difference)
    assert np.all(difference[4:] <= 1e-3), (engine, difference)
    assert abs(engine_jitter - rust_jitter) <= 1e-4, (engine, engine_jitter, rust_jitter)


@pytest.mark.parametrize("engine", ENGINES)
def test_an_engine_that_ignores_enumerations_keeps_the_realistic_antennas_rounding_encoder(engine, scenarios):
    """Both engines ignore FMI 2.0 enumerations, and with them the plants' `encoder.count_mode`;
    the archive also binds its Integer twin, `encoder.count_mode_number`, which they honour. The
    realistic antenna's encoders then round in the engines as in the Rust master: the encoders
    agree within a count and the jitter within what the exchange moves it by, 2e-4 arcsec (without
    the twin they truncated and the jitter came out 0.0226 arcsec low, a hundred times that).
    Measured: libcosim 0.972324 arcsec against the Rust master's 0.972431 (1.07e-4: its
    whole-nanosecond clock and every-output-then-every-input exchange, on wind loads that the
    feed support's drag raised by about a fifth).
    The beam agrees within 8e-3 arcsec (measured 5.7e-3 on the azimuth offset, 7.9e-4 on the
    truncating archive above: the engines' exchange, where an encoder count that flips a step
    apart changes the controller's command for that step; a truncating count, which the twin is
    there to avoid, would move the beam by half a count, 0.019 arcsec)."""
    values, rust, steps, (engine_jitter, rust_jitter) = engine_run(engine, *scenarios("realistic"))
    assert abs(engine_jitter - rust_jitter) <= 2e-4, (engine, engine_jitter, rust_jitter)
    window = steps >= WINDOW_START
    difference = np.abs(values - rust)[window].max(axis=0)
    assert np.all(difference[2:4] <= COUNT_DEG * 1.001), (engine, difference)
    assert np.all(difference[4:] <= 8e-3), (engine, difference)


@pytest.mark.parametrize("engine", ENGINES)
def test_each_engine_is_the_rust_masters_coupling_with_its_own_exchange_and_clock_bit_for_bit(engine, scenarios):
    """The cause of the differences above: the archive's connections, exchanged as the engines
    exchange them (every output read, then every input set, then every unit stepped) on the
    engine's clock (libcosim: whole nanoseconds, each step the difference of two times; ecos: the
    step added to a floating-point time), over the fmpy master's units initialised as the Rust
    master initialises them, give the engine's run bit for bit (the first 20 s)."""
    folder, trace = scenarios("truncating")
    values, _, steps, _ = engine_run(engine, folder, trace)
    clock = jacobi_master.libcosim_clock(STEP_S) if engine == "libcosim" else jacobi_master.ecos_clock(STEP_S)
    watched = [(element, name) for element, name, _ in ssp_archives.WATCHED]
    ours = jacobi_master.run(folder / f"{SCENARIO}.ssp", folder / f"{SCENARIO}.config",
                             folder / f"{SCENARIO}.commands.csv", clock, 20_000, watched)
    compared = steps <= 20_000
    assert np.array_equal(ours[steps[compared]], values[compared]), engine


def test_every_archive_loads_and_runs_in_both_engines(tmp_path):
    """The tracking archives (their command held at the start, where no one feeds it) and the
    plant (its current commands open) load and run in both engines, with the parameters bound:
    the azimuth stays within 0.01 deg of the scenario's 30 deg (it gives some 0.002 deg to the
    first gusts), far from the FMU's default."""
    folder = ssp_archives.export(tmp_path, "el45-normal-wind")
    archives = sorted(folder.glob("*.ssp"))
    assert len(archives) == 4
    for archive in archives:
        scenario = archive.stem if archive.stem != "plant" else "hold-el45-normal-wind-plant"
        for engine, rows in (("libcosim", ssp_archives.run_libcosim(archive, STEP_S, 0.1)),
                             ("ecos", ssp_archives.run_ecos(archive, scenario.replace("-", "_").replace(".", "_"),
                                                            STEP_S, 0.1))):
            azimuth = np.array([row[0] for _, row in sorted(rows.items())])
            assert len(azimuth) >= 100 and np.all(np.abs(azimuth - 30.0) < 0.01), (archive.name, engine)


def test_ecos_tracks_at_the_sidereal_rate_as_the_rust_master_when_fed_the_archives_table(tmp_path):
    """A moving command comes as its table (SSP 1.0 has no signal source): fed to the controllers
    at every point, the tracking scenario of Req. 5 agrees as the hold does (truncating encoders,
    from 10 s; measured: beam within 6.5e-4 arcsec, jitter 8.845694 against 8.845671 arcsec)."""
    scenario, settings = "track-sidereal-el45-normal-wind", ["encoder.count_mode=1"]
    ssp_archives.export(tmp_path, scenario, settings)
    trace = ssp_archives.rust_trace(tmp_path, scenario, settings)
    archive = tmp_path / f"{scenario}.ssp"
    with zipfile.ZipFile(archive) as zipped:
        (tmp_path / "archived-commands.csv").write_bytes(zipped.read("resources/commands.csv"))
    table = coupled_master.CommandTable.read(tmp_path / "archived-commands.csv")
    rows = ssp_archives.run_ecos(archive, scenario.replace("-", "_"), STEP_S, END_S, commands=table)
    values, rust, steps = ssp_archives.aligned(rows, trace)
    window = steps >= WINDOW_START
    assert np.abs(values - rust)[window][:, 4:].max() <= 1e-3
    commands = tmp_path / f"{scenario}.commands.csv"
    jitter = [ssp_archives.jitter_arcsec(v, steps, STEP_S, commands) for v in (values, rust)]
    assert abs(jitter[0] - jitter[1]) <= 1e-4, jitter
