"""Co-simulation: a fixed-step FMI 2.0 master on fmpy, SSP files, and FMU packaging helpers.

Import the pieces from here::

    from oilwatch.cosim import FmuSpec, Master, SystemDescription, Connection, CsvRecorder
"""

from .connections import Connection
from .errors import SlaveError, SystemDescriptionError
from .master import FmuSpec, Master, RunResult, SystemDescription
from .recording import CsvRecorder, MemoryRecorder

__all__ = [
    "Connection",
    "CsvRecorder",
    "FmuSpec",
    "Master",
    "MemoryRecorder",
    "RunResult",
    "SlaveError",
    "SystemDescription",
    "SystemDescriptionError",
]
