"""The dimensionless table of the synchronous coefficients K(Omega), C(Omega): the scaling it rests on
(whirl ratio 1), the committed file against direct solves off its nodes, and against the 75 Hz synchronous
table."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from oilwatch.models.bearing.coefficient_kinds import SYNCHRONOUS, table_kind
from oilwatch.models.bearing.dynamic import synchronous_coefficients
from oilwatch.models.bearing.equilibrium import static_equilibrium
from oilwatch.models.bearing.grid import Mesh
from oilwatch.models.bearing.operating_accuracy import table_error
from oilwatch.models.bearing.sommerfeld import couette_flow_m3_s
from oilwatch.models.bearing.supply import SupplyFlow
from oilwatch.models.machine import load_machine
from oilwatch.models.rotor.assembly import Rotor
from oilwatch.models.system.factory import load_tables
from oilwatch.models.system.operating_point import operating_table_of

MACHINE = load_machine()
LOAD_N = 3272.8248078061615


@pytest.fixture(scope="module")
def table():
    return operating_table_of(MACHINE, SYNCHRONOUS)


def _dimensionless(speed_hz, viscosity, fraction_of_couette, mesh):
    bearing = dataclasses.replace(MACHINE.bearing, viscosity_pa_s=viscosity)
    supply = SupplyFlow(fraction_of_couette * couette_flow_m3_s(bearing, speed_hz))
    eq = static_equilibrium(bearing, LOAD_N, speed_hz, supply, mesh)
    k, c = synchronous_coefficients(eq.film, eq.eccentricity_m, speed_hz, supply)
    scale = bearing.clearance_m / LOAD_N
    return np.concatenate([(k * scale).ravel(), (c * scale * 2 * math.pi * speed_hz).ravel()])


def test_synchronous_coefficients_depend_only_on_sommerfeld_number_and_flow_over_couette_flow():
    # Same S (mu N constant) and q / q_c at two speeds, whirl = spin at each: the same K c/W, C c Omega/W.
    mesh = Mesh(60, 20)
    a = _dimensionless(75.0, 0.094, 0.09, mesh)
    b = _dimensionless(60.0, 0.094 * 75.0 / 60.0, 0.09, mesh)
    np.testing.assert_allclose(a, b, rtol=1e-7, atol=1e-9 * np.max(np.abs(a)))


def test_committed_table_is_synchronous_with_provenance(table):
    assert table_kind(table.metadata) == SYNCHRONOUS
    assert table.metadata["provenance"]["command_line"].startswith("oilwatch bearing-map")
    assert "--coefficients synchronous" in table.metadata["provenance"]["command_line"]
    assert table.metadata["mesh"] == {"n_circ": 240, "n_axial": 72}
    assert table.fraction_range == (0.5, 1.5) and 1.0 in table.fraction_nodes


def test_table_agrees_with_the_75hz_synchronous_table_at_its_nodes(table):
    # The 75 Hz table's flowrates are (to its q_t) nodes of this table at the nominal Sommerfeld number.
    one_d = load_tables(MACHINE, Rotor.from_machine(MACHINE), 75.0, coefficients=SYNCHRONOUS)[0]
    for q in one_d.flowrates_m3_s:
        point = table.evaluate(75.0, MACHINE.bearing.viscosity_pa_s, one_d.load_n, q).coefficients
        ref = one_d.evaluate(q)
        assert np.abs(point.stiffness - ref.stiffness).max() < 2e-3 * np.abs(ref.stiffness).max()
        assert np.abs(point.damping - ref.damping).max() < 2e-3 * np.abs(ref.damping).max()


@pytest.mark.slow
@pytest.mark.parametrize(("speed_hz", "viscosity", "fraction"), [(60.0, 0.07, 0.8), (90.0, 0.12, 1.0)])
def test_table_reproduces_direct_synchronous_solves_off_its_nodes(table, speed_hz, viscosity, fraction):
    err = table_error(table, MACHINE.bearing, speed_hz, viscosity, LOAD_N, fraction, Mesh(240, 72))
    assert err.stiffness < 0.01
    assert err.damping < 0.01
    assert err.eccentricity_ratio < 0.005
