"""The realistic antenna's parameter files shipped in the FMUs (resources/realistic.params), under
fmpy, an FMI master written independently of this project.

For each FMU that ships one: fmpy starts the FMU with nothing but parameter_file =
realistic.params, and every variable the file names reads back, after initialisation, the value
the file gives, which is the default column of docs/parameters.csv (read here with the csv
module, no project code). The Rust test tests/rust/realistic_parameter_file.rs checks that the
files reproduce the Rust master's realistic antenna bit for bit.
"""

import csv
import shutil
import zipfile
from pathlib import Path

from fmpy import extract, instantiate_fmu, read_model_description

from conftest import FMU_DIRECTORY, PACKAGE_HINT

TABLE = Path(__file__).resolve().parents[2] / "docs" / "parameters.csv"
SHIPPING = ("AzimuthPlant", "ElevationPlant", "Wind")


def table_defaults(model_identifier):
    """{variable: default} of the table's rows that set a variable of this FMU."""
    defaults = {}
    with open(TABLE, newline="") as f:
        # Comment lines (#) head the file.
        for row in csv.DictReader(line for line in f if not line.startswith("#")):
            for target in row["targets"].split():
                unit, _, name = target.partition(":")
                if unit == model_identifier:
                    defaults[name] = float(row["default"])
    return defaults


def file_values(path):
    with zipfile.ZipFile(path) as archive:
        text = archive.read("resources/realistic.params").decode()
    values = {}
    for line in text.splitlines():
        line = line.split("#", 1)[0].strip()
        if line:
            name, value = (part.strip() for part in line.split("=", 1))
            values[name] = float(value)
    return values


def test_each_shipped_realistic_parameter_file_sets_the_tables_defaults_in_fmpy():
    for model_identifier in SHIPPING:
        path = FMU_DIRECTORY / f"{model_identifier}.fmu"
        assert path.is_file(), f"{path} is missing: {PACKAGE_HINT}"
        values = file_values(path)
        defaults = table_defaults(model_identifier)
        assert defaults, model_identifier
        for name, default in defaults.items():
            assert values[name] == default, f"{model_identifier}.{name}: file {values[name]}, table {default}"
        description = read_model_description(str(path))
        variables = {v.name: v for v in description.modelVariables}
        unzipdir = extract(str(path))
        fmu = instantiate_fmu(unzipdir, description, fmi_type="CoSimulation")
        try:
            fmu.setupExperiment(startTime=0.0)
            fmu.setString([variables["parameter_file"].valueReference], ["realistic.params"])
            fmu.enterInitializationMode()
            fmu.exitInitializationMode()
            for name, expected in values.items():
                variable = variables[name]
                if variable.type == "Real":
                    got = fmu.getReal([variable.valueReference])[0]
                else:
                    got = fmu.getInteger([variable.valueReference])[0]
                assert got == expected, f"{model_identifier}.{name}: {got} after loading, file {expected}"
        finally:
            fmu.terminate()
            fmu.freeInstance()
            shutil.rmtree(unzipdir, ignore_errors=True)
