"""The README's FMU variable tables are the ones generated from the built FMUs (never typed by hand)."""

from __future__ import annotations

from pathlib import Path

from oilwatch.cosim.fmu_docs import readme_with_tables

README = Path(__file__).resolve().parents[1] / "README.md"


def test_readme_tables_match_the_fmus_own_documentation(built_fmus):
    text = README.read_text(encoding="utf-8")
    fmus = [built_fmus / "RotorBearingPlant.fmu", built_fmus / "OilFlowEKF.fmu"]
    assert readme_with_tables(text, fmus) == text, (
        "README tables differ from the FMUs: run python -m oilwatch.cosim.fmu_docs --readme README.md "
        "build/RotorBearingPlant.fmu build/OilFlowEKF.fmu"
    )
