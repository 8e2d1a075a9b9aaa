"""The table commands' shared options: ``--coefficients`` offers the kinds of
``models/bearing/coefficient_kinds.py`` in both ``bearing-table`` and ``bearing-map`` (one helper beside
``add_machine_option``), and the fraction ranges of ``bearing-map`` are refused in one line naming the
flag."""

from __future__ import annotations

import pytest

from oilwatch.cli import main
from oilwatch.models.bearing.coefficient_kinds import COEFFICIENT_KINDS


@pytest.mark.parametrize("command", ["bearing-table", "bearing-map"])
def test_coefficients_offers_the_kinds_of_the_models(command, capsys):
    with pytest.raises(SystemExit) as stop:
        main([command, "--coefficients", "dynamic"])
    assert stop.value.code == 2
    error = capsys.readouterr().err
    assert "--coefficients" in error
    for kind in COEFFICIENT_KINDS:
        assert repr(kind) in error


@pytest.mark.parametrize(
    ("option", "values"),
    [("--speed-range", ["1.2", "1.4"]), ("--viscosity-range", ["0", "2"]), ("--speed-range", ["0.5", "0.9"])],
)
def test_a_range_without_the_nominal_is_one_line_naming_the_flag(option, values, capsys):
    code = main(["bearing-map", option, *values])
    error = capsys.readouterr().err.strip()
    assert code == 2 and len(error.splitlines()) == 1
    assert f"{option} must satisfy 0 < LOW <= 1 <= HIGH" in error
