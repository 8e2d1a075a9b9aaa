"""Whether a run's estimate can be trusted: the share of the record at which the estimate sat at a limit of
the coefficient table (the filter clamps the flowrates there: the data asked for a flowrate the model
cannot represent) or the model was inconsistent with the data (``model_consistent`` false). Above
:data:`NOTICEABLE_SHARE` of the record, summary.json's ``trust`` says so, the verdict and the report say
so, and ``oilwatch estimate`` exits with :data:`UNTRUSTED_EXIT_CODE`.
"""

from __future__ import annotations

import numpy as np

NOTICEABLE_SHARE = 0.10
"""A share of the record above which an estimate at a table limit or inconsistent is called out."""
LIMIT_TOLERANCE = 0.002
"""An estimate within this fraction of its bearing's table span from a bound sits at that bound."""
UNTRUSTED_EXIT_CODE = 3
"""``oilwatch estimate``'s exit status when the run completed but its estimate is not trustworthy (the
summary's ``trust.trusted`` false). docs/operations.md."""
FLOWRATES = slice(1, 3)  # estimates.csv's q1_est_ml_min, q2_est_ml_min (oilwatch.monitoring.columns)


def noticeable(share: float) -> bool:
    """Whether a share of the record (at a table limit, inconsistent) is above :data:`NOTICEABLE_SHARE`: the
    rule by which ``oilwatch estimate`` and ``oilwatch baseline`` call a result not trustworthy."""
    return share > NOTICEABLE_SHARE


class TrustShares:
    """Counts, over the samples estimated, those at a limit of their bearing's table (per bearing; the
    tables' ranges ``bounds_ml_min`` (2, 2), row b bearing b + 1's (low, high) [ml/min]) and those
    inconsistent."""

    def __init__(self, bounds_ml_min: np.ndarray) -> None:
        low, high = np.asarray(bounds_ml_min, dtype=float).T
        margin = LIMIT_TOLERANCE * (high - low)
        self.low, self.high = low + margin, high - margin
        self.samples = 0
        self.at_limit = np.zeros(2, dtype=np.int64)
        self.inconsistent = 0
        self._consistent_column: int | None = None

    def columns(self, columns: list[str]) -> None:
        """Where ``model_consistent`` is in the rows (absent: the estimator has no such output)."""
        self._consistent_column = columns.index("model_consistent") if "model_consistent" in columns else None

    def add(self, rows: np.ndarray) -> None:
        """Count a block of estimates.csv rows (every sample, before ``output_every``)."""
        q = rows[:, FLOWRATES]
        self.samples += rows.shape[0]
        self.at_limit += np.count_nonzero((q <= self.low) | (q >= self.high), axis=0)
        if self._consistent_column is not None:
            self.inconsistent += int(np.count_nonzero(rows[:, self._consistent_column] < 0.5))

    def summary(self) -> dict:
        """summary.json's ``trust``: the shares, the threshold, and whether the estimate is trusted."""
        total = max(1, self.samples)
        at_limit = {f"bearing{b + 1}": round(int(self.at_limit[b]) / total, 6) for b in range(2)}
        inconsistent = round(self.inconsistent / total, 6)
        reasons = [
            f"bearing {b[-1]}'s estimate at the coefficient table's limit for {100 * share:.1f} % of the "
            "record"
            for b, share in at_limit.items()
            if noticeable(share)
        ]
        if noticeable(inconsistent):
            reasons.append(f"model inconsistent with the data for {100 * inconsistent:.1f} % of the record")
        return {
            "trusted": not reasons,
            "reasons": reasons,
            "at_limit_fraction": at_limit,
            "inconsistent_fraction": inconsistent,
            "noticeable_share": NOTICEABLE_SHARE,
            "table_limits_ml_min": {
                f"bearing{b + 1}": [float(self.low[b]), float(self.high[b])] for b in range(2)
            },
        }


def apply_to_verdict(summary: dict) -> None:
    """Append the trust's reasons to each bearing's verdict (the console line and the report show it)."""
    trust = summary.get("trust")
    if not trust or trust["trusted"]:
        return
    for key in summary["verdict"]:  # bearingN: its own limit, and the model's consistency
        other = [f"bearing {b}'" for b in (1, 2) if f"bearing{b}" != key]
        reasons = [reason for reason in trust["reasons"] if not reason.startswith(tuple(other))]
        summary["verdict"][key] += " (NOT TRUSTWORTHY: " + "; ".join(reasons) + ")"
