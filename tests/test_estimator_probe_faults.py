"""Probe faults on the real plant: the faulty channel is flagged and excluded, the estimate stays right.

Truth: the plant's Newmark integration of the full model at nominal flowrates, 1 um noise; filter: the reduced
grid model with the recommended tuning. Each fault starts at 3 s on probe y1 (the channel that carries most of
bearing 1's information). Measured when written (8 s records): every estimate within 2 of its stds of the
truth at every sample after the fault, the same final means as the clean run within 0.03 % of nominal; dead
and stuck probes flagged 49 and 99 ms after the fault, out-of-range readings at once; no alarm, no other probe
flagged. With the synchronous 1x model (issue 16) 99.9 % of the samples are within 2 stds, all within 2.5,
and each bearing's final mean is within its std of the clean run's.
"""

from __future__ import annotations

import numpy as np
import pytest
from fixtures.toy_model import NOMINAL_FLOWRATE_M3_S

from oilwatch.estimator.channels import DEAD, OK, OUT_OF_RANGE, REJECTED, STUCK
from oilwatch.estimator.ekf import OilFlowEKF
from oilwatch.estimator.ekf_config import EKFConfig
from oilwatch.models.system.augmented import GridAugmentedModel
from oilwatch.models.system.factory import load_system
from oilwatch.models.system.plant import RotorBearingPlant

QN = NOMINAL_FLOWRATE_M3_S
DT = 1e-3
START = 3000
FAULTS = {
    # name: (injection on y1, expected status while faulty, whether the probe is back by the end)
    "dead": (lambda y: np.full(y.size - START, np.nan), DEAD, False),
    "stuck": (lambda y: np.full(y.size - START, y[START - 1]), STUCK, False),
    "huge": (lambda y: np.r_[np.full(500, 1.0), y[START + 500 :]], OUT_OF_RANGE, True),
    "glitch_500um": (lambda y: np.r_[y[START : START + 100] + 500e-6, y[START + 100 :]], OUT_OF_RANGE, True),
    "glitch_50um": (lambda y: np.r_[y[START : START + 100] + 50e-6, y[START + 100 :]], REJECTED, True),
}


@pytest.fixture(scope="module")
def runs():
    model = GridAugmentedModel(load_system(reduced=True), DT)
    plant = RotorBearingPlant(load_system(reduced=False), DT, None, 1e-6, 7, initial_flowrates_m3_s=(QN, QN))
    record = np.array([plant.step((QN, QN)).measured_position_m for _ in range(8000)])
    config = EKFConfig.recommended(first_sample_time_s=DT)
    traces = {"clean": OilFlowEKF(model, config).run(record)}
    for name, (inject, _, _) in FAULTS.items():
        data = record.copy()
        data[START:, 1] = inject(record[:, 1])
        traces[name] = OilFlowEKF(model, config).run(data)
    return traces


@pytest.mark.parametrize("name", sorted(FAULTS))
def test_the_faulty_probe_is_flagged_and_the_estimate_stays_within_its_std(runs, name):
    _, status, recovers = FAULTS[name]
    trace, clean = runs[name], runs["clean"]
    y1 = trace.probe_status[:, 1]
    assert (y1[:START] == OK).all() and (y1[START : START + 100] == status).any()
    assert (y1[-1] == OK) == recovers
    assert not trace.probe_faulty[:, [0, 2, 3]].any()
    assert not trace.starved.any() and not clean.starved.any()
    assert trace.measurement_ok[START:].all()  # the other probes update the filter at every sample
    error = np.abs(trace.q_m3_s[START:] - QN)
    # The clean run itself touches 2.05 std on bearing 2 for a few samples with the synchronous 1x model
    # (1.97 with the quasi-static one): "every sample within 2 std" measured the noise realization.
    assert (error <= 2.0 * trace.q_std_m3_s[START:]).mean() >= 0.999
    assert (error <= 2.5 * trace.q_std_m3_s[START:]).all()
    final = trace.q_m3_s[5000:].mean(axis=0)
    # Each bearing against its own std (with y1 dead, bearing 1's std is 1.5 times bearing 2's).
    assert (np.abs(final - clean.q_m3_s[5000:].mean(axis=0)) < trace.q_std_m3_s[-1]).all()
    assert trace.converged[-1]


def test_a_fault_is_flagged_quickly(runs):
    first = {name: np.flatnonzero(runs[name].probe_faulty[:, 1])[0] - START for name in FAULTS}
    assert first["huge"] == first["glitch_500um"] == 0
    assert first["dead"] < 60 and first["stuck"] < 110 and first["glitch_50um"] < 60
