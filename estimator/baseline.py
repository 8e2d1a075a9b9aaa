"""A commissioning baseline: the probe zero offsets estimated from a record at known, healthy flowrates.

With the flowrates known, the static position the model predicts is known, so the probes' zero offsets are
what separates it from the measured mean position: the EKF itself estimates them, run on the baseline record
with the flowrates held at the known values (prior std 1e-6 of nominal, no flowrate process noise, no change
detection) and the offsets as random-walk states from the configured prior. The final offset estimates and
their stds become the prior of later runs (:class:`estimator.config.OffsetBaseline`); drift after
commissioning is then tracked by the offsets' random walk.

File format (JSON, units in the keys): ``format``, ``format_version``, ``flowrates_ml_min`` (2,),
``offsets_um`` (4,), ``offset_std_um`` (4,), ``offset_covariance_um2`` (4, 4), ``samples``, ``record``;
and/or ``runout``: the probes' slow-roll vectors with their stds (:meth:`SlowRollVectors.to_document`, from a
slow-roll record, :func:`estimator.runout.fit_slow_roll`), which the estimator subtracts
(``EKFConfig.runout``, :func:`load_runout`).
"""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import numpy as np

from models.validation import InputError

from .config import ML_MIN, EKFConfig, OffsetBaseline
from .ekf import OilFlowEKF
from .model import AugmentedModel
from .runout import SlowRollVectors

FORMAT = "oilwatch commissioning baseline"
FORMAT_VERSION = 1
KNOWN_FLOWRATE_STD_FRACTION = 1e-6


def estimate_baseline(
    model: AugmentedModel, displacements_m: np.ndarray, flowrates_m3_s, config: EKFConfig
) -> dict:
    """Estimate the offsets from a record (K, 4) [m] taken at the known ``flowrates_m3_s`` (q1, q2).

    ``config`` gives the noise, tuning, probe angle and the offsets' prior (``offset_prior_std_m``, > 0).
    Returns the baseline document (module docstring) without ``record``.
    """
    if config.offset_prior_std_m <= 0.0:
        raise InputError("a baseline needs offset_prior_std_m > 0 (the offsets' prior std)")
    q = tuple(float(v) for v in flowrates_m3_s)
    config = config.for_model(model)
    known = dataclasses.replace(
        config,
        q_initial_m3_s=q,
        initial_flowrate_std_m3_s=KNOWN_FLOWRATE_STD_FRACTION * config.q_nominal_m3_s,
        flowrate_process_std_m3_s=0.0,
        change_flowrate_std_fraction=0.0,
        offset_baseline=None,
    )
    ekf = OilFlowEKF(model, known)
    trace = ekf.run(displacements_m)
    if not trace.measurement_ok.any():
        raise InputError("the baseline record has no usable sample")
    n = model.n_states
    covariance = ekf.covariance[n + 2 :, n + 2 :]
    return {
        "format": FORMAT,
        "format_version": FORMAT_VERSION,
        "flowrates_ml_min": [v / ML_MIN for v in q],
        "offsets_um": (ekf.offset_m * 1e6).tolist(),
        "offset_std_um": (ekf.offset_std_m * 1e6).tolist(),
        "offset_covariance_um2": (covariance * 1e12).tolist(),
        "samples": len(displacements_m),
        "probes_flagged": [int(c) for c in np.flatnonzero(trace.probe_faulty.any(axis=0))],
    }


def save_baseline(document: dict, path: str | Path) -> None:
    """Write a baseline document as JSON."""
    Path(path).write_text(json.dumps(document, indent=1) + "\n")


def _read_document(path: str | Path) -> dict:
    try:
        data = json.loads(Path(path).read_text())
    except FileNotFoundError:
        raise InputError(f"baseline file not found: {path}") from None
    except json.JSONDecodeError as error:
        raise InputError(f"baseline file {path} is not valid JSON: {error}") from None
    if not isinstance(data, dict) or data.get("format") != FORMAT:
        raise InputError(f"{path} is not an {FORMAT} file")
    return data


def load_baseline(path: str | Path) -> OffsetBaseline:
    """Read a baseline file into the estimator's prior (one-line InputError on a bad file)."""
    data = _read_document(path)
    if "offsets_um" not in data:
        raise InputError(f"baseline file {path} holds no offsets (made from a slow-roll record only)")
    try:
        offsets = tuple(float(v) * 1e-6 for v in data["offsets_um"])
        std = tuple(float(v) * 1e-6 for v in data["offset_std_um"])
    except (KeyError, TypeError, ValueError) as error:
        raise InputError(f"baseline file {path}: bad or missing offsets ({error})") from None
    return OffsetBaseline(offsets, std)


def load_runout(path: str | Path) -> SlowRollVectors | None:
    """The slow-roll vectors of a baseline file (None when it has none; one-line InputError on a bad file)."""
    data = _read_document(path)
    if "runout" not in data:
        return None
    if not isinstance(data["runout"], dict):
        raise InputError(f"baseline file {path}: runout must be a table")
    return SlowRollVectors.from_document(data["runout"], f"baseline file {path}")
