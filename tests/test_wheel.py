"""What ``pip install oilwatch`` puts into site-packages: the one package ``oilwatch`` and its dist-info."""

from __future__ import annotations

import zipfile

import pytest
from fixtures.venvs import build_wheel


@pytest.mark.slow
def test_the_wheel_holds_only_the_oilwatch_package_and_its_dist_info(tmp_path):
    wheel = build_wheel(tmp_path / "dist")
    with zipfile.ZipFile(wheel) as archive:
        names = archive.namelist()
    top = {name.split("/", 1)[0] for name in names}
    assert top == {"oilwatch", f"{wheel.name.split('-')[0]}-{wheel.name.split('-')[1]}.dist-info"}
    # the models, the estimator and the FMU shells are subpackages, with their data
    for part in (
        "models/turbine.toml",
        "models/system/factory.py",
        "estimator/ekf.py",
        "fmu_src/__init__.py",
    ):
        assert f"oilwatch/{part}" in names, part
    entry_points = next(n for n in names if n.endswith(".dist-info/entry_points.txt"))
    with zipfile.ZipFile(wheel) as archive:
        assert "oilwatch = oilwatch.cli:console_main" in archive.read(entry_points).decode()
