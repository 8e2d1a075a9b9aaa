"""Transient p-theta film: mass balance per step, the steady limit, the frequency-dependent coefficients."""

from __future__ import annotations

import math

import numpy as np
import pytest

from oilwatch.models.bearing.dynamic import FilmImpedance, bdf_symbol
from oilwatch.models.bearing.equilibrium import coefficients_at, static_equilibrium
from oilwatch.models.bearing.film import solve_film
from oilwatch.models.bearing.geometry import JournalBearing
from oilwatch.models.bearing.grid import Mesh
from oilwatch.models.bearing.supply import ML_MIN_PER_M3_S, SupplyFlow
from oilwatch.models.bearing.transient import TransientFilm, mass_balance_error
from oilwatch.models.validation import InputError

BEARING = JournalBearing(0.045, 0.070, 120e-6, 0.094, 0.0, 16.2e-3, 35e-3)
SPEED_HZ = 75.0
LOAD_N = 3272.8
MESH = Mesh(60, 16)
MESH_MULTIGRID = Mesh(120, 36)
NOMINAL = 596.3 / ML_MIN_PER_M3_S


@pytest.fixture(scope="module", params=[1.0, 0.75], ids=["flooded", "starved"])
def equilibrium(request):
    supply = SupplyFlow(request.param * NOMINAL)
    return supply, static_equilibrium(BEARING, LOAD_N, SPEED_HZ, supply, MESH)


@pytest.mark.parametrize("order", [1, 2])
def test_mass_balance_of_every_step(equilibrium, order):
    """supply - side leakage - d(content)/dt = 0 per step, for a journal whirling 10 um and a flow change."""
    supply, eq = equilibrium
    film = TransientFilm(BEARING, SPEED_HZ, MESH, order=order)
    state = film.from_steady(eq.film, eq.eccentricity_m)
    omega = 2.0 * math.pi * 60.0
    dt = 2e-4
    worst = 0.0
    for k in range(1, 41):
        e = eq.eccentricity_m + 10e-6 * np.array([math.cos(omega * k * dt) - 1.0, math.sin(omega * k * dt)])
        q = supply.q_m3_s * (0.8 if k > 20 else 1.0)
        new = film.step(state, e, q, dt)
        worst = max(worst, abs(mass_balance_error(film, state, new)))
        assert np.all(new.pressure_pa >= -1e-6 * film.p_ref)
        state = new
    assert worst < 1e-9
    assert film.sweep_count > 0 and film.fallbacks < 40  # the sweeps solved steps


@pytest.mark.parametrize("whirl_um", [3.0, 10.0])
def test_sweeps_reach_the_active_set_solution(equilibrium, whirl_um):
    """The projected SOR step and the active-set step of the same problem give the same film."""
    supply, eq = equilibrium
    sweeping = TransientFilm(BEARING, SPEED_HZ, MESH)
    direct = TransientFilm(BEARING, SPEED_HZ, MESH, sweep_limit=0)
    a = sweeping.from_steady(eq.film, eq.eccentricity_m)
    b = direct.from_steady(eq.film, eq.eccentricity_m)
    omega = 2.0 * math.pi * 75.0
    dt = 1.0 / 75.0 / 64
    for k in range(1, 25):
        e = eq.eccentricity_m + whirl_um * 1e-6 * np.array(
            [math.cos(omega * k * dt) - 1, math.sin(omega * k * dt)]
        )
        a = sweeping.step(a, e, supply.q_m3_s, dt)
        b = direct.step(b, e, supply.q_m3_s, dt)
        assert a.sweeps > 0 and a.iterations == 0  # solved by the sweeps, no fallback
        assert a.sweep_residual <= sweeping.residual_tolerance
        np.testing.assert_allclose(a.force_n, b.force_n, rtol=0, atol=1e-7 * LOAD_N)
        assert abs(a.side_leakage_m3_s - b.side_leakage_m3_s) < 1e-8 * supply.q_m3_s
        assert np.abs(a.fill_fraction - b.fill_fraction).max() < 1e-7
    assert sweeping.fallbacks == 0 and direct.sweep_count == 0


def test_sweep_options_are_checked():
    with pytest.raises(InputError, match="solver must be one of"):
        TransientFilm(BEARING, SPEED_HZ, MESH, solver="jacobi")
    with pytest.raises(InputError, match="sweep_limit"):
        TransientFilm(BEARING, SPEED_HZ, MESH, sweep_limit=-1)
    with pytest.raises(InputError, match="residual_tolerance"):
        TransientFilm(BEARING, SPEED_HZ, MESH, residual_tolerance=0.0)


@pytest.mark.parametrize("solver", ["sweeps", "multigrid"])
def test_journal_held_still_converges_to_the_steady_film(solver):
    """From the nominal film, a sudden 75 % supply with the journal held converges to the steady 75 % film."""
    e = np.array([1.3e-5, -8e-6])
    q_new = 0.75 * NOMINAL
    start = solve_film(BEARING, SPEED_HZ, tuple(e), SupplyFlow(NOMINAL), mesh=MESH)
    target = solve_film(BEARING, SPEED_HZ, tuple(e), SupplyFlow(q_new), mesh=MESH)
    film = TransientFilm(BEARING, SPEED_HZ, MESH, solver=solver)
    state = film.from_steady(start, e)
    for _ in range(400):
        state = film.step(state, e, q_new, 1e-3)
    np.testing.assert_allclose(state.force_n, target.force_n, rtol=1e-7, atol=1e-6 * LOAD_N)
    assert state.side_leakage_m3_s == pytest.approx(q_new, rel=1e-7)
    assert np.abs(film.cell_values(state.fill_fraction) - target.fill_fraction).max() < 1e-6
    assert film.fallbacks == 0


def test_symmetric_half_film_is_the_whole_film(equilibrium):
    """The mid-plane half (the default on an even mesh) steps to the film of the whole bearing."""
    supply, eq = equilibrium
    half = TransientFilm(BEARING, SPEED_HZ, MESH)
    whole = TransientFilm(BEARING, SPEED_HZ, MESH, symmetric=False)
    assert half.symmetric and half.grid.n_nodes < 0.6 * whole.grid.n_nodes
    a = half.from_steady(eq.film, eq.eccentricity_m)
    b = whole.from_steady(eq.film, eq.eccentricity_m)
    assert a.total_content_m3 == pytest.approx(b.total_content_m3, rel=1e-12)
    omega, dt = 2.0 * math.pi * 75.0, 1.0 / 75.0 / 64
    for k in range(1, 13):
        e = eq.eccentricity_m + 5e-6 * np.array([math.cos(omega * k * dt) - 1, math.sin(omega * k * dt)])
        a, b = half.step(a, e, supply.q_m3_s, dt), whole.step(b, e, supply.q_m3_s, dt)
        np.testing.assert_allclose(a.force_n, b.force_n, rtol=0, atol=1e-7 * LOAD_N)
        assert a.side_leakage_m3_s == pytest.approx(b.side_leakage_m3_s, rel=1e-8)
        assert a.total_content_m3 == pytest.approx(b.total_content_m3, rel=1e-9)
        theta_half, theta_whole = half.cell_values(a.fill_fraction), whole.cell_values(b.fill_fraction)
        np.testing.assert_allclose(theta_half, theta_whole, atol=1e-7)
    with pytest.raises(InputError, match="even mesh n_axial"):
        TransientFilm(BEARING, SPEED_HZ, Mesh(60, 15), symmetric=True)


@pytest.mark.parametrize("whirl_um", [3.0, 10.0])
def test_multigrid_reaches_the_active_set_solution(equilibrium, whirl_um):
    """The projected multigrid step meets the tolerances with no fallback, keeps the mass balance per
    step and gives the active set's film."""
    supply, eq = equilibrium
    multigrid = TransientFilm(BEARING, SPEED_HZ, MESH_MULTIGRID, solver="multigrid")
    direct = TransientFilm(BEARING, SPEED_HZ, MESH_MULTIGRID, solver="active-set")
    eq = static_equilibrium(BEARING, LOAD_N, SPEED_HZ, supply, MESH_MULTIGRID)
    a = multigrid.from_steady(eq.film, eq.eccentricity_m)
    omega = 2.0 * math.pi * 75.0
    dt = 1.0 / 75.0 / 64
    for k in range(1, 17):
        e = eq.eccentricity_m + whirl_um * 1e-6 * np.array(
            [math.cos(omega * k * dt) - 1, math.sin(omega * k * dt)]
        )
        new = multigrid.step(a, e, supply.q_m3_s, dt)
        b = direct.step(a, e, supply.q_m3_s, dt)  # the same step solved exactly
        assert new.sweeps > 0 and new.iterations == 0 and new.sweep_residual <= multigrid.residual_tolerance
        assert abs(mass_balance_error(multigrid, a, new)) < 1e-9
        np.testing.assert_allclose(new.force_n, b.force_n, rtol=0, atol=1e-8 * LOAD_N)
        assert abs(new.side_leakage_m3_s - b.side_leakage_m3_s) < 1e-8 * supply.q_m3_s
        assert np.abs(new.fill_fraction - b.fill_fraction).max() < 1e-7
        a = new
    assert multigrid.fallbacks == 0


def test_impedance_limits_are_the_quasi_static_coefficients(equilibrium):
    """omega -> 0: the held-partition stiffness; omega -> infinity: the frozen-content (full-film) damping."""
    supply, eq = equilibrium
    stiffness, damping = coefficients_at(BEARING, eq, SPEED_HZ, supply, MESH)
    impedance = FilmImpedance(eq.film, eq.eccentricity_m, SPEED_HZ)
    k_low, _ = impedance.coefficients(2.0 * math.pi * 1e-4)
    _, c_high = impedance.coefficients(2.0 * math.pi * 1e6)
    np.testing.assert_allclose(k_low, stiffness, atol=1e-4 * np.abs(stiffness).max())
    np.testing.assert_allclose(c_high, damping, atol=1e-3 * np.abs(damping).max())


@pytest.mark.slow  # transient runs: seconds of film steps
@pytest.mark.parametrize("whirl_hz", [30.0, 75.0])
def test_impedance_matches_a_small_amplitude_transient_run(equilibrium, whirl_hz):
    """A harmonic motion of 0.1 % of the clearance through the stepper gives the discrete impedance (1 %)."""
    supply, eq = equilibrium
    impedance = FilmImpedance(eq.film, eq.eccentricity_m, SPEED_HZ)
    film = TransientFilm(BEARING, SPEED_HZ, MESH)
    omega = 2.0 * math.pi * whirl_hz
    per_period = 32
    dt = 1.0 / whirl_hz / per_period
    amplitude = 1e-3 * BEARING.clearance_m
    for j in range(2):
        state = film.from_steady(eq.film, eq.eccentricity_m)
        direction = np.eye(2)[j]
        forces = []
        for k in range(1, 6 * per_period + 1):
            state = film.step(
                state, eq.eccentricity_m + amplitude * direction * math.sin(omega * k * dt), supply.q_m3_s, dt
            )
            forces.append(state.force_n - eq.film.force_n)
        t = dt * np.arange(5 * per_period + 1, 6 * per_period + 1)
        basis = np.column_stack([np.cos(omega * t), np.sin(omega * t)])
        a, b = np.linalg.lstsq(basis, np.array(forces[-per_period:]), rcond=None)[0]
        z_run = -(a - 1j * b) / (-1j * amplitude)
        z_linear = impedance.impedance(bdf_symbol(omega, dt, film.order))[:, j]
        assert np.abs(z_run - z_linear).max() < 0.01 * np.abs(z_linear).max()
