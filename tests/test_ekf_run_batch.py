"""``OilFlowEKF.run_batch``, the batch entry of ``oilwatch estimate``, gives exactly what ``step`` gives.

On a grid model at one speed the whole block runs in one compiled call (the grid's transition and the
filter's step; ``step`` itself takes that path, one sample at a time); with an operating point it goes
sample by sample through Python. Either way the trace must equal the Python steps bit for bit, block after
block from the filter's state, with a NaN operating point meaning "not given" for that sample.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from oilwatch.estimator.ekf import OilFlowEKF
from oilwatch.estimator.ekf_config import EKFConfig
from oilwatch.estimator.reports import EstimateTrace
from oilwatch.models.machine import load_machine
from oilwatch.models.system.factory import load_system
from oilwatch.models.system.operating_model import build_operating_model

STORED = Path(__file__).parent / "data" / "ekf_reference_trace.npz"
FIELDS = ("q_m3_s", "q_std_m3_s", "nis", "n_measurements", "converged", "measurement_ok", "starved",
          "probe_status", "model_consistent", "changing", "starved_consistent", "viscosity_factor",
          "viscosity_factor_std")  # fmt: skip


@pytest.fixture(scope="module")
def record():
    values = np.load(STORED)["constant/record"][:900].copy()
    values[300, 1] = np.nan  # a dropped channel
    values[301:305] = np.nan  # a missing stretch
    values[600, 2] += 40e-6  # a glitch
    return values


@pytest.fixture(scope="module")
def operating():
    return build_operating_model(load_system(reduced=True), load_machine())


def _steps(ekf, record, speed=None, temperature=None):
    reports, offsets = [], []
    for k, z in enumerate(record):
        given = [None if v is None else float(v[k]) for v in (speed, temperature)]
        given = [None if v is None or v != v else v for v in given]  # NaN: not given
        reports.append(ekf.step(z, *given))
        offsets.append(ekf.offset_m)
    return reports, np.array(offsets)


def _blocks(ekf, record, speed=None, temperature=None, size=400):
    out = EstimateTrace.empty(size)
    parts = []
    for start in range(0, len(record), size):
        part = slice(start, start + size)
        pick = [None if v is None else v[part] for v in (speed, temperature)]
        trace = ekf.run_batch(record[part], *pick, out=out)
        count = len(record[part])
        parts.append({f: getattr(trace, f)[:count].copy() for f in (*FIELDS, "offset_m")})
    return {f: np.concatenate([p[f] for p in parts]) for f in parts[0]}


def _same(trace, reports, offsets):
    for field in FIELDS:
        np.testing.assert_array_equal(trace[field], np.array([getattr(r, field) for r in reports]), field)
    np.testing.assert_array_equal(trace["offset_m"], offsets)


class _WithoutBatch:
    """A grid model seen through the protocol only (no ``batch_transition``): the filter steps it from
    Python, the path the compiled batch must reproduce."""

    def __init__(self, model) -> None:
        self._model = model

    def __getattr__(self, name):
        if name == "batch_transition":
            raise AttributeError(name)
        return getattr(self._model, name)


def test_a_grid_model_s_compiled_batches_equal_its_python_steps(operating, record):
    config = EKFConfig.recommended(offset_prior_std_m=10e-6)
    batched = OilFlowEKF(operating.reference, config)
    stepped = OilFlowEKF(_WithoutBatch(operating.reference), config)
    assert batched._grid_batch is not None and stepped._grid_batch is None  # the two paths under test
    trace = _blocks(batched, record)
    reports, offsets = _steps(stepped, record)
    _same(trace, reports, offsets)
    compiled, _ = _steps(OilFlowEKF(operating.reference, config), record)  # step() takes the batch path
    _same(trace, compiled, offsets)
    assert trace["offset_m"][-1].any() and not trace["measurement_ok"][301:305].any()


def test_an_operating_model_s_batches_equal_its_steps_with_nan_as_not_given(operating, record):
    config = EKFConfig.recommended(viscosity_factor_prior_std=0.05)
    nominal = load_machine().nominal_oil_temperature_c
    speed = 75.0 + 1e-3 * np.arange(len(record))
    temperature = nominal + 0.01 * np.arange(len(record))
    speed[100:140] = np.nan
    temperature[500] = np.nan
    trace = _blocks(OilFlowEKF(operating, config), record, speed, temperature)
    reports, offsets = _steps(OilFlowEKF(operating, config), record, speed, temperature)
    _same(trace, reports, offsets)


def test_a_step_report_s_values_are_its_fields_in_the_report_layout(operating, record):
    from oilwatch.estimator import step_kernel as layout

    ekf = OilFlowEKF(operating.reference, EKFConfig.recommended(offset_prior_std_m=10e-6))
    for z in record[:50]:
        report = ekf.step(z)
    values = report.values
    assert not values.flags.writeable
    np.testing.assert_array_equal(values[layout.REPORT_FLOWRATE : layout.REPORT_FLOWRATE + 2], report.q_m3_s)
    assert values[layout.REPORT_NIS] == report.nis and values[layout.REPORT_ROWS] == report.n_measurements
    np.testing.assert_array_equal(values[layout.REPORT_OFFSET : layout.REPORT_OFFSET + 4], ekf.offset_m)
    ekf.step(record[50])
    assert values[layout.REPORT_NIS] == report.nis  # a copy: the next step leaves it alone
