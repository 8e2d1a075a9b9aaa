"""Speed and oil-temperature profiles of scenarios."""

import numpy as np
import pytest

from oilwatch.models.system.profiles import OperatingProfile, parse_profile
from oilwatch.models.validation import InputError


def test_shapes():
    t = np.array([0.0, 1.0, 2.0, 6.0, 20.0])
    np.testing.assert_allclose(OperatingProfile("constant", 75.0)(t), 75.0)
    np.testing.assert_allclose(OperatingProfile("step", 75.0, 70.0, 2.0)(t), [75, 75, 70, 70, 70])
    np.testing.assert_allclose(OperatingProfile("ramp", 72.0, 78.0, 1.0, 10.0)(t), [72, 72, 72.6, 75, 78])
    assert OperatingProfile("ramp", 72.0, 78.0, 1.0, 10.0)(6.0) == pytest.approx(75.0)


def test_parse_relative_values_and_errors():
    profile = parse_profile("ramp:+0:+10:0:60", 30.8, "--oil-temperature-profile")
    assert (profile.initial, profile.final, profile.duration_s) == (
        pytest.approx(30.8),
        pytest.approx(40.8),
        60,
    )
    assert parse_profile("step:75:70:5", 75.0, "--speed-profile").final == 70.0
    with pytest.raises(InputError, match="--speed-profile must be"):
        parse_profile("ramp:72:78", 75.0, "--speed-profile")
    with pytest.raises(InputError, match="duration_s"):
        parse_profile("ramp:72:78:0:0", 75.0, "--speed-profile")
