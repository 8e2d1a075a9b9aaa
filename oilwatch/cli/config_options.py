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
