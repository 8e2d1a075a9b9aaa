"""The estimator FMU's start outputs: whether its estimate is past its start, so that a host can tell an
unsettled estimate from a settled one.

Beside the filter's own convergence (``converged``: both flowrate stds below 3 % of nominal and drift below
1 % over 1 s), two starts of the estimator make an estimate not yet the one to act on. Both run only where
the flowrates are estimated beside viscosity factors that no baseline primed (``bearing_table`` 1,
``viscosity_factor_prior_std`` > 0, no ``baseline_file`` with factors), the nearly unobservable direction
of :mod:`oilwatch.estimator.nuisance_start`:

* the settling start (:mod:`oilwatch.estimator.nuisance_start`): for ``settling_steps`` samples the flowrates
and
  nuisances stay out of the Jacobian while the dynamic states settle; then they restart from their prior;
* the start bank (:mod:`oilwatch.estimator.start_bank`): five filters from fractions 1.1 to 0.7 of the initial
  flowrate run through the first ``SELECT_S`` (20 s); the one with the least accumulated NIS continues
  alone. Until the choice the estimates are the leading start's (the nominal one's until the record
  prefers another: :mod:`oilwatch.estimator.start_bank`).

The outputs (:data:`START_OUTPUTS`) say where the estimator is: ``start_choosing``, ``start_fraction``,
``start_choice_in_s``, ``settling_start_left_s`` and ``estimate_settled``, which is ``converged`` once both
starts are over and false before. With one filter and no settling start (every other configuration) they
are constant but for ``estimate_settled``, which is then ``converged``: the compiled plain step
(:mod:`oilwatch.fmu_src.ekf_plain_step`) writes it from the report's converged column, so the start outputs
cost it nothing. Whether the machine still matches the model is ``model_consistent``'s, not these outputs'.

The values live in the fast path's output array (:data:`oilwatch.fmu_src.ekf_variables.STEP_OUTPUTS`), so the
loader serves them in C, fmi2GetFMUstate saves them and fmi2SetFMUstate restores them with the other outputs.
"""

from __future__ import annotations

from typing import NamedTuple


class StartOutput(NamedTuple):
    """One start output: name, FMI type ("Real" or "Boolean"), unit (Real), start value, description."""

    name: str
    kind: str
    unit: str | None
    start: float
    description: str


START_OUTPUTS = (
    StartOutput(
        "start_choosing", "Boolean", None, False,
        "The start bank is still choosing the flowrates' start (nuisances that no baseline primed: "
        "starts at 1.1 to 0.7 times the initial flowrate, the least accumulated NIS continues "
        "alone); until then the estimates are the leading start's (start_fraction). False with one filter",
    ),
    StartOutput(
        "start_fraction", "Real", "1", 1.0,
        "The start the estimates come from, as a fraction of each bearing's initial flowrate "
        "(q1_initial_ml_min, q2_initial_ml_min): the start bank's choice, or while it is choosing the "
        "leading start (the nominal one, 1, until the record prefers another); 1 with one filter (its start "
        "is the configured one)",
    ),
    StartOutput(
        "start_choice_in_s", "Real", "s", 0.0,
        "Time left until the start bank's choice, counted in the filter's samples; 0 after it and with one "
        "filter",
    ),
    StartOutput(
        "settling_start_left_s", "Real", "s", 0.0,
        "Time left of the settling start (free viscosity factors without a baseline for them: the dynamic "
        "states settle, then the flowrates and nuisances restart from their prior), counted in the "
        "filter's samples; 0 after it and without one",
    ),
)  # fmt: skip
"""The start outputs written by the slave's Python step (module docstring), in the output array's order."""
SETTLED_OUTPUT = StartOutput(
    "estimate_settled", "Boolean", None, False,
    "The estimate is past its start and converged: the start bank has chosen, the settling start is over "
    "and converged is true; with one filter and no settling start, converged. Whether the machine still "
    "matches the model is model_consistent's",
)  # fmt: skip
"""Written with the report (the converged column), then cleared by the Python step during the starts."""


def declare_start_outputs(slave) -> None:
    """Declare :data:`START_OUTPUTS` and :data:`SETTLED_OUTPUT` on ``slave``."""
    for output in (SETTLED_OUTPUT, *START_OUTPUTS):
        if output.kind == "Boolean":
            slave.declare_boolean(
                output.name, "output", start=bool(output.start), description=output.description
            )
        else:
            slave.declare_real(
                output.name,
                "output",
                start=output.start,
                unit=output.unit,
                minimum=0.0,
                description=output.description,
            )


def start_values(estimator, period_s: float) -> tuple[float, float, float, float]:
    """The values of :data:`START_OUTPUTS` for ``estimator``
    (:func:`oilwatch.estimator.factory.make_estimator`'s: a filter or the start bank) now, with ``period_s``
    its sampling period [s]."""
    settling = estimator.settling_steps
    left = (
        max(0, settling + 1 - estimator.step_count) if settling > 0 else 0
    )  # restart after sample `settling`
    fraction = getattr(estimator, "active_fraction", 1.0)  # one filter: its start is the configured one
    if getattr(estimator, "chosen_fraction", 1.0) is None:  # the bank is choosing
        return 1.0, fraction, estimator.samples_to_choice * period_s, left * period_s
    return 0.0, fraction, 0.0, left * period_s
