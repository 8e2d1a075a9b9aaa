"""Run a scenario: the plant FMU and the estimator FMU through the fmpy master, with the run's files.

Writes, in ``out_dir``:

* ``result.csv``: one row per 1 ms sample (time, true and estimated flowrates, their stds, alarms, NIS,
  convergence, the probe signals and operating point in the record format), flushed after every row, so a
  run stopped part-way keeps what it had;
* ``summary.json``: the scenario, its parameters and the figures of :mod:`oilwatch.scenarios.summary`;
* ``estimates.png``: the plot of :mod:`oilwatch.scenarios.plot`.

SIGINT and SIGTERM are honoured between macro steps, not inside an FMU call (where the FMU would report
them as an error): the run stops with :class:`oilwatch.outputs.interrupts.Interrupted` and result.csv keeps
every step done, in whole rows. summary.json is written last; until then it says the run is not complete.
"""

from __future__ import annotations

import time as wallclock
from contextlib import contextmanager
from pathlib import Path

import numpy as np

from oilwatch.outputs import interrupts, ledger
from oilwatch.outputs.atomic import write_json_atomic

from ..cosim import CsvRecorder, Master
from ..cosim.errors import SystemDescriptionError
from ..cosim.ssp import open_ssp
from . import SAMPLE_PERIOD_S, ScenarioRun
from .fmus import plant_and_estimator
from .summary import summarize

COLUMNS = {
    "plant.q1_ml_min": "q1_true_ml_min",
    "plant.q2_ml_min": "q2_true_ml_min",
    "ekf.q1_est_ml_min": "q1_est_ml_min",
    "ekf.q2_est_ml_min": "q2_est_ml_min",
    "ekf.q1_std_ml_min": "q1_std_ml_min",
    "ekf.q2_std_ml_min": "q2_std_ml_min",
    "ekf.starved1": "starved1",
    "ekf.starved2": "starved2",
    "ekf.nis": "nis",
    "ekf.converged": "converged",
    "ekf.measurement_ok": "measurement_ok",
    **{f"plant.{probe}_um": f"{probe}_um" for probe in ("x1", "y1", "x2", "y2")},
}
"""Recorded variables (``plant``/``ekf`` instance names) -> result.csv column names. The probe columns are the
plant's measured signals in um along each probe's axis, under the record format's names, so that a
result.csv is a record for ``oilwatch estimate`` and ``oilwatch baseline --record``."""
OPERATING_INPUTS = {"speed_hz": "speed_hz", "oil_temperature_c": "oil_temperature_c"}
"""The plant's operating-point inputs recorded under the record format's names, when the plant has them."""
OUTPUT_FILES = ("result.csv", "summary.json", "estimates.png")
"""The files a run writes in its folder (module docstring)."""
ROLES = {"plant": "x1_true_um", "ekf": "q1_est_ml_min"}
"""An output that identifies each role's FMU in an SSP whose instances have other names."""


class _StopBetweenSteps:
    """A recorder wrapper that stops the run after a whole row when SIGINT or SIGTERM was received
    (:func:`oilwatch.outputs.interrupts.checkpoint`), and replaces the files of ``stale`` when the recording
    starts (every FMU initialized): a run that cannot start leaves the previous run's files as they were;
    one that starts leaves nothing of them but a summary.json that says it is running. ``inner`` may be
    set after construction (once the FMUs are loaded), before the recording starts."""

    def __init__(self, inner, stale: tuple[Path, ...] = ()):
        self.inner = inner
        self.stale = stale
        self.last_time_s: float | None = None
        self.started = False

    def start(self, columns):
        self.started = True
        for path in self.stale:
            if path.name == "summary.json":
                write_json_atomic(path, {"completed": False, "status": "running"})
            else:
                path.unlink(missing_ok=True)
        self.inner.start(columns)

    def record(self, time_s, values):
        self.inner.record(time_s, values)
        self.last_time_s = time_s
        interrupts.checkpoint()

    def close(self):
        self.inner.close()


def _partial_summary(out: Path, error: BaseException, last_time_s: float | None) -> None:
    """summary.json of a run that stopped after its recording started (best effort: the disk may be full)."""
    if isinstance(error, KeyboardInterrupt):
        status = f"interrupted ({interrupts.signal_name(error)})"
    else:
        status = f"failed: {error}"
    try:
        write_json_atomic(
            out / "summary.json", {"completed": False, "status": status, "last_time_s": last_time_s}
        )
        ledger.keep("summary", lambda: "summary.json says partial")
    except OSError:
        ledger.keep("summary", lambda: "summary.json could not be updated")


@contextmanager
def scenario_system(fmu_dir: Path | None = None, ssp: Path | None = None):
    """Yield the two-FMU system, from ``fmu_dir`` or an .ssp (its FMUs valid inside the ``with``)."""
    if ssp is not None:
        with open_ssp(ssp) as system:
            yield system
        return
    yield plant_and_estimator(fmu_dir)


def _operating_columns(plant, machine_file: str) -> dict[str, tuple[str, float]]:
    """``{"plant.<input>": (<column>, nominal value)}`` for the :data:`OPERATING_INPUTS` the loaded plant
    FMU (a master's :class:`~oilwatch.cosim.loading.Slave`) has as inputs (the oil temperature only for a
    machine with an oil); the nominal value replaces the input's "the machine's nominal" sentinel (speed 0,
    temperature -300) in result.csv."""
    from oilwatch.models.machine import load_machine

    machine = load_machine(machine_file or None)
    nominal = {"speed_hz": machine.nominal_speed_hz, "oil_temperature_c": machine.nominal_oil_temperature_c}
    inputs = {name for name, variable in plant.variables.items() if variable.causality == "input"}
    return {
        f"plant.{name}": (column, nominal[name])
        for name, column in OPERATING_INPUTS.items()
        if name in inputs and nominal[name] is not None
    }


class _Sentinels:
    """A recorder that writes the last ``len(nominal)`` columns (the operating inputs) with their sentinel
    (speed <= 0, temperature below absolute zero: "the machine's nominal") replaced by the nominal value."""

    def __init__(self, inner, nominal: list[tuple[bool, float]]) -> None:
        self.inner, self.nominal = inner, nominal

    def start(self, columns):
        self.inner.start(columns)

    def record(self, time_s, values):
        if self.nominal:
            values = list(values)
            first = len(values) - len(self.nominal)
            for i, (speed, nominal) in enumerate(self.nominal):
                value = values[first + i]
                if (value <= 0.0) if speed else (value < -273.15):
                    values[first + i] = nominal
        self.inner.record(time_s, values)

    def close(self):
        self.inner.close()


def _roles(slaves: dict, origin: str) -> dict[str, str]:
    """``{"plant": instance, "ekf": instance}`` from the outputs of the FMUs the master loaded (their model
    descriptions are read once, by the master)."""
    roles = {}
    for name, slave in slaves.items():
        outputs = {n for n, v in slave.variables.items() if v.causality == "output"}
        for role, marker in ROLES.items():
            if marker in outputs:
                roles[role] = name
    missing = sorted(set(ROLES) - set(roles))
    if missing:
        raise SystemDescriptionError(
            f"{origin}: no FMU instance with the output {ROLES[missing[0]]!r} (the {missing[0]} role)"
        )
    return roles


def run_scenario(
    run: ScenarioRun,
    out_dir: str | Path,
    fmu_dir: Path | None = None,
    ssp: Path | None = None,
    progress: bool = True,
    plot: bool = True,
    labels: dict[str, dict[str, str]] | None = None,
) -> dict:
    """Simulate ``run`` with the FMUs of ``fmu_dir`` (or the system of ``ssp``), write the run's files in
    ``out_dir`` (module docstring) and return the summary. A failing FMU raises SlaveError, a wrong system
    SystemDescriptionError (an InputError); KeyboardInterrupt leaves result.csv with the steps done.
    labels: per role (``plant``/``ekf``), how the user gave a parameter (``{"plant": {"seed": "--seed"}}``),
    for error messages."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    csv_path = out / "result.csv"
    wall_start = wallclock.perf_counter()
    recorder = None
    try:
        with scenario_system(fmu_dir, ssp) as system:
            recorder = _StopBetweenSteps(None, tuple(out / name for name in OUTPUT_FILES))
            # SIGINT and SIGTERM held from before loading: raised inside an FMU call (the slave is Python in
            # this process) they would surface as an FMU error; the recorder stops the run after a whole row
            with interrupts.held(), Master(system) as master:
                roles = _roles(master.slaves, str(ssp if ssp is not None else fmu_dir))
                parameters = {roles["plant"]: run.plant_parameters(), roles["ekf"]: run.ekf_parameters()}
                # the plant's inputs from the FMU the master loaded (a file it refuses never gets here)
                operating = _operating_columns(master.slaves[roles["plant"]], run.machine_file)
                columns = {**COLUMNS, **{name: column for name, (column, _) in operating.items()}}
                record = [f"{roles[c.split('.')[0]]}.{c.split('.')[1]}" for c in columns]
                rename = dict(zip(record, columns.values(), strict=True))
                nominal = [(name.endswith("speed_hz"), value) for name, (_, value) in operating.items()]
                recorder.inner = _Sentinels(CsvRecorder(csv_path, rename=rename), nominal)
                result = master.run(
                    stop_time=run.duration_s,
                    step_size=SAMPLE_PERIOD_S,
                    start_time=0.0,
                    method="gauss-seidel",
                    order=[roles["plant"], roles["ekf"]],
                    record=record,
                    recorder=recorder,
                    parameters=parameters,
                    progress=progress,
                    labels={roles[role]: names for role, names in (labels or {}).items()},
                    input_signals=run.input_signals(roles),
                )
    except BaseException as error:
        if recorder is not None and recorder.started:
            _partial_summary(out, error, recorder.last_time_s)
        raise
    total_s = wallclock.perf_counter() - wall_start
    columns = read_result(csv_path)
    summary = {
        "scenario": run.scenario.name,
        "title": run.scenario.title,
        "noise_um": run.noise_um,
        **summarize(run, columns),
        "wall_s": round(result.wall_s, 3),
        "setup_s": round(total_s - result.wall_s, 3),
        "realtime_factor": round(result.realtime_factor, 3),
        "duration_s": run.duration_s,
        "seed": run.seed,
        "fault_time_s": run.fault_time_s,
        "fault_duration_s": run.fault_duration_s,
        "transition_start_s": run.transition_start_s,
        "parameters": {"plant": run.plant_parameters(), "ekf": run.ekf_parameters()},
        "method": "gauss-seidel (plant, then estimator), 1 ms macro step",
        "source": str(ssp) if ssp is not None else str(fmu_dir),
        "result_csv": str(csv_path),
    }
    if plot:
        from .plot import plot_estimates

        summary["plot"] = str(plot_estimates(run, columns, summary, out / "estimates.png"))
    summary.update(completed=True, status="completed")
    write_json_atomic(out / "summary.json", summary)  # last: it says the run completed
    return summary


def read_result(path: str | Path) -> dict[str, np.ndarray]:
    """The columns of a result.csv as arrays of shape (n,) by header name (incomplete last line dropped)."""
    lines = Path(path).read_text(encoding="utf-8").splitlines()
    header = lines[0].split(",")
    rows = [line.split(",") for line in lines[1:]]
    rows = [row for row in rows if len(row) == len(header)]
    table = np.array(rows, dtype=float).reshape(len(rows), len(header))
    return {name: table[:, i] for i, name in enumerate(header)}
