"""CLI options generated from a settings dataclass of :mod:`oilwatch.experiment_config`: one option per field,
its flag, type, default and help (description, unit, default, allowed values) read from the field."""

from __future__ import annotations

import argparse
from dataclasses import fields

from oilwatch.experiment_config import allowed_text, flag


def option_help(spec) -> str:
    """``measurement noise std of each probe [um] (default: 1; 0.001 to 50 um)`` (argparse-escaped)."""
    meta, default = spec.metadata, spec.default
    unit = "" if meta["unit"] in ("1", "%") else f" [{meta['unit']}]"
    shown = " ".join(f"{v:g}" for v in default) if isinstance(default, tuple) else f"{default:g}"
    allowed = allowed_text(spec)
    text = f"{meta['description']}{unit} (default: {shown}" + (f"; {allowed})" if allowed else ")")
    return text.replace("%", "%%")


def add_config_options(parser: argparse.ArgumentParser, config_class, names: tuple[str, ...] | None = None):
    """Add ``--field-name`` for each field of ``config_class`` (only ``names``, in that order, if given)."""
    specs = {spec.name: spec for spec in fields(config_class)}
    for name in names or tuple(specs):
        spec = specs[name]
        default = spec.default
        scalar = default[0] if isinstance(default, tuple) else default
        extra = {key: spec.metadata[key] for key in ("nargs", "metavar") if key in spec.metadata}
        parser.add_argument(
            flag(name), dest=name, type=type(scalar), default=default, help=option_help(spec), **extra
        )


PRESET_PRIOR_OPTIONS = (
    ("--unbalance-prior", "unbalance_prior", "unbalance_prior_std", "prior std of the complex unbalance "
     "relative to the machine file's, e.g. 2; 0: not estimated"),
    ("--viscosity-prior", "viscosity_prior", "viscosity_factor_prior_std", "prior std of each bearing's "
     "viscosity factor (film over the oil law at the measured temperature), e.g. 0.1; needs the model that "
     "follows the operating point and a record of tens of seconds; 0: known"),
)  # fmt: skip
"""The nuisance priors a preset sets: flag, dest, EKFConfig field, help (defaults: from the presets)."""


def add_preset_options(parser: argparse.ArgumentParser) -> None:
    """``--preset`` (:data:`oilwatch.estimator.ekf_config.PRESETS`) and the nuisance priors it sets, whose
    help gives each preset's value (generated from the presets, never retyped)."""
    from oilwatch.estimator.ekf_config import DEFAULT_PRESET, PRESETS, EKFConfig

    parser.add_argument(
        "--preset",
        choices=[p.name for p in PRESETS],
        default=DEFAULT_PRESET,
        help="the estimator's configuration: "
        + "; ".join(f"{p.name}: {p.description}" for p in PRESETS)
        + f" (default: {DEFAULT_PRESET})",
    )
    for name, dest, field, text in PRESET_PRIOR_OPTIONS:
        values = ", ".join(
            f"{p.name} {p.value(field, getattr(EKFConfig.recommended(), field)):g}" for p in PRESETS
        )
        parser.add_argument(
            name,
            dest=dest,
            type=float,
            default=None,
            metavar="STD",
            help=f"{text} (default: the preset's: {values})",
        )


def check_preset_options(args: argparse.Namespace) -> None:
    """One-line InputError for a nuisance prior outside its range."""
    from oilwatch.models.validation import require_in_range

    require_in_range(
        "--unbalance-prior", 0.0 if args.unbalance_prior is None else args.unbalance_prior, 0.0, 100.0
    )
    require_in_range(
        "--viscosity-prior", 0.0 if args.viscosity_prior is None else args.viscosity_prior, 0.0, 0.5
    )


def preset_prior(args: argparse.Namespace, dest: str) -> float:
    """The value of a nuisance-prior option: the user's, else the ``--preset``'s."""
    from oilwatch.estimator.ekf_config import EKFConfig, preset_named

    given = getattr(args, dest)
    if given is not None:
        return given
    field = next(row[2] for row in PRESET_PRIOR_OPTIONS if row[1] == dest)
    return preset_named(args.preset).value(field, getattr(EKFConfig.recommended(), field))
