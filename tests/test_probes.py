"""The machine file's [probes] section (models.probes)."""

from __future__ import annotations

import dataclasses

import pytest

from models.machine import load_machine
from models.probes import read_probes
from models.validation import InputError


def test_the_turbine_declares_its_probes_and_a_file_without_the_section_gets_the_defaults():
    machine = load_machine()
    probes = read_probes(machine)
    assert probes.angle_deg == 0.0 and probes.offset_prior_std_m == pytest.approx(25e-6)
    bare = dataclasses.replace(machine, raw={k: v for k, v in machine.raw.items() if k != "probes"})
    assert read_probes(bare) == probes


@pytest.mark.parametrize(
    ("section", "message"),
    [
        ({"offset_prior_std_um": -1.0}, "probes.offset_prior_std_um"),
        ({"angle_deg": 45.0}, "probes.angle_deg is no longer read: give the mounting as probes.layout"),
        ({"layout": "diagonal"}, "probes.layout must be one of xy, api670"),
        ({"x1": {"angle_deg": "north"}}, "probes.x1.angle_deg must be a number"),
        ({"x2": {"angle_deg": 30.0}}, "same angle on both bearings"),
    ],
)
def test_bad_probe_entries_are_named(section, message):
    machine = load_machine()
    with pytest.raises(InputError, match=message):
        read_probes(dataclasses.replace(machine, raw={**machine.raw, "probes": section}))


@pytest.mark.parametrize(
    ("section", "angle"),
    [
        ({"layout": "api670"}, 45.0),
        ({"layout": "xy"}, 0.0),
        ({k: {"angle_deg": a} for k, a in (("x1", 30.0), ("y1", 120.0), ("x2", 30.0), ("y2", 120.0))}, 30.0),
    ],
)
def test_one_key_gives_the_probe_angle_to_the_estimator_and_the_records_reader(section, angle):
    from oilwatch.records.probes import probe_setup

    machine = load_machine()
    probes = read_probes(dataclasses.replace(machine, raw={**machine.raw, "probes": section}))
    assert probes.angle_deg == pytest.approx(angle)
    setup = probe_setup(section)
    assert [p.angle_deg for p in setup.probes] == pytest.approx([angle, angle + 90.0] * 2)
