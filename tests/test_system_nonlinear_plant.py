"""The high-fidelity plant (rotor on transient films): the plant interface, restart, bad input."""

from __future__ import annotations

import numpy as np
import pytest

from oilwatch.models.bearing.grid import Mesh
from oilwatch.models.machine import load_machine
from oilwatch.models.system.fault import SigmoidFlowrate
from oilwatch.models.system.nonlinear_plant import TransientFilmPlant, check_film_model
from oilwatch.models.validation import InputError

MACHINE = load_machine(None)
Q = MACHINE.shared_nominal_flowrate_m3_s("this test")


@pytest.mark.slow  # transient runs: seconds of film steps
def test_plant_steps_follow_the_schedule_and_restore_bit_identically():
    schedules = tuple(SigmoidFlowrate(Q, 0.75 * Q, 0.001, 0.0002) for _ in range(2))
    plant = TransientFilmPlant(MACHINE, Mesh(60, 16), 1e-3, schedules, 1e-6, seed=3)
    first = plant.step()
    assert first.true_position_m.shape == (4,)
    assert plant.rotor_angle_rad == pytest.approx(2.0 * np.pi * MACHINE.nominal_speed_hz * 1e-3)  # keyphasor
    snapshot = plant.snapshot()
    a = [plant.step()]
    plant.restore(snapshot)
    b = [plant.step()]
    for x, y in zip(a, b, strict=True):
        np.testing.assert_array_equal(x.measured_position_m, y.measured_position_m)
    assert b[-1].flowrate_m3_s[0] < 0.9 * Q
    # The journal sits near its static eccentricity (14 um, attitude ~66 deg) on a few-um orbit.
    assert 10e-6 < np.hypot(*b[-1].true_position_m[:2]) < 20e-6


def test_film_model_names_are_checked():
    assert check_film_model("transient-film") == "transient-film"
    with pytest.raises(InputError, match="film_model must be one of"):
        check_film_model("cfd")


def test_make_plant_picks_the_film_model():
    from oilwatch.models.system.factory import build_system
    from oilwatch.models.system.nonlinear_plant import make_plant
    from oilwatch.models.system.plant import RotorBearingPlant

    system = build_system(MACHINE)
    linear = make_plant(
        "linearized-table", system, MACHINE, 1e-3, None, 0.0, 1, initial_flowrates_m3_s=(Q, Q)
    )
    assert isinstance(linear, RotorBearingPlant)
    other_speed = build_system(MACHINE, reduced=True, unbalance_moment_kg_m=1e-3)
    with pytest.raises(InputError, match="unbalance"):
        make_plant("transient-film", other_speed, MACHINE, 1e-3, None, 0.0, 1, initial_flowrates_m3_s=(Q, Q))


def test_transient_film_plant_takes_the_fmu_default_probes_and_refuses_probe_errors():
    """The FMU's probes without a fault (fault time 1e9 s) are ideal; an offset is refused in one line."""
    from oilwatch.models.system.factory import build_system
    from oilwatch.models.system.measurement import MeasurementChain, ProbeErrors, UnbalanceChange
    from oilwatch.models.system.nonlinear_plant import _refuse_chain_options, make_plant

    _refuse_chain_options(
        {
            "chain": MeasurementChain((ProbeErrors(fault_time_s=1e9),) * 4),
            "unbalance_change": UnbalanceChange(1e9),
        }
    )
    with pytest.raises(InputError, match="unbalance change"):
        _refuse_chain_options({"unbalance_change": UnbalanceChange(5.0, 1e-3)})
    offset = MeasurementChain((ProbeErrors(zero_offset_m=1e-6),) + (ProbeErrors(),) * 3)
    with pytest.raises(InputError, match="ideal probes"):
        make_plant("transient-film", build_system(MACHINE), MACHINE, 1e-3, None, 0.0, 1, (Q, Q), chain=offset)
