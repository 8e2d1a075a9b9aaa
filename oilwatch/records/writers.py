"""Write records in the formats :mod:`oilwatch.records.readers` reads: CSV, Parquet and NI TDMS.

For exporting a simulated run as a data-acquisition system would have recorded it (tests, benchmarks, and
users who want to try ``oilwatch estimate`` on a known case). Columns are written in the given order; TDMS
channels are waveforms in one group (``wf_increment`` from the time column, which is then not written, and
``unit_string`` from ``units``).
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

import numpy as np

from .readers import RecordError, _import, record_format

TDMS_GROUP = "oilwatch"


def write_record(
    path: str | Path,
    columns: Mapping[str, np.ndarray],
    time_column: str = "time_s",
    units: Mapping[str, str] | None = None,
) -> Path:
    """Write ``columns`` (name -> (n,) array, the time column among them) to ``path`` (format from its
    suffix)."""
    path = Path(path)
    kind = record_format(str(path))
    if time_column not in columns:
        raise RecordError(f"write_record: no {time_column!r} column")
    if kind == "csv":
        names = list(columns)
        table = np.column_stack([np.asarray(columns[name], dtype=float) for name in names])
        formats = ["%.7f" if name == time_column else "%.9g" for name in names]
        with open(path, "w", encoding="utf-8", newline="") as file:
            file.write(",".join(names) + "\n")
            np.savetxt(file, table, fmt=formats, delimiter=",")
    elif kind == "parquet":
        pa = _import("pyarrow", "pyarrow")
        parquet = _import("pyarrow.parquet", "pyarrow")
        table = pa.table({name: np.asarray(values, dtype=float) for name, values in columns.items()})
        parquet.write_table(table, path)
    else:
        nptdms = _import("nptdms", "npTDMS")
        time_s = np.asarray(columns[time_column], dtype=float)
        increment = float(np.median(np.diff(time_s)))
        channels = []
        for name, values in columns.items():
            if name == time_column:
                continue
            properties = {"wf_start_offset": float(time_s[0]), "wf_increment": increment}
            if units and name in units:
                properties["unit_string"] = units[name]
            channels.append(
                nptdms.ChannelObject(TDMS_GROUP, name, np.asarray(values, dtype=float), properties)
            )
        with nptdms.TdmsWriter(path) as writer:
            writer.write_segment([nptdms.GroupObject(TDMS_GROUP), *channels])
    return path
