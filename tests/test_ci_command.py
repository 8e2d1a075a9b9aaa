"""CI runs the README's test command (README, Set-up), on two workers split by fixtures/xdist_units.py."""

from __future__ import annotations

import re

import pytest
from fixtures.fmu_subprocess import REPO_ROOT
from fixtures.xdist_units import group_and_order


def test_ci_runs_the_readmes_test_command():
    readme = (REPO_ROOT / "README.md").read_text(encoding="utf-8")
    documented = re.findall(r"\.venv/bin/(python -m pytest[^`\n]*)", readme)
    ci = [line for line in (REPO_ROOT / ".ci" / "run").read_text().splitlines() if "pytest" in line]
    assert documented and ci == [documented[0]], (documented, ci)
    assert "-n 2 --dist loadgroup" in ci[0]


class _Item:
    def __init__(self, nodeid, *marks):
        self.nodeid, self.marks = nodeid, list(marks)

    def iter_markers(self, name):
        return (mark for mark in self.marks if mark.name == name)

    def get_closest_marker(self, name):
        return next(self.iter_markers(name), None)

    def add_marker(self, mark):
        self.marks.append(mark.mark)


def test_units_are_whole_modules_or_groups_sent_longest_first():
    group = pytest.mark.xdist_group(name="shared").mark
    slow = pytest.mark.slow.mark
    items = [
        _Item("tests/test_a.py::fast_1"),
        _Item("tests/test_a.py::fast_2"),
        _Item("tests/test_b.py::slow_1", slow),
        _Item("tests/test_c.py::grouped", group),
        _Item("tests/test_second_machine.py::known_long"),
        _Item("tests/test_d.py::grouped_too", group, slow),
    ]
    group_and_order(items)
    assert [item.nodeid.split("::")[1] for item in items] == [
        "known_long", "grouped", "grouped_too", "slow_1", "fast_1", "fast_2"
    ]  # fmt: skip
    names = [item.get_closest_marker("xdist_group").kwargs["name"] for item in items]
    assert names == [
        "tests/test_second_machine.py", "shared", "shared", "tests/test_b.py", "tests/test_a.py",
        "tests/test_a.py",
    ]  # fmt: skip
