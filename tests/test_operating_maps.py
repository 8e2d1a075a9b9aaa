"""oilwatch.models.system.operating_maps: a re-centring's stacked blocks and derivatives against direct
evaluations."""

import numpy as np
import pytest

from oilwatch.models.machine import load_machine
from oilwatch.models.system.factory import load_system
from oilwatch.models.system.operating_maps import AXES, SLICES_KEPT
from oilwatch.models.system.operating_model import build_operating_model

MACHINE = load_machine()


@pytest.fixture(scope="module")
def maps():
    return build_operating_model(load_system(reduced=True), MACHINE).maps


def test_stacked_blocks_are_the_single_point_blocks(maps):
    q = np.array([0.8, 0.9]) * MACHINE.lubrication.nominal_flowrates_m3_s
    points = [(q, 74.0, np.array([0.07, 0.08])), (1.01 * q, 77.5, np.array([0.09, 0.06]))]
    stacked = maps.blocks(points)
    for block, point in zip(stacked, points, strict=True):
        single = maps.blocks([point])[0]
        np.testing.assert_allclose(block, single, rtol=0.0, atol=1e-14 * np.abs(single).max())


def test_derivatives_are_the_exact_map_s_along_every_axis(maps):
    """Each axis' Frechet derivative against the central difference of the exact map (expm) itself over the
    same step (the difference's own truncation error grows as the step squared: 1e-7 here, 1e-5 at 10x)."""
    q = np.array([0.85, 0.95]) * MACHINE.lubrication.nominal_flowrates_m3_s
    speed, mu = 76.0, np.array([0.075, 0.08])
    a_d, g, d_ad, d_g = maps.derivatives(q, speed, mu)
    exact = maps.discrete_map(q, speed, mu)
    # scipy's expm and expm_frechet scale the block differently (17 squarings here): ~1e-9 apart
    np.testing.assert_allclose(a_d, exact[0], rtol=0.0, atol=1e-8 * np.abs(exact[0]).max())
    np.testing.assert_allclose(g, exact[1], rtol=0.0, atol=1e-8 * np.abs(exact[1]).max())
    for index, axis in enumerate(AXES):
        high, low = (maps.shifted_point(axis, q, speed, mu, sign) for sign in (+1, -1))
        width = high[3] - low[3]
        numeric_a = (maps.discrete_map(*high[:3])[0] - maps.discrete_map(*low[:3])[0]) / width
        numeric_g = (maps.discrete_map(*high[:3])[1] - maps.discrete_map(*low[:3])[1]) / width
        assert np.abs(d_ad[index] - numeric_a).max() < 1e-6 * np.abs(numeric_a).max(), axis
        assert np.abs(d_g[index] - numeric_g).max() < 1e-6 * np.abs(numeric_g).max(), axis


def test_a_flowrate_past_the_tables_edge_at_a_moved_threshold_is_taken_at_the_edge(maps):
    """The estimator bounds its flowrates at the reference point; at another viscosity the flooded threshold
    moves, and a bound estimate lies past the table's range there: the film is taken at the edge (before,
    an InputError stopped the estimator FMU's doStep)."""
    speed, mu = 75.0, np.array([0.095, 0.095])
    (_, high), (low, _) = maps.bearing_flowrate_bounds_m3_s(speed, mu)
    past = maps.blocks([(np.array([1.002 * high, 0.998 * low]), speed, mu)])[0]
    edge = maps.blocks([(np.array([high, low]), speed, mu)])[0]
    np.testing.assert_array_equal(past, edge)


def test_the_table_slices_held_stay_bounded_as_the_viscosity_wanders(maps):
    """With the viscosity factors estimated every re-centring asks for slices at new viscosities; a long run
    must not keep them all (it grew by about 100 slices, 0.25 MB, per 10 s of a constant operating point),
    and a slice dropped and made again gives the same block."""
    q = np.array([0.8, 0.9]) * MACHINE.lubrication.nominal_flowrates_m3_s
    first = (q, 75.0, np.array([0.08, 0.08]))
    before = maps.blocks([first])[0]
    for mu in np.linspace(0.06, 0.1, 2 * SLICES_KEPT):
        maps.blocks([(q, 75.0, np.array([mu, 1.01 * mu]))])
    assert maps.slice_count <= SLICES_KEPT
    np.testing.assert_array_equal(maps.blocks([first])[0], before)
