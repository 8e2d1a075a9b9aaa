"""The estimator of a configuration: one construction for every caller.

``oilwatch estimate``, the estimator FMU and the robustness report build their estimator here, so that the
report tests the estimator the product runs: :class:`oilwatch.estimator.start_bank.StartBank` where it applies
(the flowrates beside nuisances no baseline primed: several starts, the record's NIS picks
one in the first :data:`oilwatch.estimator.start_bank.SELECT_S` seconds, at ``len(START_FRACTIONS)`` filters'
cost until then), else one :class:`oilwatch.estimator.ekf.OilFlowEKF`. Both have the same public interface.
"""

from __future__ import annotations

from . import start_bank
from .ekf import OilFlowEKF


def make_estimator(model, config):
    """The estimator of ``config`` on ``model`` (module docstring); the bank's window is read from
    :data:`oilwatch.estimator.start_bank.SELECT_S` when it is built."""
    if start_bank.StartBank.applies(config):
        return start_bank.StartBank(model, config, select_s=start_bank.SELECT_S)
    return OilFlowEKF(model, config)
