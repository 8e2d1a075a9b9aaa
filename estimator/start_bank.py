"""A start bank for the flowrates beside free viscosity factors: several starts, the record picks one.

With the viscosity factors free and no baseline, the filter's end point along the nearly unobservable
direction (a lower flow, a thicker film, a larger unbalance, shifted offsets: :mod:`.nuisance_start`)
follows its start: on the robustness ramps at 80/90 % the filter started at the nominal flowrates ends
8-11 % low, started lower it ends within 0.3 %. ``scripts/free_factor_likelihood.py`` holds each end
point's parameters fixed and sums the record's innovations: both are minima of the summed NIS with a
higher one between (a local optimum of the filter model's likelihood, not only a linearization artefact),
and the right one has the lower sum. So the record can choose between starts where one filter cannot
travel: multiple-model adaptive estimation (Magill, IEEE Trans. Automatic Control 10, 1965; Maybeck,
"Stochastic Models, Estimation, and Control" vol. 2, 1982, ch. 10) used as a start.

:class:`StartBank` runs one filter per start, the starts spread along the flowrates' prior only (fractions
:data:`START_FRACTIONS` of the configured initial flowrate, both bearings alike; the other states at their
prior), through a selection window; at its end it keeps the filter whose accumulated NIS since the settling
start's restart is smallest (the log-likelihood up to the log-determinant of the innovation covariance,
the same to first order for filters with the same measurement noise and settled dynamic states) and
continues it alone. Before the choice the reports are the nominal start's (the unchanged filter's), so the
bank is causal and costs ``len(starts)`` filters for the window only.
"""

from __future__ import annotations

import copy
import dataclasses

import numpy as np

START_FRACTIONS = (1.1, 1.0, 0.9, 0.8, 0.7)
"""The starts, as fractions of the configured initial flowrate: -1.2 to +0.4 prior std of 25 % apart by
0.4 std (the monitored direction is starvation, so most starts lie below nominal)."""

SELECT_S = 20.0
"""The selection window from the first sample [s]: a third of the robustness record; the filters'
accumulated NIS separate in their first tens of seconds and not afterwards (their random walks let each
follow its own point)."""


class StartBank:
    """Filters from :data:`START_FRACTIONS` of the initial flowrate; the smallest accumulated NIS at
    ``select_s`` continues (module docstring). ``step`` takes what :meth:`OilFlowEKF.step` takes and returns
    the report of the filter followed (the nominal start's until the choice)."""

    def __init__(
        self,
        model,
        config,
        fractions=START_FRACTIONS,
        select_s: float = SELECT_S,
    ) -> None:
        from .ekf import OilFlowEKF

        q0 = np.asarray(config.for_model(model).q_initial_pair(), dtype=float)
        self.fractions = tuple(float(f) for f in fractions)
        if 1.0 not in self.fractions:
            raise ValueError("the start fractions must include 1 (the configured start)")
        self._nominal = self.fractions.index(1.0)
        # each start its own model (an operating model carries the rotor angle and its correction centre)
        self.filters = [
            OilFlowEKF(
                model if k == self._nominal else copy.deepcopy(model),
                dataclasses.replace(config, q_initial_m3_s=tuple(f * q0)),
            )
            for k, f in enumerate(self.fractions)
        ]
        self._select_step = round(select_s / float(model.dt_s)) if np.isfinite(select_s) else None
        self._settling = self.filters[0]._settling
        self.nis = np.zeros(len(self.filters))
        self.chosen: int | None = None
        self._step = 0

    @staticmethod
    def applies(config) -> bool:
        """Whether ``config`` is the one the bank is for: flowrates estimated beside viscosity factors that
        no baseline primed, with the shadow Jacobian (:mod:`.nuisance_start`; every other configuration
        runs one filter, unchanged)."""
        baseline = config.offset_baseline
        free = config.viscosity_factor_prior_std > 0.0
        free = free and (baseline is None or baseline.viscosity_factor is None)
        return free and config.flowrate_process_std_m3_s > 0.0 and config.nuisance_shadow

    @property
    def active(self):
        """The filter whose reports are given (the chosen one, else the nominal start's)."""
        return self.filters[self._nominal if self.chosen is None else self.chosen]

    def step(self, displacement_m, **operating):
        """One sample through every filter until the choice, then through the chosen one."""
        if self.chosen is not None:
            return self.active.step(displacement_m, **operating)
        reports = []
        for ekf in self.filters:
            reports.append(ekf.step(displacement_m, **operating))
            if self._step > self._settling:
                self.nis[len(reports) - 1] += reports[-1].nis
        self._step += 1
        if self._select_step is not None and self._step >= self._select_step:
            self.chosen = int(np.argmin(self.nis))
            self.filters = [ekf if k == self.chosen else None for k, ekf in enumerate(self.filters)]
        return reports[self._nominal if self.chosen is None else self.chosen]
