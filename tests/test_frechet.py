"""oilwatch.models.system.frechet: the exponential and its Frechet derivatives in many directions, against
scipy's."""

import numpy as np
import pytest
from scipy.linalg import expm_frechet

from oilwatch.models.system.frechet import expm_frechet_many


def _stiff_block(rng, size=12):
    """A rotor-like block: [[0, I dt], [-K dt, -C dt]] with entries of very different sizes (17 squarings)."""
    half = size // 2
    block = np.zeros((size, size))
    block[:half, half:] = 1e-3 * np.eye(half)
    block[half:, :half] = -1e4 * rng.uniform(0.5, 2.0, (half, half))
    block[half:, half:] = -10.0 * rng.uniform(0.5, 2.0, (half, half))
    return block


@pytest.mark.parametrize("scale", [1e-3, 0.1, 0.5, 1.5, 3.0, None])
def test_every_direction_matches_scipy_at_every_pade_degree(scale):
    """Norms below each degree's bound (3, 5, 7, 9) and above it (13, with and without scaling)."""
    rng = np.random.default_rng(1)
    if scale is None:
        a = _stiff_block(rng)
    else:
        a = rng.standard_normal((9, 9))
        a *= scale / np.abs(a).sum(axis=0).max()
    directions = rng.standard_normal((4, *a.shape)) * np.abs(a).max()
    exponential, frechet = expm_frechet_many(a, directions)
    for e, got in zip(directions, frechet, strict=True):
        expected_exp, expected = expm_frechet(a, e)
        assert np.abs(exponential - expected_exp).max() <= 1e-13 * np.abs(expected_exp).max()
        assert np.abs(got - expected).max() <= 1e-13 * np.abs(expected).max()


def test_the_derivative_is_the_exponential_s_directional_derivative():
    """Independent of scipy: (exp(A + hE) - exp(A - hE)) / 2h."""
    from scipy.linalg import expm

    rng = np.random.default_rng(2)
    a = rng.standard_normal((7, 7))
    e = rng.standard_normal((2, 7, 7))
    _, frechet = expm_frechet_many(a, e)
    h = 1e-5
    for k in range(2):
        numeric = (expm(a + h * e[k]) - expm(a - h * e[k])) / (2 * h)
        assert np.abs(frechet[k] - numeric).max() < 1e-8 * np.abs(numeric).max()


def test_bad_shapes_are_refused():
    with pytest.raises(ValueError, match="expected A"):
        expm_frechet_many(np.zeros((3, 3)), np.zeros((3, 3)))
