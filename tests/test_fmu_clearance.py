"""The estimator FMU's model takes the clearances its ``baseline_file``'s coast-down measured
(fmu_src/ekf_configuration.py), as ``oilwatch estimate --baseline`` does."""

from __future__ import annotations

import json
from types import SimpleNamespace

import pytest

from oilwatch.fmu_src.ekf_configuration import estimator_model
from oilwatch.fmu_src.machine_parameters import rotor_bearing_system
from oilwatch.models.machine import load_machine
from oilwatch.models.validation import InputError

FACTORS = (0.9, 0.95)


def _slave(baseline_file: str, bearing_table: int) -> SimpleNamespace:
    return SimpleNamespace(
        baseline_file=baseline_file,
        bearing_table=bearing_table,
        resources=None,
        unbalance_g_mm=-1.0,
        unbalance_phase_deg=0.0,
        sample_period_s=1e-3,
        viscosity_factor_prior_std=0.0,
        preset="machine",
    )


@pytest.fixture(scope="module")
def baseline(tmp_path_factory) -> str:
    path = tmp_path_factory.mktemp("fmu_clearance") / "baseline.json"
    document = {
        "format": "oilwatch commissioning baseline",
        "format_version": 1,
        "offsets_um": [0.0] * 4,
        "offset_std_um": [0.1] * 4,
        "clearance_factor": list(FACTORS),
        "clearance_factor_std": [0.02, 0.02],
    }
    path.write_text(json.dumps(document))
    return str(path)


def test_the_estimator_fmus_model_takes_the_baselines_clearances(baseline):
    machine = load_machine(None)
    system = rotor_bearing_system("", None, 0.0, -1.0, 0.0, reduced=True)
    model = estimator_model(_slave(baseline, 1), system, machine)
    clearances = [t.metadata["bearing"]["clearance_m"] for t in model.reference.system.tables]
    assert clearances == pytest.approx([f * machine.bearing.clearance_m for f in FACTORS], rel=1e-12)


def test_a_baseline_with_clearances_needs_the_table_that_follows_the_operating_point(baseline):
    system = rotor_bearing_system("", None, 0.0, -1.0, 0.0, reduced=True)
    with pytest.raises(InputError, match="bearing_table = 1") as raised:
        estimator_model(_slave(baseline, 0), system, load_machine(None))
    assert "baseline_file" in str(raised.value) and "\n" not in str(raised.value)
