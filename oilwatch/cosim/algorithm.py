"""Fixed-step co-simulation algorithms: one macro step over all slaves.

Gauss-Seidel (the default): the slaves step one after another in the given order, and each one's
inputs are set just before its step from the latest outputs, so a slave later in the order sees
the outputs its predecessors produced at the END of the current step (plant first: the estimator
sees the measurement of t + h). Jacobi: all inputs are set from the outputs at the START of the step
(time t), then all slaves step; every connection therefore lags by one macro step.
"""

from __future__ import annotations

from collections.abc import Callable

from .connections import Transfer
from .errors import SystemDescriptionError
from .loading import Slave

METHODS = ("gauss-seidel", "jacobi")


def gauss_seidel_stepper(order: list[Slave], transfers: list[Transfer]) -> Callable[[float, float], None]:
    """A function ``step(t, h)`` doing one Gauss-Seidel macro step in ``order``."""
    plan = [(slave, [tr for tr in transfers if tr.target is slave]) for slave in order]

    def step(time: float, step_size: float) -> None:
        for slave, incoming in plan:
            for transfer in incoming:
                transfer.move()
            slave.do_step(time, step_size)

    return step


def jacobi_stepper(order: list[Slave], transfers: list[Transfer]) -> Callable[[float, float], None]:
    """A function ``step(t, h)`` doing one Jacobi macro step (all inputs from time t)."""

    def step(time: float, step_size: float) -> None:
        for transfer in transfers:
            transfer.pull()
        for transfer in transfers:
            transfer.push()
        for slave in order:
            slave.do_step(time, step_size)

    return step


def make_stepper(method: str, order: list[Slave], transfers: list[Transfer]):
    """The stepper for ``method`` ("gauss-seidel" or "jacobi")."""
    if method == "gauss-seidel":
        return gauss_seidel_stepper(order, transfers)
    if method == "jacobi":
        return jacobi_stepper(order, transfers)
    raise SystemDescriptionError(f"method must be one of {METHODS}, got {method!r}")
