"""The FMUs' modelDescription: fmpy validate clean, units, ranges, descriptions, documentation."""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
import zipfile
from pathlib import Path

import pytest
from fmpy.validation import validate_fmu


def _model_description(path):
    with zipfile.ZipFile(path) as archive:
        return ET.fromstring(archive.read("modelDescription.xml"))


@pytest.mark.parametrize("name", ["ToyPlant", "ToyFilter"])
def test_fmpy_validate_reports_no_problem(toys, name):
    assert validate_fmu(str(toys / f"{name}.fmu")) == []


@pytest.mark.parametrize("name", ["ToyPlant", "ToyFilter"])
def test_every_variable_has_description_and_every_real_a_defined_unit(toys, name):
    root = _model_description(toys / f"{name}.fmu")
    units = {u.get("name"): u.find("BaseUnit").attrib for u in root.find("UnitDefinitions")}
    variables = root.find("ModelVariables")
    assert len(variables) > 0
    for variable in variables:
        assert variable.get("description"), variable.get("name")
        real = variable.find("Real")
        if real is not None:
            assert real.get("unit") in units, variable.get("name")
        if variable.get("causality") == "output":
            assert variable.get("initial") == "exact"
            assert next(iter(variable)).get("start") is not None


def test_unit_definitions_map_to_si(toys):
    root = _model_description(toys / "ToyPlant.fmu")
    units = {u.get("name"): u.find("BaseUnit").attrib for u in root.find("UnitDefinitions")}
    assert units["um"] == {"m": "1", "factor": "1e-06"}
    assert units["s"] == {"s": "1"}
    # UnitDefinitions must come right after CoSimulation (FMI 2.0 schema order).
    tags = [child.tag for child in root]
    assert tags.index("UnitDefinitions") == tags.index("CoSimulation") + 1


def test_min_max_written_where_declared(toys):
    root = _model_description(toys / "ToyPlant.fmu")
    reals = {
        v.get("name"): v.find("Real").attrib
        for v in root.iter("ScalarVariable")
        if v.find("Real") is not None
    }
    assert float(reals["width_s"]["min"]) == 1e-6
    assert float(reals["width_s"]["max"]) == 100.0
    assert "min" not in reals["y0_um"] and "max" not in reals["y0_um"]
    seed = next(v for v in root.iter("ScalarVariable") if v.get("name") == "seed")
    assert seed.find("Integer").get("min") == "0"


def test_documentation_lists_every_variable_with_its_unit(toys):
    with zipfile.ZipFile(toys / "ToyPlant.fmu") as archive:
        page = archive.read("documentation/index.html").decode()
    root = _model_description(toys / "ToyPlant.fmu")
    for variable in root.iter("ScalarVariable"):
        assert f"<td>{variable.get('name')}</td>" in page
    assert "<td>um</td>" in page and "simulate_fmu" in page


def test_the_bundled_package_is_oilwatch_unchanged_with_its_data_and_fingerprint(toys):
    import json

    import oilwatch
    from oilwatch.cosim.fmu_build import package_dir
    from oilwatch.fmu_src.bundle import SUBPACKAGES, source_digest

    with zipfile.ZipFile(toys / "ToyPlant.fmu") as archive:
        names = archive.namelist()
        slave = archive.read("resources/toy_plant_slave.py").decode()
        base = archive.read("resources/oilwatch/fmu_src/slave_base.py").decode()
        stamp = json.loads(archive.read("resources/oilwatch/bundle.json"))
    for package in SUBPACKAGES:
        assert f"resources/oilwatch/{package}/__init__.py" in names
    assert "resources/oilwatch/models/turbine.toml" in names
    assert not any(n.startswith("resources/models/") or n.startswith("resources/fmu_src/") for n in names)
    assert "from oilwatch.fmu_src.slave_base import OilwatchSlave" in slave
    assert base == (package_dir("fmu_src") / "slave_base.py").read_text(encoding="utf-8")
    # the fingerprint is the installed sources' digest: this process's oilwatch may serve the FMU
    assert stamp["digest"] == source_digest(Path(oilwatch.__file__).parent)
    assert not any(n.startswith("binaries/") and not n.startswith("binaries/linux64/") for n in names)


def test_unit_real_requires_a_known_unit_and_a_description():
    from oilwatch.fmu_src.fmi_variables import UNITS, UnitDefinition, UnitReal, register_unit

    with pytest.raises(ValueError, match="unit 'furlong'"):
        UnitReal("x", unit="furlong", description="d")
    with pytest.raises(ValueError, match="description"):
        UnitReal("x", unit="um")
    assert math.isclose(UNITS["ml/min"].factor, 1e-6 / 60.0)
    with pytest.raises(ValueError, match="already defined"):
        register_unit(UnitDefinition("um", {"m": 1}, 1e-3))
