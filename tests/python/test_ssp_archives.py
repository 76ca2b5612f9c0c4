"""The SSP 1.0 archives of `antenna --ssp` (docs/ssp.md): valid against the standard's XML
schemas (tests/ssp-schemas/), complete (every component's FMU and parameter set inside), the
command as the standard allows, and written deterministically."""

import io
import zipfile

import pytest
from lxml import etree

from conftest import REPOSITORY
from ssp_archives import export

SCHEMAS = REPOSITORY / "tests" / "ssp-schemas"
NAMESPACES = {"ssd": "http://ssp-standard.org/SSP1/SystemStructureDescription",
              "ssv": "http://ssp-standard.org/SSP1/SystemStructureParameterValues"}
UNITS = ("AzimuthPlant", "ElevationPlant", "AzimuthController", "ElevationController", "Wind", "Structure")


@pytest.fixture(scope="module")
def archives(tmp_path_factory):
    """The archives of the three Req. 5 scenarios at 45 deg (a hold and two tracking rates) and
    the plant of the first."""
    folder = export(tmp_path_factory.mktemp("ssp"), "el45-normal-wind")
    return {path.name: path for path in sorted(folder.glob("*.ssp"))}


def schema(name):
    return etree.XMLSchema(etree.parse(str(SCHEMAS / name)))


def documents(path):
    """The archive's SSD and its parameter sets, parsed, by entry name."""
    with zipfile.ZipFile(path) as archive:
        return {name: etree.parse(io.BytesIO(archive.read(name))) for name in archive.namelist()
                if name.endswith((".ssd", ".ssv"))}


def test_every_archive_is_valid_ssp_1_0_and_holds_what_it_names(archives):
    assert set(archives) == {"hold-el45-normal-wind.ssp", "track-sidereal-el45-normal-wind.ssp",
                             "track-0.04-el45-normal-wind.ssp", "plant.ssp"}
    description, values = schema("SystemStructureDescription.xsd"), schema("SystemStructureParameterValues.xsd")
    for name, path in archives.items():
        with zipfile.ZipFile(path) as archive:
            entries = set(archive.namelist())
        parsed = documents(path)
        ssd = parsed.pop("SystemStructure.ssd")
        assert description.validate(ssd), (name, description.error_log)
        for entry, ssv in parsed.items():
            assert values.validate(ssv), (name, entry, values.error_log)
        components = ssd.findall(".//ssd:Component", NAMESPACES)
        expected = UNITS if name != "plant.ssp" else tuple(u for u in UNITS if "Controller" not in u)
        assert sorted(c.get("name") for c in components) == sorted(expected), name
        for component in components:
            assert component.get("source") in entries, (name, component.get("source"))
            bindings = component.findall(".//ssd:ParameterBinding", NAMESPACES)
            assert [b.get("source") in entries for b in bindings] == [True], (name, component.get("name"))


def test_every_connection_joins_declared_connectors_and_every_parameter_has_its_units(archives):
    for name, path in archives.items():
        parsed = documents(path)
        ssd = parsed.pop("SystemStructure.ssd")
        system = ssd.find("ssd:System", NAMESPACES)
        connectors = {(None, c.get("name")) for c in system.findall("ssd:Connectors/ssd:Connector", NAMESPACES)}
        for component in system.findall(".//ssd:Component", NAMESPACES):
            connectors |= {(component.get("name"), c.get("name"))
                           for c in component.findall("ssd:Connectors/ssd:Connector", NAMESPACES)}
        connections = system.findall("ssd:Connections/ssd:Connection", NAMESPACES)
        assert connections, name
        for connection in connections:
            for end in ("start", "end"):
                assert (connection.get(f"{end}Element"), connection.get(f"{end}Connector")) in connectors, name
        for entry, ssv in parsed.items():
            declared = {u.get("name") for u in ssv.findall("ssv:Units/*", NAMESPACES)}
            used = {r.get("unit") for r in ssv.findall(".//ssv:Real", NAMESPACES) if r.get("unit")}
            assert used and used <= declared, (name, entry, used - declared)


def start_values(path, unit):
    """The values the archive binds to `unit`, by name."""
    ssv = documents(path)[f"resources/{unit}.ssv"]
    return {p.get("name"): float(p[0].get("value")) for p in ssv.findall(".//ssv:Parameter", NAMESPACES)
            if p[0].tag.endswith("Real")}


def entries(path):
    with zipfile.ZipFile(path) as archive:
        return set(archive.namelist())


def test_the_command_starts_as_the_controllers_start_values_and_a_moving_one_comes_with_its_table(archives):
    """SSP 1.0 has no signal source: a hold is its start values, a tracking command comes with its
    table for the engine's user to feed. No connection leaves the components, since libcosim and
    ecos refuse connections to the system's own connectors."""
    hold, tracking = archives["hold-el45-normal-wind.ssp"], archives["track-0.04-el45-normal-wind.ssp"]
    for unit, position in (("AzimuthController", 30.0), ("ElevationController", 45.0)):
        held = start_values(hold, unit)
        assert (held["command.position"], held["command.velocity"]) == (position, 0.0), unit
        # The Rust master's command at the first point: the table's start, at rest.
        assert start_values(tracking, unit)["command.position"] == position, unit
    assert "resources/commands.csv" not in entries(hold)
    with zipfile.ZipFile(tracking) as archive:
        header, *rows = archive.read("resources/commands.csv").decode().splitlines()
    assert header == "time_s,azimuth_deg,elevation_deg"
    assert float(rows[-1].split(",")[1]) == pytest.approx(30.0 + 0.04 * 70.0)
    for name, path in archives.items():
        ssd = documents(path)["SystemStructure.ssd"]
        for connection in ssd.findall(".//ssd:Connection", NAMESPACES):
            assert connection.get("startElement") and connection.get("endElement"), name


def test_the_plant_archive_leaves_the_motor_current_commands_open_for_a_controller_of_ones_own(archives):
    ssd = documents(archives["plant.ssp"])["SystemStructure.ssd"]
    connected = {(c.get("endElement"), c.get("endConnector")) for c in ssd.findall(".//ssd:Connection", NAMESPACES)}
    for plant, current in (("AzimuthPlant", "motor1.current_command"), ("AzimuthPlant", "motor2.current_command"),
                           ("ElevationPlant", "motor.current_command")):
        component = ssd.find(f".//ssd:Component[@name='{plant}']", NAMESPACES)
        kinds = {c.get("name"): c.get("kind") for c in component.findall("ssd:Connectors/ssd:Connector", NAMESPACES)}
        assert kinds[current] == "input" and (plant, current) not in connected, (plant, current)


def test_the_same_scenario_gives_the_same_archive_byte_for_byte(archives, tmp_path):
    again = export(tmp_path, "hold-el45-normal-wind")
    for name in ("hold-el45-normal-wind.ssp", "plant.ssp"):
        assert (again / name).read_bytes() == archives[name].read_bytes(), name
    with zipfile.ZipFile(archives["plant.ssp"]) as archive:
        names = archive.namelist()
        assert names == sorted(names)
        assert {info.date_time for info in archive.infolist()} == {(1980, 1, 1, 0, 0, 0)}
