"""Steady-state unbalance response (frequency domain) and static deflection under gravity.

Reference: Friswell et al., "Dynamics of Rotating Machines" (2010), ch. 6 (unbalance
response) and ch. 5 (static load). Responses are complex amplitudes R with r(t) = Re(R exp(i Omega t)).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import scipy.linalg

from ..validation import InputError, require_non_negative
from .assembly import Rotor
from .supports import BearingSupplier, LinearBearing, bearing_matrices, resolve_bearings

MAX_CONDITION = 1e13


def unbalance_response(
    rotor: Rotor,
    speed_hz: float,
    bearings: Sequence[LinearBearing] | BearingSupplier,
) -> np.ndarray:
    """Complex steady-state response (n_dof,) [m, rad] to the unbalance of Eqs. 5-6 at speed_hz.

    Solves (K + K_b - Omega^2 M + i Omega (C + C_b + Omega G)) R = F(Omega), F from
    :meth:`Rotor.unbalance_amplitude`; the response is r(t) = Re(R exp(i Omega t)).
    """
    speed_hz = require_non_negative("speed_hz", speed_hz, "Hz")
    omega = 2.0 * np.pi * speed_hz
    k_b, c_b = bearing_matrices(rotor.n_dof, resolve_bearings(bearings, speed_hz))
    dynamic = (
        rotor.stiffness_matrix
        + k_b
        - omega**2 * rotor.mass_matrix
        + 1j * omega * (rotor.damping_matrix + c_b + omega * rotor.gyroscopic_matrix)
    )
    try:
        return scipy.linalg.solve(dynamic, rotor.unbalance_amplitude(omega))
    except scipy.linalg.LinAlgError:
        raise InputError(
            f"the rotor-bearing system is singular at {speed_hz:g} Hz (unsupported rotor or an "
            "undamped resonance): no steady-state unbalance response"
        ) from None


def unbalance_response_sweep(
    rotor: Rotor,
    speeds_hz: Sequence[float] | np.ndarray,
    bearings_at: Sequence[LinearBearing] | BearingSupplier,
) -> np.ndarray:
    """Complex unbalance responses (n_speeds, n_dof) over ``speeds_hz`` [Hz] (Bode data).

    ``bearings_at`` may be a callable speed_hz -> list of bearings.
    """
    speeds = np.atleast_1d(np.asarray(speeds_hz, dtype=float))
    return np.array([unbalance_response(rotor, float(s), bearings_at) for s in speeds])


def orbit_semi_axes(response: np.ndarray, node: int) -> tuple[float, float]:
    """Major and minor semi-axes [m] of the elliptical orbit at ``node`` for a complex response."""
    x, y = response[4 * (node - 1)], response[4 * (node - 1) + 1]
    # Split into forward and backward circular components: |r_f| +- |r_b| are the semi-axes.
    forward = 0.5 * abs(x + 1j * y)
    backward = 0.5 * abs(x - 1j * y)
    return forward + backward, abs(forward - backward)


def static_deflection(rotor: Rotor, bearings: Sequence[LinearBearing]) -> np.ndarray:
    """Static displacement (n_dof,) [m, rad] under the static load: (K + K_b) r = static_force (the weight
    and any external force that makes a bearing's static load the machine file's).

    Raises :class:`InputError` if the supports do not hold the rotor (singular stiffness).
    """
    k_b, _ = bearing_matrices(rotor.n_dof, bearings)
    stiffness = rotor.stiffness_matrix + k_b
    # A free rotor's K has condition numbers near 1/eps; supported rotors stay below about 1e11.
    if np.linalg.cond(stiffness) > MAX_CONDITION:
        raise InputError("the bearings do not hold the rotor statically (singular stiffness)")
    return np.linalg.solve(stiffness, rotor.static_force)
