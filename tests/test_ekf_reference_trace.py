"""The estimator step gives the estimates of the step before it (fixtures/ekf_reference_trace.py).

The stored records were run through the estimator's step before it was made faster (with the synchronous
1x load at the instantaneous speed, see the script); the estimator must agree within 1e-7 of each field's
largest value on the estimates, their stds and the NIS, and exactly on the counts and flags. Not bit for
bit: the trace is replayed on other CPUs and other numpy and numba releases, whose roundoff (vector
widths, the reassociated sums of the fast-math kernels) the filter carries to a few 1e-9 of the flowrate
over the ramps case's 3000 steps; a change of the filter's behaviour moves the estimates by orders of
magnitude more.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from fixtures import ekf_reference_trace as script

REFERENCE = Path(__file__).parent / "data" / "ekf_reference_trace.npz"
TOLERANCE = 1e-7
"""Of each float field's largest stored value."""


@pytest.fixture(scope="module")
def stored():
    return np.load(REFERENCE)


@pytest.fixture(scope="module")
def models():
    return script.cases(with_records=False)


@pytest.mark.parametrize("name", ["constant", "nuisances", "ramps"])
def test_the_step_reproduces_the_reference_estimates(stored, models, name):
    model, config, _, _, _ = models[name]
    speed = stored[f"{name}/speed_hz"] if f"{name}/speed_hz" in stored else None
    temperature = stored[f"{name}/oil_temperature_c"] if speed is not None else None
    result = script.trace(model, config, stored[f"{name}/record"], speed, temperature)
    for field in script.FIELDS:
        reference = stored[f"{name}/{field}"]
        if reference.dtype.kind == "f":
            scale = np.max(np.abs(reference))
            tolerance = TOLERANCE * scale
            np.testing.assert_allclose(result[field], reference, rtol=0.0, atol=tolerance, err_msg=field)
        else:
            np.testing.assert_array_equal(result[field], reference, err_msg=field)
