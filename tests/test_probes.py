"""The machine file's [probes] section (models.probes)."""

from __future__ import annotations

import dataclasses

import pytest

from oilwatch.models.machine import load_machine
from oilwatch.models.probes import read_probes
from oilwatch.models.validation import InputError


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


def test_runout_vectors_and_the_drift_rate_come_from_the_probes_section():
    """The machine file's runout keys give the vectors the estimator subtracts, in the plant's convention
    (``a cos(theta + phi)``, oilwatch.models.system.measurement); the reader of records accepts the keys."""
    import math

    import numpy as np

    from oilwatch.estimator.runout import runout_of_probes
    from oilwatch.models.system.measurement import MeasurementChain, ProbeErrors
    from oilwatch.records.probes import probe_setup

    section = {
        "offset_drift_um_per_day": 0.2,
        "x1": {"runout_1x_um": 2.0, "runout_1x_phase_deg": 30.0, "runout_1x_std_um": 0.05},
        "y2": {"runout_2x_um": 1.0, "runout_2x_phase_deg": -100.0, "runout_2x_std_um": 0.02},
    }
    machine = load_machine()
    probes = read_probes(dataclasses.replace(machine, raw={**machine.raw, "probes": section}))
    assert probes.offset_drift_m_per_day == pytest.approx(0.2e-6)
    vectors = runout_of_probes(probes)
    errors = [ProbeErrors() for _ in range(4)]
    errors[0] = ProbeErrors(runout_1x_m=2e-6, runout_1x_phase_rad=math.radians(30.0))
    errors[3] = ProbeErrors(runout_2x_m=1e-6, runout_2x_phase_rad=math.radians(-100.0))
    chain = MeasurementChain(tuple(errors), 0.0, 1e-6)
    for theta in (0.0, 1.0, 4.0):
        assert np.allclose(vectors.runout_m(theta), chain.probe_readings(np.zeros(4), theta), atol=1e-15)
    assert np.allclose(vectors.residual_variance_m2(), [0.05e-6**2, 0.0, 0.0, 0.02e-6**2])
    assert runout_of_probes(read_probes(machine)) is None
    probe_setup(section)  # the records reader accepts the estimator's keys
    with pytest.raises(InputError, match=r"probes\.x1\.runout_1x_um must lie in"):
        read_probes(dataclasses.replace(machine, raw={**machine.raw, "probes": {"x1": {"runout_1x_um": -1}}}))
