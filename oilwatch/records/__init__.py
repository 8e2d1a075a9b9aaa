"""Recorded measurements: readers (CSV, Parquet, TDMS), the probe set-up, and their conditioning onto the
estimator's sampling grid (see :mod:`oilwatch.records.stream`)."""

from .probes import PROBE_NAMES, PositionConverter, Probe, ProbeSetup, probe_setup
from .readers import STDIN, RecordError, open_record
from .stream import GridBlock, RecordStream

__all__ = [
    "PROBE_NAMES",
    "STDIN",
    "GridBlock",
    "PositionConverter",
    "Probe",
    "ProbeSetup",
    "RecordError",
    "RecordStream",
    "open_record",
    "probe_setup",
]
