"""Measurement channels of the EKF: the four displacements and, optionally, their backward differences.

The paper (section 3.2) feeds eight channels, the four measured displacements ``d_k = H s_k + v_k`` and the
velocities differentiated from them, ``(d_k - d_{k-1}) / dt``, modelled as ``H_v s_k`` with ``R = sigma^2 I``.
Two treatments are offered:

``"paper"``
    eight channels, ``R = sigma^2 I_8`` in SI units, literally as published. The true variance of a
    differentiated channel is ``2 sigma^2 / dt^2`` (2e6 times larger at dt = 1 ms), so the filter trusts the
    velocities far too much.
``"displacement-only"``
    the four displacements, ``R = sigma^2 I_4``. Since ``(d_k - d_{k-1}) / dt`` is a linear function of
    ``d_k`` and ``d_{k-1}``, a filter that has used ``d_{k-1}`` and ``d_k`` exactly gains nothing from it;
    its measurement noise really is white and its model is exact, and it is the default.

No eight-channel treatment can do better: even with the exact within-step joint covariance of
``[v_k, (v_k - v_{k-1}) / dt]`` it would count the previous step's noise ``v_{k-1}`` twice (the filter has
already used it) and model the backward difference, the mean velocity over the step (the velocity half a step
earlier: 13.5 deg of phase at 75 Hz and 1 ms), as ``H_v s_k``. On a plant with large orbits that lag biases
it and its reported std does not cover the error; with small orbits it comes close to the four channels but
gains nothing over them, so the paper's treatment is kept only to reproduce the paper.
"""

from __future__ import annotations

import numpy as np

from .model import AugmentedModel


def probe_rotation(probe_angle_rad: float) -> np.ndarray:
    """(4, 4) map from the bearings' (x1, y1, x2, y2) to the probe signals along the probes' axes.

    Each bearing's probe pair is mounted at ``probe_angle_rad`` from the model's axes, counter-clockwise from
    +x towards +y (x horizontal, y vertical up): its X probe reads ``cos a x + sin a y``, its Y probe
    ``-sin a x + cos a y``. 0: probes along the model's axes; 45 deg: the API 670 pair 45 deg either side of
    top dead centre.
    """
    c, s = np.cos(probe_angle_rad), np.sin(probe_angle_rad)
    block = np.array([[c, s], [-s, c]])
    rotation = np.zeros((4, 4))
    rotation[:2, :2] = block
    rotation[2:, 2:] = block
    return rotation


def displacement_channels(
    model: AugmentedModel, noise_std_m: float, probe_angle_rad: float = 0.0, n_offsets: int = 0
) -> tuple[np.ndarray, np.ndarray]:
    """Return ``(H_a, R)`` for the four displacement channels: H_a (4, n + 2 + n_offsets) = [Rot H, 0, I],
    R = sigma^2 I_4; ``n_offsets`` is 0 or 4 (one zero-offset state per probe after the flowrates)."""
    n = model.n_states
    observation = np.zeros((4, n + 2 + n_offsets))
    observation[:, :n] = probe_rotation(probe_angle_rad) @ np.asarray(model.output_matrix, dtype=float)
    if n_offsets:
        observation[:, n + 2 :] = np.eye(4)
    return observation, noise_std_m**2 * np.eye(4)


def velocity_channels(
    model: AugmentedModel, noise_std_m: float, mode: str, probe_angle_rad: float = 0.0, n_offsets: int = 0
) -> tuple[np.ndarray, np.ndarray] | None:
    """Return ``(H_a, R)`` for the eight channels ``[d_k, (d_k - d_{k-1})/dt]``, or None if ``mode`` uses
    none.

    H_a is (8, n + 2 + n_offsets) = [[Rot H, 0, I], [Rot H_v, 0, 0]] (a constant offset has no velocity); R
    = sigma^2 I_8 (the paper's).
    """
    if mode == "displacement-only":
        return None
    n = model.n_states
    rotation = probe_rotation(probe_angle_rad)
    observation = np.zeros((8, n + 2 + n_offsets))
    observation[:4] = displacement_channels(model, noise_std_m, probe_angle_rad, n_offsets)[0]
    observation[4:, :n] = rotation @ np.asarray(model.velocity_output_matrix, dtype=float)
    return observation, noise_std_m**2 * np.eye(8)
