"""How old a commissioning baseline is when a record is estimated: the record's start minus the baseline's.

A baseline file (``oilwatch baseline``) records when its record started (``record_start_utc``, ISO 8601 in
UTC); ``oilwatch estimate --record-start`` says when the estimated record started. Their difference is the
baseline's age, over which the probes' zero offsets may have drifted by up to the machine file's ``[probes]
offset_drift_um_per_day`` (``oilwatch.estimator.offset_baseline.OffsetBaseline.age_s``): the offsets' prior
widens by it. Either time unknown: age 0, the prior the baseline gives (what ``estimate`` always did before).
"""

from __future__ import annotations

import json
from datetime import UTC, datetime
from pathlib import Path

from oilwatch.models.validation import InputError

BASELINE_START_KEY = "record_start_utc"


def parse_utc(text: str, name: str) -> datetime:
    """An ISO 8601 time (``2026-12-01T08:00:00Z``; no zone: UTC) as an aware UTC datetime, else a one-line
    InputError naming ``name``."""
    try:
        value = datetime.fromisoformat(text)
    except (TypeError, ValueError):
        example = "2026-12-01T08:00:00Z"
        raise InputError(f"{name} must be an ISO 8601 time such as {example}, got {text!r}") from None
    return value.replace(tzinfo=UTC) if value.tzinfo is None else value.astimezone(UTC)


def baseline_age_days(baseline_file: str | Path, record_start: str | None) -> float | None:
    """Days from the baseline file's record start to ``record_start`` (ISO 8601), or None when either is
    unknown. A record that starts before its baseline's is a one-line InputError."""
    if record_start is None:
        return None
    start = parse_utc(record_start, "--record-start")
    stored = json.loads(Path(baseline_file).read_text()).get(BASELINE_START_KEY)
    if stored is None:
        return None
    baseline_start = parse_utc(stored, f"baseline file {baseline_file}: {BASELINE_START_KEY}")
    days = (start - baseline_start).total_seconds() / 86400.0
    if days < 0.0:
        raise InputError(
            f"--record-start {record_start} is before the baseline's record ({stored}): a baseline must be "
            "older than the records it primes"
        )
    return days
