"""build.py's relocation of bundled packages: the import rewrite and its loud failures."""

from __future__ import annotations

import pytest

from oilwatch.cosim.packaging import RelocationError, rewrite_imports

MAPPING = {"oilwatch": "p_oilwatch"}


def test_from_imports_are_relocated_and_others_left_alone():
    source = (
        '"""Docstring: from oilwatch.models.x import y stays as written."""\n'
        "from oilwatch.models.validation import InputError\n"
        "from oilwatch.models import machine\n"
        "from oilwatch.fmu_src.slave_base import (\n    OilwatchSlave,\n)\n"
        "from .local import thing\n"
        "from modelsx.other import z\n"
        "import numpy as np\n"
        "def f():\n    from  oilwatch.models.rotor import disc\n"
    )
    result = rewrite_imports(source, MAPPING, "x.py")
    assert "from p_oilwatch.models.validation import InputError" in result
    assert "from p_oilwatch.models import machine" in result
    assert "from p_oilwatch.fmu_src.slave_base import (" in result
    assert "from .local import thing" in result
    assert "from modelsx.other import z" in result
    assert "from  p_oilwatch.models.rotor import disc" in result
    assert result.startswith('"""Docstring: from oilwatch.models.x import y stays as written."""')


@pytest.mark.parametrize(
    "line",
    ["import oilwatch", "import oilwatch.models.validation", "import numpy, oilwatch.fmu_src.slave_base"],
)
def test_plain_import_of_a_relocated_package_fails_with_file_and_line(line):
    with pytest.raises(RelocationError, match=r"x\.py:2: 'import"):
        rewrite_imports("a = 1\n" + line + "\n", MAPPING, "x.py")


def test_module_name_passed_as_string_fails():
    source = "import importlib\nimportlib.import_module('oilwatch.models.machine')\n"
    with pytest.raises(RelocationError, match=r"x\.py:2"):
        rewrite_imports(source, MAPPING, "x.py")
