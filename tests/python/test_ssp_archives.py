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


def system_inputs(path):
    ssd = documents(path)["SystemStructure.ssd"]
    return sorted(c.get("name") for c in ssd.findall("ssd:System/ssd:Connectors/ssd:Connector[@kind='input']",
                                                     NAMESPACES))


def test_a_held_command_is_a_start_value_and_a_moving_one_an_input_of_the_system(archives):
    assert system_inputs(archives["hold-el45-normal-wind.ssp"]) == []
    controller = documents(archives["hold-el45-normal-wind.ssp"])["resources/AzimuthController.ssv"]
    held = {p.get("name"): p[0].get("value") for p in controller.findall(".//ssv:Parameter", NAMESPACES)}
    assert float(held["command.position"]) == 30.0 and float(held["command.velocity"]) == 0.0
    tracking = archives["track-sidereal-el45-normal-wind.ssp"]
    assert system_inputs(tracking) == ["command.azimuth", "command.azimuth_rate", "command.elevation",
                                       "command.elevation_rate"]
    with zipfile.ZipFile(tracking) as archive:
        assert archive.read("resources/commands.csv").startswith(b"time_s,azimuth_deg,elevation_deg\n")
    assert system_inputs(archives["plant.ssp"]) == ["azimuth.motor1.current_command",
                                                    "azimuth.motor2.current_command",
                                                    "elevation.motor.current_command"]


def test_the_same_scenario_gives_the_same_archive_byte_for_byte(archives, tmp_path):
    again = export(tmp_path, "hold-el45-normal-wind")
    for name in ("hold-el45-normal-wind.ssp", "plant.ssp"):
        assert (again / name).read_bytes() == archives[name].read_bytes(), name
    with zipfile.ZipFile(archives["plant.ssp"]) as archive:
        names = archive.namelist()
        assert names == sorted(names)
        assert {info.date_time for info in archive.infolist()} == {(1980, 1, 1, 0, 0, 0)}
