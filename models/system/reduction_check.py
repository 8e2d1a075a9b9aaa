"""How much flowrate the reduced (Craig-Bampton) model's error is worth: the check behind a machine's
``reduced_model.cutoff_hz``.

The estimator runs on the reduced model, the plant on all physical dofs. What the reduction leaves out (the
fixed-interface modes above the cutoff, beyond their static correction) changes the model's static probe
positions and 1x orbits a little, and the estimator reads that difference as oil flow. Its size in flow is
what matters, and that depends on how little the response moves with the flow: in the flooded band (supply
above the flooded threshold) a 1 % flow change moves a bearing's 1x orbit by hundredths of a micron, so a
reduction error of the same size is a bias of a whole percent.

:func:`reduction_flow_bias` takes the reduced model's static positions and complex 1x amplitudes at the probes
against the full model's at given flowrates, and solves for the flowrate change that best explains the
difference in least squares, with the nuisances the real-machine estimator has free beside it: a static
offset per probe and the complex unbalance (a scale and a phase of the 1x response). That is the bias a
noise-free estimator with those nuisances free would show from the reduction alone (the linearized "consider"
analysis; Crassidis & Junkins 2012, Optimal Estimation of Dynamic Systems, sec. 2.6).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..machine import Machine
from .factory import build_system

POINTS_PCT = ((100.0, 100.0), (80.0, 90.0), (80.0, 80.0))
"""Flowrates [% of nominal] where the reduction is checked: nominal, and the robustness cases' truth points
(bearing 2 at 90 % sits in the flooded band of the bundled machines, where the flow moves the 1x orbit
least)."""
STEP_PCT = 1.0
"""Flowrate step of the sensitivity columns [% of nominal]."""


@dataclass(frozen=True)
class ReductionError:
    """The reduced model's error at one pair of flowrates.

    Attributes: flowrates_pct (2,) [% of nominal]; n_coordinates of the reduced model; orbit_error_um (4,)
    |1x reduced - 1x full| per probe; orbit_sensitivity_um (2, 4) |1x change| per probe for a 1 % change
    of each bearing's flowrate; flow_bias_pct (2,) the flowrate change [% of its own nominal] that explains
    the difference with offsets and unbalance free (module docstring).
    """

    flowrates_pct: tuple[float, float]
    n_coordinates: int
    orbit_error_um: np.ndarray
    orbit_sensitivity_um: np.ndarray
    flow_bias_pct: np.ndarray


def _probe_response(system, flowrates_m3_s: np.ndarray) -> np.ndarray:
    """Static positions and 1x complex amplitudes at the probes (8,) complex [m]."""
    h = system.output_matrix[:, : system.n_coordinates]
    static = h @ system.static_coordinates(flowrates_m3_s)
    return np.concatenate([static, h @ system.unbalance_coordinates(flowrates_m3_s)])


def _real_rows(response: np.ndarray) -> np.ndarray:
    """The 12 real observations: 4 static positions, the 1x amplitudes' real and imaginary parts."""
    return np.concatenate([response[:4].real, response[4:].real, response[4:].imag])


def reduction_flow_bias(
    machine: Machine, cutoff_hz: float | None = None, points_pct=POINTS_PCT, full=None
) -> list[ReductionError]:
    """The reduced model's error (``cutoff_hz``, default the machine file's) against the full model at each
    pair of flowrates in ``points_pct`` [% of each bearing's nominal], as flowrate (module docstring).
    ``full``: the full system built earlier (:func:`build_system` with ``reduced=False``).

    Examples
    --------
    >>> from oilwatch.models.machine import load_machine
    >>> [error] = reduction_flow_bias(load_machine("turbine"), points_pct=[(80.0, 90.0)])
    >>> bool(abs(error.flow_bias_pct).max() < 0.05)
    True
    """
    full = build_system(machine, reduced=False) if full is None else full
    reduced = build_system(machine, reduced=True, cutoff_hz=cutoff_hz)
    nominal = machine.lubrication.nominal_flowrates_m3_s
    errors = []
    for point in points_pct:
        q = np.asarray(point, dtype=float) / 100.0 * nominal
        exact = _probe_response(full, q)
        columns, sensitivity = [], []
        for b in range(2):
            moved = q.copy()
            moved[b] += STEP_PCT / 100.0 * nominal[b]
            change = _probe_response(full, moved) - exact
            columns.append(_real_rows(change) / STEP_PCT)
            sensitivity.append(np.abs(change[4:]) / STEP_PCT * 1e6)
        orbit = exact[4:]
        nuisances = np.zeros((12, 6))
        nuisances[:4, :4] = np.eye(4)  # a static offset per probe
        nuisances[4:, 4] = np.concatenate([orbit.real, orbit.imag])  # the unbalance: scale ...
        nuisances[4:, 5] = np.concatenate([-orbit.imag, orbit.real])  # ... and phase of the 1x response
        design = np.hstack([np.column_stack(columns), nuisances])
        difference = _real_rows(_probe_response(reduced, q) - exact)
        solution = np.linalg.lstsq(design, difference, rcond=None)[0]
        errors.append(
            ReductionError(
                flowrates_pct=(float(point[0]), float(point[1])),
                n_coordinates=reduced.n_coordinates,
                orbit_error_um=np.abs(difference[4:8] + 1j * difference[8:12]) * 1e6,
                orbit_sensitivity_um=np.array(sensitivity),
                flow_bias_pct=-solution[:2],
            )
        )
    return errors
