"""The committed transient-film results and synchronous table: samples recomputed, done-when figures."""

from __future__ import annotations

import json

import numpy as np
import pytest

from oilwatch.models.bearing.dynamic_table import synchronous_coefficients
from oilwatch.models.bearing.equilibrium import static_equilibrium
from oilwatch.models.bearing.grid import Mesh
from oilwatch.models.bearing.supply import SupplyFlow
from oilwatch.models.bearing.table import CoefficientTable
from oilwatch.models.machine import load_machine
from oilwatch.models.rotor.assembly import Rotor
from oilwatch.models.system.frequency_stability import film_impedances, film_roots, least_stable
from oilwatch.models.system.nonlinear import NonlinearRotorBearing
from oilwatch.models.system.nonlinear_studies import SAMPLE_STEPS, linear_orbits, orbit_setup
from oilwatch.models.system.transient_comparison import (
    results_path,
    synchronous_table_path,
    transient_figures,
)

MACHINE = load_machine(None)
RESULTS = json.loads(results_path(MACHINE).read_text()) if results_path(MACHINE).exists() else {}


def _study_mesh(key: str) -> Mesh:
    return Mesh(**RESULTS[key]["provenance"]["mesh"])


@pytest.mark.skipif(not synchronous_table_path(MACHINE, 75.0).exists(), reason="no synchronous table")
def test_synchronous_table_row_recomputes():
    table = CoefficientTable.load(synchronous_table_path(MACHINE, 75.0))
    row = table.rows[len(table.rows) // 2 + 1]
    mesh = Mesh(**table.metadata["mesh"])
    supply = SupplyFlow(row["supply_flowrate_m3_s"])
    guess = np.array([row["eccentricity_x_m"], row["eccentricity_y_m"]])
    eq = static_equilibrium(MACHINE.bearing, table.load_n, 75.0, supply, mesh, initial_guess_m=guess)
    k, c = synchronous_coefficients(eq.film, eq.eccentricity_m, 75.0, supply)
    i = table.rows.index(row)
    np.testing.assert_allclose(k, table.stiffness[i], atol=1e-6 * np.abs(table.stiffness[i]).max())
    np.testing.assert_allclose(c, table.damping[i], atol=1e-6 * np.abs(table.damping[i]).max())


@pytest.mark.skipif("linear_threshold_60x16" not in RESULTS, reason="no linear threshold in the results")
def test_frequency_dependent_root_recomputes():
    found = RESULTS["linear_threshold_60x16"]
    speed, log_decrement, frequency = found["evaluated"][-1]
    rotor = Rotor.from_machine(MACHINE)
    impedances, quasi = film_impedances(
        MACHINE,
        rotor,
        speed,
        MACHINE.shared_nominal_flowrate_m3_s("this test"),
        _study_mesh("linear_threshold_60x16"),
    )
    mode = least_stable(film_roots(rotor, speed, impedances, quasi))
    assert mode.log_decrement == pytest.approx(log_decrement, abs=1e-6)
    assert mode.frequency_hz == pytest.approx(frequency, abs=1e-6)


@pytest.mark.slow  # transient runs: seconds of film steps
# orbits_240x72 takes the 120x36 run's settings on a mesh four times the cells (20 times its time): the two
# samples below run each code path of the orbit runs
@pytest.mark.parametrize("key", ["orbits", "orbits_120x36"])
def test_orbit_run_start_recomputes(key):
    if key not in RESULTS:
        pytest.skip(f"no {key} in the results")
    run = RESULTS[key]["by_flowrate_pct"]["100"]
    options = {}
    if "position_tolerance_m" in run:
        options = {
            "position_tolerance_m": run["position_tolerance_m"],
            "film_options": {
                "residual_tolerance": run["film_residual_tolerance"],
                "mass_tolerance": 10.0 * run["film_residual_tolerance"],
            },
        }
    sim, _, start, _ = orbit_setup(
        MACHINE,
        _study_mesh(key),
        MACHINE.shared_nominal_flowrate_m3_s("this test"),
        run["steps_per_revolution"],
        **options,
    )
    q = MACHINE.shared_nominal_flowrate_m3_s("this test")
    _, record = sim.run(start, SAMPLE_STEPS, lambda t: (q, q))
    np.testing.assert_allclose(
        record["bearing_positions_m"][-1].ravel() * 1e6,
        run["sample_positions_um"],
        # a run at the plant's coupling tolerance reproduces to that tolerance, not to round-off
        atol=max(1e-5, 20.0 * run.get("position_tolerance_m", 0.0) * 1e6),
    )


@pytest.mark.skipif("orbit_mesh" not in RESULTS, reason="no orbit mesh study in the results")
def test_linear_orbit_of_the_mesh_study_recomputes():
    run = RESULTS["orbit_mesh"]["by_flowrate_pct"]["100"]["runs"]["60x16"]
    again = linear_orbits(MACHINE, Mesh(60, 16), MACHINE.shared_nominal_flowrate_m3_s("this test"))
    np.testing.assert_allclose(again["static_position_um"], run["static_position_um"], atol=1e-6)
    for name in ("frequency-dependent", "full-film"):
        np.testing.assert_allclose(again[name]["amplitude_um"], run[name]["amplitude_um"], rtol=1e-6)
        np.testing.assert_allclose(again[name]["phase_deg"], run[name]["phase_deg"], atol=1e-4)


def test_coupled_integration_holds_the_static_equilibrium():
    """Without unbalance, the rotor on its transient films stays where the steady films carry it."""
    q = MACHINE.shared_nominal_flowrate_m3_s("this test")
    sim = NonlinearRotorBearing(MACHINE, 75.0, Mesh(60, 16), 2e-4, unbalance=False)
    state = sim.static_state((q, q))
    start = sim.selector @ state.r
    state, record = sim.run(state, 10, lambda t: (q, q))
    # The coupling's position tolerance (1e-10 m) is the noise floor: ~1e-4 of the supply in the leakage.
    assert np.abs(record["bearing_positions_m"].reshape(10, -1) - start).max() < 1e-9
    np.testing.assert_allclose(record["side_leakage_m3_s"], q, rtol=1e-3)


@pytest.mark.skipif("threshold" not in RESULTS or "orbits" not in RESULTS, reason="results incomplete")
def test_done_when_figures_of_the_committed_results():
    figures = transient_figures(MACHINE)
    low, high = figures["instability_threshold_direct_bracket_hz"]
    assert high - low <= 2.0
    direct = figures["instability_threshold_direct_hz"]
    assert abs(figures["instability_threshold_frequency_dependent_hz"] / direct - 1.0) <= 0.03
    for check in [figures["orbit_check"], *figures["orbit_check_by_mesh"].values()]:
        for models in check.values():
            assert models["frequency-dependent"]["max_amplitude_error_pct"] <= 5.0
            assert models["frequency-dependent"]["max_phase_error_deg"] <= 5.0
