"""Run oilwatch's estimator on a recorded machine: record in, estimates, summary and views out.

The estimator is the one the OilFlowEKF FMU wraps, in-process and configured as that FMU's defaults
(``EKFConfig.recommended`` at the model's speed, the probes' ``noise_um``, initial flowrates at nominal, zero
initial states, the first sample at the record's first grid time). The probes' zero offsets have the
preset's prior, as the FMU's ``offset_prior_std_um = -1``: the machine file's ``[probes] offset_prior_std_um``
on the machine preset, 0 (known) on the paper preset; or a commissioning baseline's (``--baseline``, the FMU's
``baseline_file``). The probes' slow-roll runout, the baseline's when it has one, else the machine file's
``[probes]`` ``runout_*`` keys (``--probe`` overrides them as every probe key), is subtracted from each
sample at its rotor angle (``EKFConfig.runout``, as the FMU does). Fed the same samples with the same
settings, it gives the co-simulated FMU's estimates.
The model is the machine file's reduced rotor-bearing system with the machine file's unbalance, sampled at
1 kHz (:data:`ESTIMATOR_DT_S`): at the nominal speed and viscosity (the FMU's ``bearing_table = 0``), or, when
the record gives a speed (a ``speed_hz`` column or the keyphasor) or an oil temperature, its operating model,
which each sample's speed and oil temperature (held over the period that ends at the sample, as the FMU holds
its inputs over a step) move along the dimensionless bearing tables (``bearing_table = 1``; see
:class:`EstimateOptions`, ``--operating-point``).

Outputs, in ``out_dir``:

* ``estimates.csv``: one row per estimator sample (or every ``output_every``-th), written and flushed block
  by block (line by line from standard input), so that nothing is lost when a run stops; columns from
  :func:`oilwatch.monitoring.columns.estimate_columns`: time, both flowrate estimates and stds, alarms,
  NIS, convergence, the conditioned shaft positions, speed, oil temperature, and every further field the
  estimator's step report carries (nuisance estimates, probe health, model consistency: named after the
  field, SI suffixes ``_m`` and ``_m3_s`` converted to ``_um`` and ``_ml_min``);
* ``summary.json`` (:func:`oilwatch.monitoring.summary.summarize`), the views
  (:mod:`oilwatch.monitoring.views`) and ``report.html``.
"""

from __future__ import annotations

import dataclasses
import gc
import itertools
import time
from collections.abc import Callable
from contextlib import contextmanager
from pathlib import Path
from typing import TextIO

import numpy as np

from oilwatch.estimator.ekf_config import DEFAULT_PRESET, ML_MIN, preset_named
from oilwatch.estimator.factory import make_estimator
from oilwatch.estimator.runout import SlowRollVectors, runout_of_probes
from oilwatch.models.machine import Machine, load_machine
from oilwatch.models.probes import read_probes
from oilwatch.models.validation import InputError
from oilwatch.outputs import interrupts, ledger
from oilwatch.outputs.atomic import write_json_atomic
from oilwatch.outputs.lock import output_lock
from oilwatch.outputs.rows import RowFile
from oilwatch.records import RecordStream, probe_setup
from oilwatch.records.probes import merged_section
from oilwatch.records.readers import STDIN

from . import OPERATING_POINTS
from .columns import TraceRows, column_decimals, estimate_columns
from .csv_rows import RowWriter
from .estimator_setup import ESTIMATOR_DT_S, estimator_config, estimator_model
from .history import History
from .resume import (
    RESUME_CHOICES,
    SAVE_EVERY_S,
    STATE_NAME,
    forget_point,
    resume_point,
    run_identity,
    save_point,
)
from .summary import mismatch_reason
from .timing import CpuMarks, LatencyHistogram
from .trust import TrustShares, apply_to_verdict

GC_BLOCKS = 64
"""Blocks between the collections of young objects while the automatic collector is off (below)."""


@contextmanager
def _young_collections_only():
    """The automatic cyclic garbage collector off for the estimation loop: every step allocates a report
    and a few arrays, which made it run full collections over the whole heap (numba, scipy, the model), 5-10 %
    of the loop (measured in CPU time). The loop makes no reference cycles; :meth:`EstimateRun.run` still
    collects the young generations every :data:`GC_BLOCKS` blocks, so a reader that did cannot grow memory
    without bound."""
    enabled = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        if enabled:
            gc.enable()


@dataclasses.dataclass(frozen=True)
class EstimateOptions:
    """What ``oilwatch estimate`` takes besides the record (see the CLI's help)."""

    machine_file: str | None = None
    baseline_file: str | None = None
    offset_prior_std_um: float | None = None
    preset: str = DEFAULT_PRESET
    """The estimator's configuration (:data:`oilwatch.estimator.ekf_config.PRESETS`), as the FMU's ``preset``:
    the nuisance priors left None, the model (``auto`` follows the operating point when the preset does and
    the machine has an ``[oil]``) and the action on a model mismatch. The probe offsets are always
    estimated with the machine file's ``[probes]`` prior (or ``offset_prior_std_um``, or the baseline): a
    record comes from probes whose zero is not calibrated."""
    viscosity_factor_prior_std: float | None = None
    """> 0: each bearing's viscosity factor is estimated with this prior std (the estimator FMU's
    ``viscosity_factor_prior_std``; needs the model that follows the operating point); with no baseline for
    the factors the estimator is the start bank (:func:`oilwatch.estimator.factory.make_estimator`); None:
    the preset's."""
    unbalance_prior_std: float | None = None
    """The complex unbalance's prior std (the FMU's ``unbalance_prior_std``; None: the preset's)."""
    probe_overrides: tuple[str, ...] = ()
    output_every: int = 1
    chunk_rows: int = 8192
    views: bool = True
    live: bool = False
    record_start: str | None = None
    """When the record started (ISO 8601, UTC): with a baseline file that records its own start, the
    baseline's age, which widens its offsets prior (:mod:`oilwatch.monitoring.baseline_age`)."""
    resume: str = "auto"
    """A partial run of the same record, machine and options in the output folder: ``auto`` resumes it
    (else starts over), ``yes`` resumes it or refuses, ``no`` starts over (:mod:`.resume`)."""
    operating_point: str = "auto"
    """``follow``: the estimator's operating model follows the record's speed and oil temperature (the
    estimator FMU's ``bearing_table = 1``); ``nominal``: the model at the machine's nominal speed and
    viscosity (``bearing_table = 0``); ``auto``: follow when the record has a speed (a ``speed_hz`` column or
    a keyphasor) or an oil-temperature column and the machine has an ``[oil]``."""


def open_record_stream(
    source: str,
    machine: Machine,
    probe_overrides: tuple[str, ...] = (),
    chunk_rows: int = 8192,
    progress: Callable[[int], None] | None = None,
) -> RecordStream:
    """The record as the estimator's samples (:class:`oilwatch.records.RecordStream`: any format and sample
    rate at or above the estimator's, anti-aliased and resampled, keyphasor and speed columns, the machine
    file's ``[probes]`` mapping with ``probe_overrides``): the one way records come in, for ``oilwatch
    estimate`` and ``oilwatch baseline`` alike."""
    setup = probe_setup(machine.raw.get("probes"), probe_overrides)
    return RecordStream(
        source,
        setup,
        tuple(bearing.clearance_m for bearing in machine.bearings),
        ESTIMATOR_DT_S,
        machine.nominal_speed_hz,
        chunk_rows=chunk_rows,
        progress=progress,
    )


def read_record_samples(source: str, machine: Machine, probe_overrides: tuple[str, ...] = ()) -> dict:
    """A whole record through :func:`open_record_stream`: ``first_sample_time_s`` (its first grid sample's
    model time), ``measurement_m`` (K, 4) as the estimator takes it, ``speed_hz`` / ``oil_temperature_c``
    (K,) or None when the record has no such column, ``probe_angle_deg`` (the estimator's: the pairs'
    angle when it takes the readings along the probes' axes, else 0) and the stream (its provenance)."""
    stream = open_record_stream(source, machine, probe_overrides)
    blocks = list(stream.blocks())
    if not blocks:
        raise InputError(f"{source}: no sample on the estimator's grid")

    def joined(name: str) -> np.ndarray:
        return np.concatenate([getattr(block, name) for block in blocks])

    speed, temperature = joined("speed_hz"), joined("oil_temperature_c")
    return {
        "first_sample_time_s": int(blocks[0].k[0]) * ESTIMATOR_DT_S,
        "measurement_m": joined("measurement_m"),
        "speed_hz": speed if np.isfinite(speed).all() else None,
        "oil_temperature_c": temperature if np.isfinite(temperature).all() else None,
        "probe_angle_deg": stream.probe_angle_deg or 0.0,
        "stream": stream,
    }


def _is_angle_key(override: str) -> bool:
    key = override.partition("=")[0].strip()
    return key == "layout" or key.endswith(".angle_deg")


class EstimateRun:
    """One record through the estimator (module docstring); :meth:`run` returns the summary."""

    def __init__(
        self,
        source: str,
        out_dir: str | Path,
        options: EstimateOptions,
        progress: Callable[[int], None] | None = None,
        total_callback: Callable[[int | None, str], None] | None = None,
        live_stream: TextIO | None = None,
    ) -> None:
        if options.operating_point not in OPERATING_POINTS:
            raise InputError(
                f"--operating-point must be one of {', '.join(OPERATING_POINTS)}, got "
                f"{options.operating_point!r}"
            )
        if options.resume not in RESUME_CHOICES:
            raise InputError(f"--resume must be one of {', '.join(RESUME_CHOICES)}, got {options.resume!r}")
        self.source = source
        self.out = Path(out_dir)
        self.options = options
        self.machine: Machine = load_machine(options.machine_file)
        self.setup = probe_setup(self.machine.raw.get("probes"), options.probe_overrides)
        self.speed_hz = self.machine.nominal_speed_hz  # the model's reference speed
        # the estimator's probe model reads the same overridden section (offsets prior, runout_* keys) but
        # the machine file's angles: it takes the stream's pair angle, and probes overridden off square pairs
        # are read as (x, y) positions (models.probes refuses such angles in a machine file)
        kept = [item for item in options.probe_overrides if not _is_angle_key(item)]
        section = merged_section(self.machine.raw.get("probes") or {}, kept)
        self.probes = read_probes(
            dataclasses.replace(self.machine, raw={**self.machine.raw, "probes": section})
        )
        prior_um = options.offset_prior_std_um
        if not preset_named(options.preset).offsets_from_machine:
            # a preset with calibrated probes (the estimator FMU's reading of it): scale factors exact and,
            # unless given, the offsets known
            self.probes = dataclasses.replace(self.probes, scale_factor_std=0.0)
            prior_um = 0.0 if prior_um is None else prior_um
        if prior_um is not None:
            self.probes = dataclasses.replace(self.probes, offset_prior_std_m=prior_um * 1e-6)
        self.baseline, self.baseline_age_days, self.clearance_factors = None, None, None
        if options.baseline_file is not None:
            from oilwatch.estimator.baseline import load_baseline, load_clearance_factors

            from .baseline_age import baseline_age_days

            self.baseline_age_days = baseline_age_days(options.baseline_file, options.record_start)
            age_s = 0.0 if self.baseline_age_days is None else 86400.0 * self.baseline_age_days
            drift = self.probes.offset_drift_m_per_day
            self.baseline = load_baseline(options.baseline_file, age_s, drift)
            self.clearance_factors = load_clearance_factors(options.baseline_file)
        chunk_rows = 1 if source == STDIN and options.live else options.chunk_rows
        self.stream = open_record_stream(source, self.machine, options.probe_overrides, chunk_rows, progress)
        if total_callback is not None:
            total_callback(self.stream.reader.total, self.stream.reader.progress_unit)
        self.preset = preset_named(options.preset)
        self.follow, self.operating_reason = self._operating_choice()
        self.viscosity_factor_prior_std = self._prior("viscosity_factor_prior_std")
        if self.viscosity_factor_prior_std > 0.0 and not self.follow:
            raise InputError(
                "--viscosity-prior > 0 needs the model that follows the operating point: a record with a "
                "speed or an oil temperature and the machine's [oil] (or --operating-point follow); "
                f"the model is {self.operating_reason}"
            )
        # after the record's checks: errors come first
        self.model = estimator_model(
            options.machine_file,
            follow=self.follow,
            machine=self.machine,
            clearance_factors=self.clearance_factors,
        )
        self.live_stream = live_stream
        self.trust = TrustShares(self.model.bearing_flowrate_bounds_m3_s / ML_MIN)
        self.filter = None  # oilwatch.estimator.factory.make_estimator's: a filter, or the start bank
        # the estimator takes the readings along the probes' axes when it can (the FMU's probe_angle_deg)
        self.probe_angle_deg = self.stream.probe_angle_deg or 0.0
        self.runout, self.runout_source = self._runout()
        self.history = History(
            ESTIMATOR_DT_S,
            self.speed_hz,
            tuple(bearing.clearance_m for bearing in self.machine.bearings),
            self.probe_angle_deg,
        )
        self.latency = LatencyHistogram()  # from standard input: a line's arrival to its estimate written
        self.estimator_s = 0.0  # CPU time in the estimator's steps (the rest: reading, conditioning, writing)
        self.cpu_s = 0.0  # this process's CPU time over the same span as the summary's wall_s
        self.cpu_marks = CpuMarks(options.chunk_rows)  # along the record (summary cpu_us_per_sample_by_tenth)
        self.stages_s = dict.fromkeys(("read_condition", "rows", "write", "history"), 0.0)
        """Where the rest of the CPU time goes, after the first block: reading and conditioning the record,
        building the rows from the step reports, formatting and writing them, the views' history."""

    def _runout(self) -> tuple[SlowRollVectors | None, str | None]:
        """The probes' slow-roll vectors and where they come from: the baseline's when it has them (a
        slow-roll record, ``oilwatch baseline --slow-roll-record``), else the machine file's ``[probes]``
        ``runout_*`` keys, else none. They are per probe, along its axis: the estimator must take the
        readings along the probes' axes (square pairs at one angle)."""
        runout, source = None, None
        if self.options.baseline_file is not None:
            from oilwatch.estimator.baseline import load_runout

            runout, source = load_runout(self.options.baseline_file), "baseline file"
        if runout is None:
            runout, source = runout_of_probes(self.probes), "machine file [probes] runout_* keys"
        if runout is None:
            return None, None
        if self.stream.probe_angle_deg is None:
            raise InputError(
                f"{source}: runout compensation needs the readings along the probes' axes: each bearing's Y "
                "probe 90 deg counter-clockwise of its X probe and both X probes at one angle (probes.*."
                "angle_deg)"
            )
        return runout, source

    def _prior(self, field: str) -> float:
        """A nuisance prior: the option's, else the preset's (with the model that cannot follow the operating
        point, the preset's viscosity factors are known: the model has none)."""
        given = getattr(self.options, field)
        if given is not None:
            return given
        value = self.preset.value(field, 0.0)
        return 0.0 if field == "viscosity_factor_prior_std" and not self.follow else value

    def _operating_choice(self) -> tuple[bool, str]:
        """(follow the record's speed and oil temperature?, why), from ``operating_point`` (see
        :class:`EstimateOptions`)."""
        choice = self.options.operating_point
        stream = self.stream
        measured = [
            name
            for name, present in (
                ("speed", stream.speed_source != "none"),
                ("oil temperature", stream.has_temperature),
            )
            if present
        ]
        if choice == "nominal":
            return False, "nominal (--operating-point nominal)"
        if choice == "follow":
            if self.machine.oil is None:
                raise InputError(
                    "--operating-point follow needs the machine's oil ([oil] in the machine file) to turn "
                    "the oil temperature into a viscosity"
                )
            return True, "follows the record's " + (" and ".join(measured) or "(constant) operating point")
        if self.machine.oil is None:
            return False, "nominal (the machine file has no [oil]: the model cannot follow)"
        if not measured and self.preset.follow_operating_point:
            return True, f"follows the (constant, nominal) operating point: the {self.preset.name} preset"
        if not measured:
            return False, "nominal (the record has no speed and no oil temperature)"
        return True, "follows the record's " + " and ".join(measured)

    def run(self) -> dict:
        """Process the record; write estimates.csv (and, unless ``views`` is off, the views and report),
        then summary.json, last. One run at a time per folder (:func:`oilwatch.outputs.lock.output_lock`);
        a stopped run leaves whole rows, a summary that says so and a resume point (:mod:`.resume`)."""
        with output_lock(self.out, "estimate"):
            return self._run_locked()

    def _run_locked(self) -> dict:
        csv_path = self.out / "estimates.csv"
        live = self.source == STDIN
        self.identity = None if live else run_identity(self.source, self.machine.source_path, self.options)
        point = None if live else resume_point(self.out, self.identity, self.options.resume)
        self.resumed_from_s = None
        self._write_summary(self._partial_summary("running", csv_path))
        csv_file = RowFile(
            csv_path,
            append=point is not None,
            keep_bytes=0 if point is None else point["csv_bytes"],
            keep_lines=0 if point is None else point["csv_lines"],
            sync_every=256 if live else 1,
        )
        ledger.keep("estimates.csv", lambda: self._kept(csv_path, csv_file))
        self._boundary = False  # the filter, history and file at one block boundary (a resume point)
        self._writer = None
        try:
            with _young_collections_only():
                done = self._loop(csv_file, point)
        except BaseException as error:
            self._stopped(error, csv_path, csv_file)
            raise
        finally:
            csv_file.close()
        if self.filter is None:
            raise InputError(f"{self.stream.reader.name}: no sample to estimate from (record too short)")
        wall = time.perf_counter() - self._started
        self.cpu_s = time.process_time() - self._started_cpu
        self.cpu_marks.add(done, self.cpu_s, last=True)
        from .summary import summarize

        try:  # every row is written: a stop from here on leaves them all and a summary that says so
            summary = summarize(self, wall, csv_path)
            summary["identity"] = self.identity
            summary["resumed_from_time_s"] = self.resumed_from_s
            summary["trust"] = self.trust.summary()
            mismatch_reason(summary)
            apply_to_verdict(summary)
            if self.options.views:
                from .report import write_report
                from .views import write_views

                summary["views"] = {
                    name: str(path) for name, path in write_views(self.history, summary, self.out).items()
                }
                summary["report_html"] = str(write_report(summary, self.out))
            summary.update(completed=True, status="completed")
            self._write_summary(summary)
        except BaseException as error:
            self._stopped(error, csv_path, csv_file, complete_rows=True)
            raise
        forget_point(self.out)
        ledger.forget("estimates.csv")
        return summary

    def _loop(self, writer_file: RowFile, point: dict | None) -> int:
        """Estimate block after block, from the resume ``point`` if any; return the samples estimated."""
        writer = RowWriter(writer_file, self.live_stream, self.options.output_every)
        self._writer = writer  # a stop before the first periodic save saves its point with it
        clock, spent = time.process_time, self.stages_s  # CPU time: preemption by a shared machine's load
        # would land in whichever stage it interrupts
        blocks = self.stream.blocks()
        done, last_save = 0, time.perf_counter()
        self._started, self._started_cpu = time.perf_counter(), clock()
        for count in itertools.count(1):
            if count % GC_BLOCKS == 0:
                gc.collect(1)
            t0 = clock()
            block = next(blocks, None)
            t1 = clock()
            if block is None:
                break
            first = self.filter is None
            if first:
                self._start(block, writer, header=point is None)
                self._started, self._started_cpu = time.perf_counter(), clock()
                t1 = self._started_cpu
                if point is not None:
                    self._restore(point, writer)
            else:
                spent["read_condition"] += t1 - t0
            if point is not None and int(block.k[-1]) < point["k_next"]:
                continue  # estimated before the stop: in estimates.csv and in the restored state
            if point is not None and int(block.k[0]) != point["k_next"]:
                raise InputError(
                    f"{self.out / STATE_NAME}: the resume point (grid sample {point['k_next']}) is not at a "
                    "block boundary of this record; rerun with --resume no"
                )
            point = None
            # a block is estimated, written and kept whole: a signal waits for its end (a fraction of a
            # second), so that a stop always leaves the filter, the file and the history at one boundary
            with interrupts.deferred():
                self._boundary = False
                steps = self.estimator_s
                rows = self._estimate(block)
                done += rows.shape[0]
                self.cpu_marks.add(done, clock() - self._started_cpu)
                t2 = clock()
                spent["rows"] += t2 - t1 - (self.estimator_s - steps)
                writer.write(rows)
                t3 = clock()
                spent["write"] += t3 - t2
                if self.options.live and not first:  # from the arrival of the line to its estimate written
                    self.latency.add(time.perf_counter() - self.stream.reader.received_s)
                self.history.add(block, rows, self._columns)
                self.trust.add(rows)
                spent["history"] += clock() - t3
                self._boundary = True
                self._k_next = int(block.k[-1]) + 1
            if self.identity is not None and time.perf_counter() - last_save > SAVE_EVERY_S:
                self._save_point(writer_file, writer)
                last_save = time.perf_counter()
        self._writer = writer
        return done

    def _restore(self, point: dict, writer: RowWriter) -> None:
        """Continue from a resume point: the estimator's state, the history and the rows counted."""
        self.filter.set_state(point["filter"])
        self.history = point["history"]
        self.trust = point["trust"]
        writer.samples = point["samples"]
        self._k_next = point["k_next"]
        self.resumed_from_s = point["time_s"]
        self._boundary = True
        self._writer = writer

    def _save_point(self, csv_file: RowFile, writer: RowWriter) -> None:
        """Save the resume point of the current block boundary (:mod:`.resume`)."""
        csv_file.sync()
        save_point(
            self.out,
            {
                "identity": self.identity,
                "k_next": self._k_next,
                "time_s": self._k_next * ESTIMATOR_DT_S,
                "csv_bytes": csv_file.committed,
                "csv_lines": csv_file.lines,
                "samples": writer.samples,
                "filter": self.filter.get_state(),
                "history": self.history,
                "trust": self.trust,
            },
        )
        self._writer = writer

    def _kept(self, csv_path: Path, csv_file: RowFile) -> str:
        last = self.history.last_time_s if self.history.samples else None
        until = "" if last is None else f", to t = {last:.3f} s"
        return f"{csv_path} keeps {max(0, csv_file.lines - 1)} whole rows{until}"

    def _partial_summary(self, status: str, csv_path: Path) -> dict:
        return {
            "completed": False,
            "status": status,
            "identity": self.identity,
            "record": {"source": self.source},
            "estimates_csv": str(csv_path),
        }

    def _stopped(self, error: BaseException, csv_path: Path, csv_file: RowFile, complete_rows=False) -> None:
        """A run that stops early: its resume point (at a block boundary) and a summary that says so; each
        best effort (the disk may be full), the original error stands."""
        if isinstance(error, KeyboardInterrupt):
            status = f"interrupted ({interrupts.signal_name(error)})"
        else:
            status = f"failed: {error}"
        resumable = self.identity is not None and self._boundary and self.filter is not None
        saved = False
        if resumable and not complete_rows:
            try:
                self._save_point(csv_file, self._writer)
                saved = True
            except (OSError, AttributeError):
                pass
        summary = self._partial_summary(status, csv_path)
        summary.update(rows=max(0, csv_file.lines - 1), all_rows_written=complete_rows)
        summary["resumable"] = saved or (self.out / STATE_NAME).is_file()
        try:
            self._write_summary(summary)
            note = "summary.json says partial"
        except OSError:
            note = "summary.json could not be updated"
        if summary["resumable"] and not complete_rows:
            note += "; the same command resumes"
        ledger.keep("summary", lambda: note)

    def _write_summary(self, summary: dict) -> None:
        write_json_atomic(self.out / "summary.json", summary)

    def _operating(self, speed_hz: float, oil_temperature_c: float) -> tuple[float | None, float | None]:
        """A sample's (speed, oil temperature) for the filter's step: None where not recorded (NaN: the
        model keeps the last value) or not followed."""
        if not self.follow:
            return None, None
        return (
            speed_hz if speed_hz == speed_hz else None,
            oil_temperature_c if oil_temperature_c == oil_temperature_c else None,
        )

    def _start(self, block, writer: RowWriter, header: bool = True) -> None:
        """The filter, started one period before the first sample when it can, with a missing sample there:
        what the OilFlowEKF FMU does in a co-simulation started at the record's start time (the plant's
        first output is its state after one step; that missing step holds the first sample's operating
        point, as the FMU holds its inputs over the step), so that both give the same estimates."""
        first_k = int(block.k[0])
        lead = 1 if first_k >= 1 else 0
        config = estimator_config(
            self.speed_hz,
            self.setup.noise_um,
            (first_k - lead) * ESTIMATOR_DT_S,
            self.probes,
            self.baseline,
            self.probe_angle_deg,
            self.runout,
            self.viscosity_factor_prior_std,
            self._prior("unbalance_prior_std"),
            self.preset.value("model_mismatch_action", True),
        )
        self.filter = make_estimator(self.model, config)
        missing = np.full(4, np.nan)
        operating = self._operating(float(block.speed_hz[0]), float(block.oil_temperature_c[0]))
        # compile the kernels, as the FMU does, at the first sample's operating point (the FMU's start
        # inputs): that places the operating model's first correction centre where the FMU's is
        warm = (self.speed_hz if operating[0] is None else operating[0], operating[1]) if self.follow else ()
        for sample in (np.zeros(4), np.zeros(4), missing):
            self.filter.step(sample, *warm)
        self.filter.reset()
        for _ in range(lead):
            self.filter.step(missing, *operating)
        self._first_k = first_k - lead
        report = self.filter.current_report()
        self._columns, extras = estimate_columns(report)
        self._rows = TraceRows(self._columns, extras)
        self.trust.columns(self._columns)
        self._trace = None
        writer.header(self._columns, column_decimals(self._columns, report), to_file=header)

    def _estimate(self, block) -> np.ndarray:
        ekf = self.filter
        expected = self._first_k + ekf.step_count
        if int(block.k[0]) != expected:
            raise InputError(f"internal: grid index {int(block.k[0])} after {expected - 1}")  # bridged, never
        count = block.k.size
        started = time.process_time()
        trace = self._steps(block)
        self.estimator_s += time.process_time() - started
        return self._rows.rows(block, trace, count)

    def _steps(self, block):
        """The estimator's per-sample outputs over a block (its ``run_batch``, into
        the previous block's trace when it has the rows)."""
        count = block.k.size
        reuse = self._trace if self._trace is not None and self._trace.nis.shape[0] >= count else None
        speed, temperature = (block.speed_hz, block.oil_temperature_c) if self.follow else (None, None)
        self._trace = self.filter.run_batch(block.measurement_m, speed, temperature, out=reuse)
        return self._trace
