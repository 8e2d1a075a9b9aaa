"""A start bank for the flowrates beside nuisances no baseline primed: several starts, the record picks one.

With the viscosity factors free and no baseline, the filter's end point along the nearly unobservable
direction (a lower flow, a thicker film, a larger unbalance, shifted offsets: :mod:`.nuisance_start`) follows
its start. So it does with only the probe offsets and the unbalance free where the flow is weakly observable:
a supply inside the flooded band, where the flow moves the film only through the groove pressure (the bundled
compressor near its nominal supply: one filter started at nominal stays near its start for half the robustness
record, its std small). With each end point's parameters held fixed, the record's summed innovations (NIS)
have a minimum at each end point with a higher sum between (a local optimum of the filter model's likelihood,
not only a linearization artefact), and the right one has the lower sum. So the record can choose between
starts where one filter cannot travel: multiple-model adaptive estimation (Magill, IEEE Trans. Automatic
Control 10, 1965; Maybeck, "Stochastic Models, Estimation, and Control" vol. 2, 1982, ch. 10) used as a start.

:class:`StartBank` runs one filter per start, the starts spread along the flowrates' prior only (fractions
:data:`START_FRACTIONS` of the configured initial flowrate, both bearings alike, each within its own table
range; the other states at their prior), through a selection window; at its end it keeps the filter whose
accumulated NIS since the settling start's restart is smallest (the log-likelihood up to the log-determinant
of the innovation covariance, the same to first order for filters with the same measurement noise and settled
dynamic states) and continues it alone. Before the choice the reports are the leading start's: the nominal
start's until another start's accumulated NIS is lower than the leader's by :data:`LEAD_MARGIN`, then that
start's (the record so far prefers it at a likelihood ratio of about 90; without the margin the leading start
would change on the NIS's sample noise while the sums are small). So the bank is causal, costs at most
``len(starts)`` filters for the window only, and does not report, or alarm on, a start the record already
rejects: on the bundled compressor with three times its unbalance at nominal flow the nominal start drifts to
-16 % in the window and alarms, while the 1.1 start, which the record prefers from its first second, never
does. A start that trails the least sum by :data:`PRUNE_MARGIN` stops running. A record shorter than the
window ends before the choice: its estimates are the leading start's (:attr:`StartBank.chosen` stays None).

The bank has the filter's public interface (:meth:`step`, :meth:`run`, :meth:`run_batch`, :meth:`reset`,
the reports, the nuisance estimates, :meth:`get_state` / :meth:`set_state`), so that every caller builds its
estimator with :func:`oilwatch.estimator.factory.make_estimator` and does not care which one it holds:
``oilwatch estimate``, the estimator FMU and the robustness report run the same estimator.
"""

from __future__ import annotations

import copy
import dataclasses
import math
from collections.abc import Callable

import numpy as np

from oilwatch.models.validation import InputError

from .ekf import sub_state
from .reports import EstimateTrace, StepReport

START_FRACTIONS = (1.1, 1.0, 0.9, 0.8, 0.7)
"""The starts, as fractions of the configured initial flowrate: -1.2 to +0.4 prior std of 25 % apart by
0.4 std (the monitored direction is starvation, so most starts lie below nominal)."""

LEAD_MARGIN = 9.0
"""How much lower another start's accumulated NIS must be than the leading start's for it to lead (a
difference of -2 ln L; 9 is the three-sigma likelihood ratio of one parameter)."""

PRUNE_MARGIN = 100.0
"""A start whose accumulated NIS exceeds the least by more than this stops running (a likelihood ratio of
e^50 against it; on the robustness records no start that once trailed by 50 led again, and two or three of
the five are out within a few seconds, which the window's cost follows). Its sum becomes inf."""

SELECT_S = 20.0
"""The selection window from the first sample [s]: a third of the robustness record; the filters'
accumulated NIS separate in their first tens of seconds and not afterwards (their random walks let each
follow its own point)."""


def _of_active(name: str):
    return property(
        lambda bank: getattr(bank.active, name),
        doc=f"The followed filter's ``{name}`` (:class:`oilwatch.estimator.ekf.OilFlowEKF`).",
    )


class StartBank:
    """Filters from :data:`START_FRACTIONS` of the initial flowrate; the smallest accumulated NIS at
    ``select_s`` continues (module docstring). Every method takes what the same method of
    :class:`oilwatch.estimator.ekf.OilFlowEKF` takes and gives what the filter followed gives (the leading
    start's until the choice)."""

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
        # a start past a bearing's table starts at its edge: the filter holds the flowrate within it anyway
        low, high = np.asarray(model.bearing_flowrate_bounds_m3_s, dtype=float).T
        # each start its own model (an operating model carries the rotor angle and its correction centre);
        # the nominal start is the configured filter itself
        self.filters = [
            OilFlowEKF(model, config)
            if k == self._nominal
            else OilFlowEKF(
                copy.deepcopy(model),
                dataclasses.replace(config, q_initial_m3_s=tuple(np.clip(f * q0, low, high).tolist())),
            )
            for k, f in enumerate(self.fractions)
        ]
        self.select_s = float(select_s)
        self._select_step = round(select_s / float(model.dt_s)) if np.isfinite(select_s) else None
        self.settling_steps = self.filters[self._nominal].settling_steps
        """Samples of the settling start: the NIS is summed from the next one on."""
        self.nis = np.zeros(len(self.filters))
        """Each start's NIS summed since the settling start's restart (inf: stopped, :data:`PRUNE_MARGIN`)."""
        self.chosen: int | None = None
        """The index of the start chosen (None until the window ends)."""
        self.leader = self._nominal
        """The index of the start reported before the choice (module docstring)."""

    @staticmethod
    def applies(config) -> bool:
        """Whether ``config`` is one the bank is for: flowrates estimated beside viscosity factors that no
        baseline primed, or, with no baseline at all, beside free probe offsets or a free unbalance; with
        the shadow Jacobian (:mod:`.nuisance_start`). Every other configuration runs one filter, unchanged."""
        baseline = config.offset_baseline
        factors = config.viscosity_factor_prior_std > 0.0
        factors = factors and (baseline is None or baseline.viscosity_factor is None)
        others = baseline is None and (config.offset_prior_std_m > 0.0 or config.unbalance_prior_std > 0.0)
        return (factors or others) and config.flowrate_process_std_m3_s > 0.0 and config.nuisance_shadow

    @property
    def config(self):
        """The configuration (the nominal start's: the one the bank was built with)."""
        return self.filters[self._nominal].config

    model = _of_active("model")
    alarm = _of_active("alarm")
    step_count = _of_active("step_count")
    flowrate_m3_s = _of_active("flowrate_m3_s")
    flowrate_std_m3_s = _of_active("flowrate_std_m3_s")
    offset_m = _of_active("offset_m")
    offset_std_m = _of_active("offset_std_m")
    unbalance = _of_active("unbalance")
    unbalance_std = _of_active("unbalance_std")
    viscosity_factor = _of_active("viscosity_factor")
    viscosity_factor_std = _of_active("viscosity_factor_std")
    dynamic_state = _of_active("dynamic_state")
    covariance = _of_active("covariance")

    @property
    def _followed(self) -> int:
        """The index of the start whose reports are given: the chosen one, else the leading one."""
        return self.leader if self.chosen is None else self.chosen

    @property
    def active(self):
        """The filter whose reports are given (the chosen one, else the leading start's)."""
        return self.filters[self._followed]

    @property
    def chosen_fraction(self) -> float | None:
        """The chosen start as a fraction of the configured initial flowrate (None before the choice)."""
        return None if self.chosen is None else self.fractions[self.chosen]

    @property
    def active_fraction(self) -> float:
        """The start the reports come from (the chosen one, else the leading one), as a fraction of the
        configured initial flowrate."""
        return self.fractions[self._followed]

    @property
    def samples_to_choice(self) -> float:
        """Samples left until the choice: 0 once chosen, inf when the window never ends (``select_s`` inf)."""
        if self.chosen is not None:
            return 0
        return math.inf if self._select_step is None else max(0, self._select_step - self.step_count)

    def reset(self) -> None:
        """Every start back to its initial state; the choice is open again."""
        for ekf in self.filters:
            ekf.reset()
        self.nis[:] = 0.0
        self.chosen = None
        self.leader = self._nominal

    def step(
        self,
        displacement_m: np.ndarray,
        speed_hz: float | None = None,
        oil_temperature_c: float | None = None,
        rotor_angle_rad: float | None = None,
    ) -> StepReport:
        """One sample through every start until the choice, then through the chosen one."""
        operating = (speed_hz, oil_temperature_c, rotor_angle_rad)
        if self.chosen is not None:
            return self.active.step(displacement_m, *operating)
        index = self.step_count
        reports = {k: self.filters[k].step(displacement_m, *operating) for k in self._running()}
        if index > self.settling_steps:
            for k, report in reports.items():
                self.nis[k] += report.nis
            _prune(self.nis)
            self.leader = _lead(self.leader, self.nis)
        self._choose_when_due()
        return reports[self._followed]

    def _running(self) -> np.ndarray:
        """The starts still running (before the choice)."""
        return np.flatnonzero(np.isfinite(self.nis))

    def run(
        self,
        displacements_m: np.ndarray,
        progress: Callable[[int, int], None] | None = None,
        speed_hz: np.ndarray | None = None,
        oil_temperature_c: np.ndarray | None = None,
    ) -> EstimateTrace:
        """:meth:`oilwatch.estimator.ekf.OilFlowEKF.run` through the bank (``progress`` every 100 samples)."""
        record = _checked(displacements_m)
        count = record.shape[0]
        trace = EstimateTrace.empty(count)

        def through(ekf, rows):
            return ekf.run(record[rows], None, _rows(speed_hz, rows), _rows(oil_temperature_c, rows))

        for start in range(0, count, 100):
            if progress is not None:
                progress(start, count)
            self._advance_rows(through, start, min(start + 100, count), trace)
        if progress is not None:
            progress(count, count)
        return trace

    def run_batch(
        self,
        displacements_m: np.ndarray,
        speed_hz: np.ndarray | None = None,
        oil_temperature_c: np.ndarray | None = None,
        out: EstimateTrace | None = None,
    ) -> EstimateTrace:
        """:meth:`oilwatch.estimator.ekf.OilFlowEKF.run_batch` through the bank (bit-identical to as many
        :meth:`step` calls)."""
        if self.chosen is not None:
            return self.active.run_batch(displacements_m, speed_hz, oil_temperature_c, out)
        record = _checked(displacements_m)
        count = record.shape[0]
        if out is None:
            out = EstimateTrace.empty(count)
        elif out.q_m3_s.shape[0] < count:
            raise InputError(f"out must have at least {count} rows, got {out.q_m3_s.shape[0]}")

        def through(ekf, rows):
            return ekf.run_batch(record[rows], _rows(speed_hz, rows), _rows(oil_temperature_c, rows))

        self._advance_rows(through, 0, count, out)
        return out

    def _advance_rows(self, through, start: int, stop: int, out: EstimateTrace) -> None:
        """Rows ``start:stop`` of a record through the bank, into ``out``'s rows: ``through(filter, rows)``
        runs one filter on a slice of the record and returns its trace. Before the choice every start runs
        up to the sample that completes the window."""
        if start < stop and self.chosen is None:
            first = self.step_count
            window = stop - start if self._select_step is None else max(1, self._select_step - first)
            rows = slice(start, min(stop, start + window))
            running = self._running()
            traces = {k: through(self.filters[k], rows) for k in running}
            done = traces[running[0]].nis.shape[0]
            skipped = min(done, max(0, self.settling_steps + 1 - first))
            # in the order of the samples, as step() adds: the sums decide the leader, stops and choice
            counted = [traces[k].nis[skipped:] for k in running]
            sums = np.cumsum(np.column_stack([self.nis[running], counted]), axis=1)
            leaders = np.empty(done, dtype=int)
            leaders[:skipped] = self.leader
            nis = self.nis
            for row in range(skipped, done):
                nis[running] = np.where(np.isfinite(nis[running]), sums[:, row - skipped + 1], np.inf)
                _prune(nis)
                self.leader = leaders[row] = _lead(self.leader, nis)
            self._choose_when_due()
            if self.chosen is not None:  # the sample that completes the window reports the chosen start
                leaders[-1] = self.chosen
            edges = np.flatnonzero(np.diff(leaders)) + 1
            for first_row, last_row in zip(np.r_[0, edges], np.r_[edges, done], strict=True):
                out.put_rows(start + first_row, traces[leaders[first_row]], last_row - first_row, first_row)
            start += done
        if start < stop:
            out.put_rows(start, through(self.active, slice(start, stop)), stop - start)

    def _choose_when_due(self) -> None:
        if self._select_step is not None and self.step_count >= self._select_step:
            self.chosen = int(np.argmin(self.nis))

    def grid_batch_arguments(self) -> None:
        """None: a bank is several filters, never one compiled call (as
        :meth:`oilwatch.estimator.ekf.OilFlowEKF.grid_batch_arguments`)."""
        return None

    def current_report(self) -> StepReport:
        """The followed filter's last report, rebuilt from its state."""
        return self.active.current_report()

    def get_state(self) -> dict[str, np.ndarray]:
        """The bank's state: the choice, the leader, the NIS sums and the state of every running start until
        the choice (of the chosen one after it), keys prefixed ``start{k}_`` (copies; restoring continues
        bit-identically)."""
        chosen = -1.0 if self.chosen is None else float(self.chosen)
        state = {"bank": np.r_[chosen, float(self.leader), self.nis]}
        members = self._running() if self.chosen is None else (self.chosen,)
        for k in members:
            state.update({f"start{k}_{key}": value for key, value in self.filters[k].get_state().items()})
        return state

    def with_model_centre_of(
        self, state: dict[str, np.ndarray], later: dict[str, np.ndarray]
    ) -> dict[str, np.ndarray]:
        """``state`` (:meth:`get_state`) with each start's model centre from ``later``, a later state of the
        bank (:meth:`oilwatch.estimator.ekf.OilFlowEKF.with_model_centre_of`)."""
        merged = dict(state)
        for k, ekf in enumerate(self.filters):
            prefix = f"start{k}_"
            own = sub_state(state, prefix)
            if not own:
                continue
            after = sub_state(later, prefix)
            merged.update({prefix + key: v for key, v in ekf.with_model_centre_of(own, after).items()})
        return merged

    def set_state(self, state: dict[str, np.ndarray]) -> None:
        """Restore a state from :meth:`get_state` exactly (same model and configuration)."""
        bank = np.asarray(state.get("bank", ()), dtype=float)
        if bank.shape != (2 + len(self.filters),):
            raise InputError(f"start bank state 'bank' must have shape ({2 + len(self.filters)},)")
        chosen = None if bank[0] < 0 else int(bank[0])
        members = np.flatnonzero(np.isfinite(bank[2:])) if chosen is None else (chosen,)
        for k in members:
            prefix = f"start{k}_"
            self.filters[k].set_state(sub_state(state, prefix))
        self.chosen, self.leader, self.nis[:] = chosen, int(bank[1]), bank[2:]


def _prune(nis: np.ndarray) -> None:
    """Stop (sum inf) every start whose sum exceeds the least by more than :data:`PRUNE_MARGIN`."""
    nis[nis - nis.min() > PRUNE_MARGIN] = np.inf


def _lead(leader: int, nis: np.ndarray) -> int:
    """The leading start after sums ``nis``: another start leads once its sum is :data:`LEAD_MARGIN` below the
    leader's."""
    best = int(np.argmin(nis))
    return best if nis[leader] - nis[best] > LEAD_MARGIN else leader


def _rows(values, rows: slice):
    return None if values is None else values[rows]


def _checked(displacements_m) -> np.ndarray:
    record = np.asarray(displacements_m, dtype=np.float64)
    if record.ndim != 2 or record.shape[1] != 4:
        raise InputError(f"displacements_m must have shape (K, 4), got {record.shape}")
    return record
