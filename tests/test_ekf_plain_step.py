"""The estimator FMU's compiled plain step (``fmu_src/ekf_plain_step.py``) against the slave's Python step, in
process: two slaves fed the same inputs, one stepped by the compiled step (the slave's Python ``do_step`` when
it declines, as the loader does), the other by ``do_step`` alone.

Every sample leaves both with bit-identical outputs, filter arrays and keyphasor state; the compiled step
does the plain samples (NaN probes included) and those after a gap (the first sample among them), and
declines, having changed nothing, exactly the others: an infinite, off-grid or repeated time stamp and a
changed operating point. The FMU
level (the loader calling it without the GIL, statuses and messages) is ``tests/test_fmu_fast_path.py``.
"""

from __future__ import annotations

from fixtures.fmu_subprocess import run_json

RUN = """
import math
import numpy as np
from oilwatch.fmu_src.oilwatch_ekf_slave import OilFlowEKF
from oilwatch.fmu_src.ekf_plain_step import KERNEL_DECLINED, KERNEL_DONE

def initialized():
    slave = OilFlowEKF(instance_name="ekf")
    slave.preset = "paper"  # the plain step: the flowrate grid at one speed, no nuisance states
    slave.setup_experiment(0.0, None, None)
    slave.enter_initialization_mode()
    slave.exit_initialization_mode()
    return slave

compiled, python = initialized(), initialized()
plain = compiled.plain_step_table().step
start = python._inputs.copy()

def snapshot(slave):
    arrays = [*slave.filter._packed, slave._outputs, slave._keyphasor_cell]
    return [a.copy() for a in arrays]

def same(a, b):
    return all(np.array_equal(x, y, equal_nan=True) for x, y in zip(a, b, strict=True))

h = 1e-3
rng = np.random.default_rng(4)
answers, declined_unchanged, mismatches = [], [], []
SPECIAL = {100: "inf stamp", 150: "off grid", 200: "repeated", 250: "speed", 300: "gap"}
for k in range(1, 400):
    if SPECIAL.get(k) == "gap":
        continue  # this sample never arrives: the next one is two periods on
    inputs = start.copy()
    inputs[:4] = rng.normal(0.0, 20.0, 4)
    inputs[4] = k * h  # t_sample_s
    inputs[5] = -1.0 if k < 200 else 36.0 * (k % 10)  # the keyphasor connected from 200 on
    inputs[-2:] = ((k - 1) * h, h)  # the loader's time and step size
    if k % 37 == 0:
        inputs[k % 4] = math.nan  # a dropped channel: still a plain sample
    special = SPECIAL.get(k)
    if special == "inf stamp":
        inputs[4] = math.inf
    elif special == "off grid":
        inputs[4] = (k - 0.3) * h
    elif special == "repeated":
        inputs[4] = (k - 1) * h
    elif special == "speed":
        inputs[6] = start[6] + 1.0
    compiled._inputs[:] = inputs
    python._inputs[:] = inputs
    before = snapshot(compiled)
    answer = plain()
    answers.append([k, int(answer)])
    if answer == KERNEL_DECLINED:
        declined_unchanged.append([k, same(before, snapshot(compiled))])
        if special == "speed":
            continue  # the Python step refuses a speed away from the grid's: not stepped on either
        compiled.do_step(inputs[-2], h)
    python.do_step(inputs[-2], h)
    keyphasor = compiled.keyphasor_state == python.keyphasor_state
    if not (same(snapshot(compiled), snapshot(python)) and keyphasor):
        mismatches.append(k)
result = {"answers": answers, "declined": declined_unchanged, "mismatches": mismatches,
          "done": KERNEL_DONE, "t_estimate": float(compiled.t_estimate_s),
          "q1": float(compiled.q1_est_ml_min), "keyphasor": compiled.keyphasor_state}
"""


def test_the_compiled_plain_step_is_the_python_step_bit_for_bit():
    result = run_json(RUN, timeout=600)
    assert result["mismatches"] == []
    declined = [k for k, answer in result["answers"] if answer != result["done"]]
    # only the special ones: the first sample (index 1, the filter at 0: a gap) and the gap after each
    # sample that was not stepped (off grid, repeated, refused speed, missing) are compiled steps
    assert declined == [100, 150, 200, 250]
    assert all(unchanged for _, unchanged in result["declined"])
    assert result["t_estimate"] == 399 * 1e-3  # the last sample's time, as the slave computes it
    assert result["q1"] > 0.0 and result["keyphasor"] is not None
