"""The reduced rotor model against all physical dofs, as flowrate (oilwatch.models.system.reduction_check)."""

import numpy as np
import pytest

from oilwatch.models.machine import load_machine
from oilwatch.models.system.factory import build_system
from oilwatch.models.system.reduction_check import reduction_flow_bias

TOLERANCE_PCT = 0.1
"""Largest flow-equivalent error of a bundled machine's reduced model [% of nominal]: a tenth of the
robustness criterion's smallest std in the flooded band (about 0.4 %) would still let the reduction alone
put a truth outside 2 std; 0.1 % keeps it a quarter of that."""


@pytest.fixture(scope="module")
def compressor():
    machine = load_machine("compressor")
    return machine, build_system(machine, reduced=False)


@pytest.mark.parametrize(
    "name",
    [
        "turbine",
        pytest.param(
            "compressor",
            marks=pytest.mark.xfail(
                strict=True,
                reason="at its 500 Hz cutoff the compressor's reduced model is worth +0.78 % of flow at "
                "bearing 2's 90 % (docs/compressor.md); 1000 Hz would remove it (the test below)",
            ),
        ),
    ],
)
def test_each_bundled_machines_reduced_model_is_worth_less_than_a_tenth_of_a_percent_of_flow(name):
    machine = load_machine(name)
    for error in reduction_flow_bias(machine):
        assert np.abs(error.flow_bias_pct).max() < TOLERANCE_PCT, error


def test_the_check_finds_the_compressors_impeller_modes_above_500_hz(compressor):
    """At the generic 500 Hz cutoff the compressor's reduced 1x orbits are off by hundredths of a micron,
    which bearing 2 in the flooded band (90 %) reads as most of a percent of flow; a 1000 Hz cutoff keeps
    those modes for four more coordinates."""
    machine, full = compressor
    [coarse] = reduction_flow_bias(machine, points_pct=[(80.0, 90.0)], full=full)
    [kept] = reduction_flow_bias(machine, 1000.0, points_pct=[(80.0, 90.0)], full=full)
    assert coarse.flow_bias_pct[1] > 0.5
    assert coarse.orbit_error_um.max() > 10 * kept.orbit_error_um.max()
    assert coarse.orbit_sensitivity_um[1].min() < coarse.orbit_error_um.max()  # why it matters at 90 %
    assert abs(kept.flow_bias_pct).max() < 0.05
    assert (coarse.n_coordinates, kept.n_coordinates) == (13, 17)


def test_the_error_vanishes_as_the_cutoff_rises(compressor):
    """With the fixed-interface modes up to 4000 Hz kept the reduced model converges on the full one: the
    check reads no flow."""
    machine, full = compressor
    [error] = reduction_flow_bias(machine, 4000.0, points_pct=[(80.0, 90.0)], full=full)
    assert np.abs(error.flow_bias_pct).max() < 0.005
    assert error.orbit_error_um.max() < 2e-4
