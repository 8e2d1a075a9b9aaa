"""The commissioning coast-down of a robustness case, and the clearances measured from it.

What ``oilwatch baseline --coast-down-record`` reads, made from the case's plant
(:func:`oilwatch.models.system.coast_down.coast_down_record`: its clearance, length and load split, solved
directly on the plant's mesh) and read by the commissioning record's probes (their offsets, scale factors,
runout and noise): a :data:`DURATION_S` coast-down from the nominal speed to :data:`SLOW_ROLL_FRACTION` of it.
The clearances are measured as the command measures them
(:func:`oilwatch.models.system.clearance.measure_clearances`: whole revolutions averaged, then speed bins,
the locus of the machine file's bearing) and go into the estimator's model.
"""

from __future__ import annotations

from oilwatch.models.bearing.centreline import ClearanceFit
from oilwatch.models.system.clearance import measure_clearances, record_revolutions
from oilwatch.models.system.coast_down import coast_down_record
from oilwatch.models.system.measurement import MeasurementChain
from oilwatch.models.system.structure import PlantStructure

DURATION_S = 60.0
"""The coast-down's length (a slow one: the film quasi-static at every speed)."""
SLOW_ROLL_FRACTION = 0.03
"""Where it ends, over the nominal speed (2.25 Hz for the turbine: eccentricity about 0.8)."""
DT_S = 1e-3


def measured_clearances(
    machine,
    structure: PlantStructure | None,
    chain: MeasurementChain,
    seed: int,
    probe_scale_factor_std: float,
) -> tuple[ClearanceFit, ...]:
    """Each bearing's clearance fit from the case plant's coast-down (module docstring)."""
    record = coast_down_record(
        machine,
        PlantStructure() if structure is None else structure,
        chain,
        DURATION_S,
        SLOW_ROLL_FRACTION,
        seed,
        DT_S,
    )
    positions = record["readings_m"] @ chain.projection  # the readings along the probes' axes back to (x, y)
    return measure_clearances(
        machine,
        record["speed_hz"],
        positions,
        chain.noise_std_m,
        record["oil_temperature_c"],
        revolutions=record_revolutions(record["speed_hz"], DT_S),
        probe_scale_factor_std=probe_scale_factor_std,
    )
