"""The FMU page's variable tables (docs/fmus.md) are the ones generated from the built FMUs (never typed)."""

from __future__ import annotations

from pathlib import Path

from oilwatch.cosim.fmu_docs import readme_with_tables

README = Path(__file__).resolve().parents[1] / "docs" / "fmus.md"


def test_readme_tables_match_the_fmus_own_documentation(built_fmus):
    text = README.read_text(encoding="utf-8")
    fmus = [built_fmus / "RotorBearingPlant.fmu", built_fmus / "OilFlowEKF.fmu"]
    assert readme_with_tables(text, fmus) == text, (
        "docs/fmus.md tables differ from the FMUs: run python -m oilwatch.cosim.fmu_docs --readme "
        "docs/fmus.md build/RotorBearingPlant.fmu build/OilFlowEKF.fmu"
    )
