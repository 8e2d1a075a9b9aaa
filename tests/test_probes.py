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
        ({"angle_deg": "north"}, "probes.angle_deg must be a number"),
    ],
)
def test_bad_probe_entries_are_named(section, message):
    machine = load_machine()
    with pytest.raises(InputError, match=message):
        read_probes(dataclasses.replace(machine, raw={**machine.raw, "probes": section}))
