"""The operating model's compiled filter step gives exactly the estimates of the Python prediction path.

On the operating model a predicted sample is one compiled call
(:func:`oilwatch.estimator.step_kernel.operating_step`: the shadow's and the estimate's transitions and the
update), back in Python only to re-centre the correction. The same filter on the same model without its
compiled entry (``compiled_transition`` hidden) takes the Python path of the model's ``transition_full``
and ``ekf_step``; both runs here see a record whose speed and oil temperature ramp fast enough to re-centre
the correction many times, with the viscosity factors free (shadow Jacobian, settling start, information
floor), and must agree bit for bit in every reported value and the whole filter state.
"""

from __future__ import annotations

import copy
import dataclasses

import numpy as np
import pytest

from oilwatch.estimator.ekf import OilFlowEKF
from oilwatch.estimator.ekf_config import EKFConfig
from oilwatch.estimator.start_bank import StartBank
from oilwatch.models.machine import load_machine
from oilwatch.models.system.factory import load_system
from oilwatch.models.system.operating_kernels import RECENTRE, operating_transition
from oilwatch.models.system.operating_model import build_operating_model

MACHINE = load_machine()
QN = MACHINE.shared_nominal_flowrate_m3_s("this test")
T0 = MACHINE.nominal_oil_temperature_c
DT = 1e-3
STEPS = 1200
TRUTH = np.array([0.85, 0.95]) * QN
FACTORS = np.array([1.04, 0.97])
FREE = EKFConfig.preset(
    None, first_sample_time_s=DT, offset_prior_std_m=5e-6, nuisance_settling_time_constants=1.0
)


class PythonPrediction:
    """The operating model without its compiled entry: the filter predicts through ``transition_full``."""

    def __init__(self, model) -> None:
        self.model = model

    def __getattr__(self, name: str):
        if name in ("compiled_transition", "model"):  # "model": not yet set in a copy under construction
            raise AttributeError(name)
        return getattr(self.model, name)


@pytest.fixture(scope="module")
def model():
    return build_operating_model(load_system(reduced=True), MACHINE)


@pytest.fixture(scope="module")
def record(model):
    """(measured (K, 4) [m], speed (K,) [Hz], oil temperature (K,) [degC]): the model's own motion at
    :data:`TRUTH` and :data:`FACTORS` through a 72 -> 76 Hz ramp and +6 degC, 1 um noise, then a 2 um step
    on probe 1 (an offset)."""
    plant = copy.deepcopy(model)
    times = np.arange(1, STEPS + 1) * DT
    speed = 72.0 + 4.0 * times / times[-1]
    temperature = T0 + 6.0 * times / times[-1]
    state = plant.static_state(TRUTH)
    rng = np.random.default_rng(5)
    measured = np.empty((STEPS, 4))
    for k in range(STEPS):
        plant.set_operating_point(float(speed[k]), float(temperature[k]))
        state = plant.transition_full(state, TRUTH, k, FACTORS)[0].copy()
        measured[k] = plant.output_matrix @ state + 1e-6 * rng.standard_normal(4)
    measured[STEPS // 2 :, 0] += 2e-6
    return measured, speed, temperature


@pytest.mark.parametrize(
    "config",
    [
        FREE,
        dataclasses.replace(FREE, nuisance_shadow=False),
        EKFConfig.recommended(first_sample_time_s=DT),
    ],
    ids=["machine preset", "factors without shadow", "no nuisances"],
)
def test_the_compiled_step_gives_the_python_path_s_estimates_bit_for_bit(model, record, config):
    measured, speed, temperature = record
    runs = []
    for wrapped in (copy.deepcopy(model), PythonPrediction(copy.deepcopy(model))):
        ekf = OilFlowEKF(wrapped, config)
        before = wrapped.recentre_count
        trace = ekf.run(measured, speed_hz=speed, oil_temperature_c=temperature)
        runs.append((trace, ekf.get_state(), wrapped.recentre_count - before))
    (compiled, compiled_state, recentred), (python, python_state, python_recentred) = runs
    assert recentred == python_recentred
    assert recentred > 3 or config.viscosity_factor_prior_std == 0.0
    for field in dataclasses.fields(compiled):
        assert np.array_equal(getattr(compiled, field.name), getattr(python, field.name), equal_nan=True), (
            field.name
        )
    assert compiled_state.keys() == python_state.keys()
    for key, value in compiled_state.items():
        assert np.array_equal(value, python_state[key], equal_nan=True), key


def test_the_start_bank_s_compiled_steps_give_the_python_path_s_estimates(model, record):
    measured, speed, temperature = record
    traces = []
    for wrapped in (copy.deepcopy(model), PythonPrediction(copy.deepcopy(model))):
        bank = StartBank(wrapped, FREE, select_s=0.8)
        traces.append(bank.run_batch(measured, speed_hz=speed, oil_temperature_c=temperature))
    for field in dataclasses.fields(traces[0]):
        assert np.array_equal(
            getattr(traces[0], field.name), getattr(traces[1], field.name), equal_nan=True
        ), field.name


def test_a_second_state_s_next_state_is_that_of_a_transition_of_its_own(model):
    """The estimate's prediction beside the shadow's (one pass over the grid nodes and the correction's
    matrices) has the digits of the model's transition from the estimate, on the grid and corrected."""
    model = copy.deepcopy(model)
    arrays, w, _ = model.compiled_transition()
    rng = np.random.default_rng(3)
    static = model.static_state(TRUTH)
    first, second = (static * (1.0 + 0.1 * rng.standard_normal(static.size)) for _ in range(2))
    unbalance = np.array([1.1, -0.2])

    def transition(step, phase, state, *second):
        arguments = (arrays, state, w, phase, unbalance, *TRUTH, *FACTORS, True, step, *second)
        while operating_transition(*arguments) == RECENTRE:
            model.recentre_due(step)

    for step, (speed, temperature) in enumerate([(model.speed_hz, None), (75.0, T0 + 4.0)]):
        model.set_operating_point(speed, temperature)
        phase = model.transition_phase(step)
        alone = []
        for state in (first, second):
            transition(step, phase, state)
            alone.append([a.copy() for a in arrays[8:13]])
        beside = np.empty(static.size)
        transition(step, phase, first, second, beside)
        assert np.array_equal(beside, alone[1][0])
        for together, own in zip(arrays[8:13], alone[0], strict=True):
            assert np.array_equal(together, own)
