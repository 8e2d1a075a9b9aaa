"""A commissioning baseline carries the viscosity factors and the unbalance, not only the probe offsets.

A viscosity factor and a flowrate both move the journal's static position, so with the factor free an
estimator cannot tell a 10 % thinner film from more oil (the robustness report measured +22..+71 % before
the baseline carried the factor). At known flow the baseline separates them. The plant (full-order Newmark
model, film viscosity x0.9, probe offsets, unbalance x1.5) is not the estimator's discrete map.
"""

import json

import numpy as np
import pytest

from oilwatch.cli import main
from oilwatch.estimator.baseline import baseline_prior
from oilwatch.estimator.ekf import OilFlowEKF
from oilwatch.estimator.ekf_config import EKFConfig
from oilwatch.estimator.offset_baseline import OffsetBaseline
from oilwatch.models.machine import load_machine
from oilwatch.models.rotor.assembly import Rotor
from oilwatch.models.system.factory import load_system
from oilwatch.models.system.measurement import MeasurementChain, ProbeErrors
from oilwatch.models.system.operating_model import build_operating_model
from oilwatch.models.system.operating_point import operating_system
from oilwatch.models.system.plant import RotorBearingPlant

MACHINE = load_machine()
QN = MACHINE.shared_nominal_flowrate_m3_s("this test")
T0 = MACHINE.nominal_oil_temperature_c
DT = 1e-3
FACTOR = 0.9
OFFSETS_M = (-12e-6, 20e-6, 7e-6, -18e-6)


def _record(flowrates, seed: int, samples: int) -> np.ndarray:
    rotor = Rotor.from_machine(MACHINE)
    system = operating_system(
        MACHINE,
        MACHINE.nominal_speed_hz,
        MACHINE.oil.dynamic_viscosity_pa_s(T0),
        unbalance_moment_kg_m=1.5 * rotor.unbalance_moment_kg_m,
        unbalance_phase_rad=rotor.unbalance_phase_rad,
    )
    chain = MeasurementChain(tuple(ProbeErrors(zero_offset_m=v) for v in OFFSETS_M), 0.0, 1e-6)
    plant = RotorBearingPlant(
        system, DT, None, 1e-6, seed, initial_flowrates_m3_s=flowrates, chain=chain, oil=MACHINE.oil,
        oil_temperature_c=T0, viscosity_factor=FACTOR,
    )  # fmt: skip
    return np.array([plant.step(flowrates).measured_position_m for _ in range(samples)])


@pytest.fixture(scope="module")
def model():
    return build_operating_model(load_system(reduced=True), MACHINE)


@pytest.fixture(scope="module")
def config():
    return EKFConfig.recommended(
        first_sample_time_s=DT,
        offset_prior_std_m=25e-6,
        unbalance_prior_std=2.0,
        viscosity_factor_prior_std=0.1,
    )


@pytest.fixture(scope="module")
def document(tmp_path_factory):
    """``oilwatch baseline`` on a 6 s record at nominal flow, the factors and the unbalance freed."""
    data = _record((QN, QN), 3, 6000)
    folder = tmp_path_factory.mktemp("baseline")
    times = DT * np.arange(1, len(data) + 1)
    table = np.column_stack(
        [times, data * 1e6, np.full(len(data), MACHINE.nominal_speed_hz), np.full(len(data), T0)]
    )
    header = "time_s,x1_um,y1_um,x2_um,y2_um,speed_hz,oil_temperature_c"
    np.savetxt(folder / "record.csv", table, delimiter=",", header=header, comments="", fmt="%.12g")
    out = folder / "baseline.json"
    arguments = ["baseline", "--record", str(folder / "record.csv"), "--out", str(out),
                 "--offset-prior-um", "25", "--unbalance-prior", "2", "--viscosity-prior", "0.1"]  # fmt: skip
    assert main(arguments) == 0
    return json.loads(out.read_text())


def test_the_baseline_estimates_the_viscosity_factors_and_the_unbalance(document):
    assert len(document["nuisance_covariance"]) == 8  # offsets, factors, unbalance
    factor, factor_std = np.array(document["viscosity_factor"]), np.array(document["viscosity_factor_std"])
    assert (np.abs(factor - FACTOR) < 3.0 * factor_std + 0.005).all() and (factor_std < 0.01).all(), document
    unbalance, unbalance_std = np.array(document["unbalance"]), np.array(document["unbalance_std"])
    assert abs(unbalance[0] - 1.5) < 3.0 * unbalance_std[0] + 0.05 and abs(unbalance[1]) < 0.1, document
    assert np.allclose(document["offsets_um"], np.array(OFFSETS_M) * 1e6, atol=1.0), document


def test_primed_with_it_the_estimator_reads_the_flowrate_not_the_film(model, config, document):
    truth = np.array([0.8, 1.0]) * QN
    record = _record(tuple(truth), 5, 6000)
    primed = OilFlowEKF(
        model, EKFConfig.recommended(**_fields(config), offset_baseline=baseline_prior(document))
    )
    trace = primed.run(record)
    error = trace.q_m3_s[-2000:].mean(axis=0) / truth - 1.0
    std = trace.q_std_m3_s[-1] / truth
    assert (np.abs(error) < 0.02).all() and (np.abs(error) < 2.0 * std + 0.002).all(), (error, std)
    assert trace.starved[-1, 0] and not trace.starved[1000:, 1].any()


def _fields(config: EKFConfig) -> dict:
    names = ("first_sample_time_s", "offset_prior_std_m", "unbalance_prior_std", "viscosity_factor_prior_std")
    return {name: getattr(config, name) for name in names}


def test_the_offset_prior_widens_with_the_time_since_commissioning():
    baseline = OffsetBaseline((0.0,) * 4, (0.3e-6,) * 4, age_s=10 * 86400.0, drift_m_per_day=0.4e-6)
    assert np.allclose(baseline.offset_prior_std_m(), np.hypot(0.3e-6, 4e-6))
    fresh = OffsetBaseline((0.0,) * 4, (0.3e-6,) * 4)
    assert np.allclose(fresh.offset_prior_std_m(), 0.3e-6)
    with pytest.raises(Exception, match="viscosity_factor and viscosity_factor_std"):
        OffsetBaseline((0.0,) * 4, (0.3e-6,) * 4, viscosity_factor=(1.0, 1.0))
