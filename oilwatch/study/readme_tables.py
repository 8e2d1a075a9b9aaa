"""The README's study tables, generated from the studies' ``summary.json`` (never retyped).

    python -m oilwatch.study.readme_tables --readme README.md known=DIR unknown=DIR

writes, between ``<!-- generated study-nuisances: ... -->`` and ``<!-- /generated study-nuisances -->``, one
row per study and noise level: the study's label, its case model, the Table 6 figures (mean, std and max of
the relative error over both bearings and all cases) beside the paper's, the share of cases complete, the
mean signed error per bearing, the filter's own std (% of the truth) and how often the truth lies within
+-2 of it, the
RMS error over the known-nuisance Cramer-Rao bound, and the cases' summed time over every run of the study
(its wall time with one worker).
"""

from __future__ import annotations

import argparse
import json
import shlex
import sys
from pathlib import Path

from oilwatch.models.validation import InputError

from ..cli.readme_block import replace_block


def table_lines(studies: list[tuple[str, dict]]) -> list[str]:
    """Markdown rows of (label, summary) pairs."""
    lines = [
        "| nuisances | case model | noise [um] | cases | mean error % (paper) | std % (paper) "
        "| max % (paper) | bias % b1 / b2 | filter std % | truth within 2 std | RMS error / bound (nuisances "
        "known) | case time (sum) |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for label, summary in studies:
        timing = summary.get("timing", {})
        wall = timing.get("case_wall_s_total", timing.get("wall_s"))  # summed over a resumed study's runs
        for level in summary["noise_levels"]:
            paper = level.get("paper") or {}
            if not level["n_cases"]:
                lines.append(
                    f"| {label} | {summary['settings']['case_model']} | {level['noise_um']:g} | "
                    f"0/{level['n_expected']} | not run | | | | | | | |"
                )
                continue
            cells = [
                label,
                summary["settings"]["case_model"],
                f"{level['noise_um']:g}",
                f"{level['n_cases']}/{level['n_expected']}",
                f"{level['mean_err_pct']:.2f} ({paper.get('mean_err_pct', float('nan')):.2f})",
                f"{level['std_err_pct']:.2f} ({paper.get('std_err_pct', float('nan')):.2f})",
                f"{level['max_err_pct']:.2f} ({paper.get('max_err_pct', float('nan')):.2f})",
                " / ".join(_optional(level, f"bias_pct_b{b}", "{:+.2f}") for b in (1, 2)),
                _optional(level, "mean_std_pct", "{:.2f}"),
                _optional(level, "within_2std_fraction", "{:.0%}"),
                f"{level['mean_crlb_ratio']:.2f}",
                "-" if wall is None else f"{wall / 60.0:.0f} min",
            ]
            lines.append("| " + " | ".join(cells) + " |")
    return lines


def _optional(level: dict, key: str, form: str) -> str:
    """A figure a summary written before it existed may lack ("-")."""
    value = level.get(key)
    return "-" if value is None else form.format(value)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--readme", default=None, metavar="FILE", help="README to update (default: print)")
    parser.add_argument("studies", nargs="+", metavar="LABEL=DIR", help="a label and a study's --out folder")
    args = parser.parse_args(argv)
    studies = []
    for item in args.studies:
        label, _, folder = item.partition("=")
        path = Path(folder) / "summary.json"
        try:
            studies.append((label, json.loads(path.read_text())))
        except (OSError, ValueError) as error:
            raise InputError(f"{item}: cannot read {path}: {error}") from None
    table = "\n".join(table_lines(studies))
    print(table)
    if args.readme is not None:
        command = shlex.join(["python", "-m", "oilwatch.study.readme_tables", *(argv or sys.argv[1:])])
        replace_block(args.readme, "study-nuisances", table, command)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
