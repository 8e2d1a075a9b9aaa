"""The co-simulation master: FMI 2.0 co-simulation FMUs run together with fmpy at fixed macro steps.

Usage::

    from oilwatch.cosim import FmuSpec, Master, SystemDescription, CsvRecorder

    system = SystemDescription(
        fmus=[
            FmuSpec("plant", "build/RotorBearingPlant.fmu", {"noise_um": 1.0}),
            FmuSpec("ekf", "build/OilFlowEKF.fmu", {"noise_um": 1.0}),
        ],
        connections=None,  # None: connect inputs to same-named outputs
    )
    with Master(system) as master:
        result = master.run(stop_time=20.0, step_size=1e-3, method="gauss-seidel",
                            record=["plant.q1_ml_min", "ekf.q1_est_ml_min"],
                            recorder=CsvRecorder("out/result.csv"))

A second :meth:`Master.run` reuses the loaded FMUs through ``fmi2Reset``. Any FMI call that returns
error, fatal or discard stops the run with a :class:`~oilwatch.cosim.errors.SlaveError` naming the
FMU instance, the FMI function and the simulation time; a wrong system description raises
:class:`~oilwatch.cosim.errors.SystemDescriptionError` (an ``InputError``) before anything runs.
"""

from __future__ import annotations

import math
import time as wallclock
from collections import defaultdict
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

from .algorithm import make_stepper
from .connections import Connection, check_connections, make_transfers, same_name_connections
from .errors import SystemDescriptionError
from .fmi3_loading import open_slave
from .loading import Port, Slave
from .recording import as_recorder


@dataclass
class FmuSpec:
    """One FMU instance of a system: instance ``name``, ``.fmu`` ``path``, parameter values by name."""

    name: str
    path: str | Path
    parameters: dict[str, object] = field(default_factory=dict)


@dataclass
class SystemDescription:
    """FMU instances, connections (None: same-name matching) and a default experiment [s]."""

    fmus: list[FmuSpec]
    connections: list[Connection] | None = None
    start_time: float = 0.0
    stop_time: float | None = None
    step_size: float | None = None
    name: str = "system"


@dataclass
class RunResult:
    """What :meth:`Master.run` did: steps taken, final time [s], wall time [s] and the recorder."""

    steps: int
    time: float
    simulated_s: float
    wall_s: float
    recorder: object
    columns: list[str]

    @property
    def realtime_factor(self) -> float:
        """Simulated seconds per wall-clock second."""
        return self.simulated_s / self.wall_s if self.wall_s > 0 else math.inf


class Master:
    """Loads the system's FMUs once; :meth:`run` simulates it (as often as wanted)."""

    def __init__(self, system: SystemDescription):
        names = [spec.name for spec in system.fmus]
        if len(set(names)) != len(names) or not names:
            raise SystemDescriptionError(f"FMU instance names must be unique and given: {names}")
        self.system = system
        self.slaves: dict[str, Slave] = {}
        self._used = False
        try:
            for spec in system.fmus:
                self.slaves[spec.name] = open_slave(spec.name, spec.path)
            for spec in system.fmus:
                for parameter in spec.parameters:
                    self.slaves[spec.name].variable(parameter)
            connections = system.connections
            if connections is None:
                connections = same_name_connections(
                    {name: slave.variables.values() for name, slave in self.slaves.items()}
                )
            check_connections(list(connections), self.slaves)
            self.connections = list(connections)
            self.transfers = make_transfers(self.connections, self.slaves)
        except BaseException:
            self.close()
            raise

    def __enter__(self) -> Master:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def close(self) -> None:
        """Free every FMU instance and delete its extracted files (except the shared persistent folders
        of :mod:`~oilwatch.cosim.extraction`)."""
        for slave in self.slaves.values():
            slave.close()

    def _probes(self, record: list[str]) -> list[tuple[Port, list[int]]]:
        groups: dict[tuple[str, str], list[tuple[int, str]]] = defaultdict(list)
        for position, column in enumerate(record):
            instance, _, variable = column.partition(".")
            if instance not in self.slaves or not variable:
                raise SystemDescriptionError(
                    f"recorded variable {column!r} must be 'instance.variable' with an instance "
                    f"in {sorted(self.slaves)}"
                )
            type_name = self.slaves[instance].variable(variable).type
            if type_name == "String":
                raise SystemDescriptionError(f"recorded variable {column!r} is a String")
            groups[(instance, type_name)].append((position, variable))
        return [
            (Port(self.slaves[inst], [v for _, v in items], type_name), [p for p, _ in items])
            for (inst, type_name), items in groups.items()
        ]

    def default_record(self) -> list[str]:
        """All outputs of all instances, as ``instance.variable``."""
        return [
            f"{slave.name}.{v.name}"
            for slave in self.slaves.values()
            for v in slave.variables.values()
            if v.causality == "output" and v.type != "String"
        ]

    def run(
        self,
        stop_time: float | None = None,
        step_size: float | None = None,
        *,
        start_time: float | None = None,
        method: str = "gauss-seidel",
        order: list[str] | None = None,
        record: list[str] | None = None,
        recorder=None,
        record_every: int = 1,
        parameters: dict[str, dict[str, object]] | None = None,
        progress: bool = False,
        labels: dict[str, dict[str, str]] | None = None,
        input_signals: dict[str, Callable[[float], float]] | None = None,
    ) -> RunResult:
        """Simulate from ``start_time`` to ``stop_time`` [s] with macro step ``step_size`` [s].

        method: "gauss-seidel" (in ``order``, default the system's FMU order) or "jacobi".
        record: ``instance.variable`` names (default: every output); rows go to ``recorder``
        (an object with start/record/close, or a callable ``f(time, values)``; default a
        MemoryRecorder) at the start time and after every ``record_every``-th step.
        parameters: per-instance overrides of the system's parameter values.
        labels: per instance, how the user gave a variable (``{"plant": {"seed": "--seed"}}``): errors
        about it (a value of the wrong FMI type, a message in the FMU's log) name it so.
        input_signals: ``{"instance.input": f}``: each Real input is set to ``f(t)`` at the start of every
            step (t its start time; held over the step) and, before initialization, to ``f(start)``: the
            scenario's speed and oil-temperature profiles (``oilwatch.models.system.profiles``).
        """
        system = self.system
        start = system.start_time if start_time is None else start_time
        stop = system.stop_time if stop_time is None else stop_time
        step = system.step_size if step_size is None else step_size
        if stop is None or step is None or not step > 0 or not stop > start:
            raise SystemDescriptionError(
                f"need step_size > 0 and stop_time > start_time, got step_size={step}, "
                f"start_time={start}, stop_time={stop}"
            )
        steps = round((stop - start) / step)
        if not math.isclose(steps * step, stop - start, rel_tol=1e-9, abs_tol=1e-12):
            raise SystemDescriptionError(
                f"stop_time - start_time = {stop - start:g} s is not a multiple of step_size = {step:g} s"
            )
        order_names = order or [spec.name for spec in system.fmus]
        if sorted(order_names) != sorted(self.slaves):
            raise SystemDescriptionError(f"order must name each instance once: {order_names}")
        if any(slave.dead for slave in self.slaves.values()):
            raise SystemDescriptionError("a slave died in an earlier run; create a new Master")
        stepper = make_stepper(method, [self.slaves[n] for n in order_names], self.transfers)
        record = self.default_record() if record is None else list(record)
        probes = self._probes(record)
        recorder = as_recorder(recorder)
        labels = labels or {}
        values = self._parameter_values(parameters or {}, labels)
        signals = self._signals(input_signals or {})
        for port, function in signals:
            values[port.slave.name] = {**values[port.slave.name], port.names[0]: float(function(start))}

        if self._used:
            for slave in self.slaves.values():
                slave.reset()
        self._used = True
        for name in order_names:
            self.slaves[name].initialize(start, stop, values[name], labels.get(name, {}))
        for transfer in self.transfers:
            transfer.move()

        bar = None
        if progress:
            from tqdm import tqdm

            bar = tqdm(total=steps, unit="step", desc=system.name, mininterval=0.5)
        row = [0.0] * len(record)
        wall_start = wallclock.perf_counter()
        done = 0
        recorder.start(record)
        try:
            self._record(recorder, probes, row, start)
            for k in range(steps):
                for port, function in signals:
                    port.values[0] = function(start + k * step)
                    port.write()
                stepper(start + k * step, step)
                done = k + 1
                if done % record_every == 0 or done == steps:
                    self._record(recorder, probes, row, start + done * step)
                if bar is not None and done % 100 == 0:
                    bar.update(100)
            for slave in self.slaves.values():
                slave.terminate()
        finally:
            recorder.close()
            if bar is not None:
                bar.close()
        wall = wallclock.perf_counter() - wall_start
        return RunResult(done, start + done * step, done * step, wall, recorder, record)

    def _signals(self, input_signals: dict[str, Callable[[float], float]]) -> list[tuple[Port, Callable]]:
        """One single-variable Real port per driven input, checked by name."""
        out = []
        for name, function in input_signals.items():
            instance, _, variable = name.partition(".")
            if instance not in self.slaves:
                raise SystemDescriptionError(f"input signal {name!r}: no instance {instance!r}")
            slave = self.slaves[instance]
            if variable not in slave.variables or slave.variables[variable].causality != "input":
                raise SystemDescriptionError(f"input signal {name!r}: {instance} has no input {variable!r}")
            out.append((Port(slave, [variable], "Real"), function))
        return out

    @staticmethod
    def _record(recorder, probes, row, time) -> None:
        for port, positions in probes:
            port.read()
            for position, value in zip(positions, port.values, strict=True):
                row[position] = value
        recorder.record(time, row)

    def _parameter_values(self, overrides: dict[str, dict[str, object]], labels: dict) -> dict[str, dict]:
        """Every instance's parameter values, each checked against its variable's FMI type before any
        slave is initialized (so a bad value stops the run before anything is written)."""
        unknown = sorted(set(overrides) - set(self.slaves))
        if unknown:
            raise SystemDescriptionError(f"parameters for unknown FMU instances {unknown}")
        values = {}
        for spec in self.system.fmus:
            slave, names = self.slaves[spec.name], labels.get(spec.name, {})
            merged = {**spec.parameters, **overrides.get(spec.name, {})}
            values[spec.name] = {
                name: slave.checked_value(name, value, names.get(name)) for name, value in merged.items()
            }
        return values
