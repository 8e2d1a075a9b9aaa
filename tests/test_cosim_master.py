"""The fmpy-based master (oilwatch.cosim.master) on the toy FMUs, each test in a fresh process."""

from __future__ import annotations

import pytest
from fixtures.fmu_subprocess import run_json

SYSTEM = """
import numpy as np
from oilwatch.cosim import (Connection, CsvRecorder, FmuSpec, Master, MemoryRecorder, SlaveError,
                            SystemDescription, SystemDescriptionError)
PLANT, FILT = {plant!r}, {filt!r}
def system(plant=None, filt=None, connections=None):
    return SystemDescription(
        [FmuSpec("plant", PLANT, plant or {{}}), FmuSpec("filt", FILT, filt or {{}})],
        connections=connections)
"""


def _run(toys, body: str):
    prelude = SYSTEM.format(plant=str(toys / "ToyPlant.fmu"), filt=str(toys / "ToyFilter.fmu"))
    return run_json(prelude + body)


def test_jacobi_lags_gauss_seidel_by_exactly_one_step_and_reset_reproduces(toys):
    result = _run(
        toys,
        """
rec = ["plant.y_um", "filt.u_seen_um", "filt.yf_um"]
with Master(system({"noise_um": 0.3, "seed": 5}, {"alpha": 0.3})) as master:
    gs = master.run(stop_time=0.2, step_size=1e-3, record=rec).recorder.arrays()
    jac = master.run(stop_time=0.2, step_size=1e-3, record=rec, method="jacobi").recorder.arrays()
    again = master.run(stop_time=0.2, step_size=1e-3, record=rec).recorder.arrays()
y = gs["plant.y_um"]
# Gauss-Seidel: the filter's input over step k is the plant output at t_(k+1);
# Jacobi: the plant output at t_k.
filtered_jacobi = [0.0]
for u in y[:-1]:
    filtered_jacobi.append(filtered_jacobi[-1] + 0.3 * (u - filtered_jacobi[-1]))
result = {
    "gs_sees_end": bool(np.array_equal(gs["filt.u_seen_um"][1:], y[1:])),
    "jacobi_sees_start": bool(np.array_equal(jac["filt.u_seen_um"][1:], y[:-1])),
    "jacobi_filter": bool(np.array_equal(jac["filt.yf_um"], np.array(filtered_jacobi))),
    "plant_same": bool(np.array_equal(jac["plant.y_um"], y)),
    "reset_same": bool(all(np.array_equal(gs[k], again[k]) for k in gs)),
    "times": gs["time"][:3].tolist(), "n": len(y),
}
""",
    )
    assert result["gs_sees_end"] and result["jacobi_sees_start"]
    assert result["jacobi_filter"] and result["plant_same"]
    assert result["reset_same"]
    assert result["n"] == 201
    assert result["times"] == pytest.approx([0.0, 1e-3, 2e-3], abs=1e-15)


def test_gauss_seidel_order_is_respected(toys):
    result = _run(
        toys,
        """
rec = ["plant.y_um", "filt.u_seen_um"]
with Master(system()) as master:
    a = master.run(stop_time=0.01, step_size=1e-3, record=rec, order=["filt", "plant"])
a = a.recorder.arrays()
result = {"lagged": bool(np.array_equal(a["filt.u_seen_um"][1:], a["plant.y_um"][:-1]))}
""",
    )
    assert result["lagged"]


def test_recorders_csv_rows_every_n_steps_and_callable(toys, tmp_path):
    csv_path = tmp_path / "out" / "rows.csv"
    result = _run(
        toys,
        f"""
seen = []
with Master(system()) as master:
    master.run(stop_time=0.1, step_size=1e-3, record=["plant.y_true_um", "plant.above_mid"],
               recorder=CsvRecorder({str(csv_path)!r}, rename={{"plant.y_true_um": "y"}}),
               record_every=10)
    master.run(stop_time=0.003, step_size=1e-3, record=["filt.yf_um"],
               recorder=lambda t, values: seen.append([t, *values]))
result = {{"seen": seen}}
""",
    )
    lines = csv_path.read_text().splitlines()
    assert lines[0] == "time_s,y,plant.above_mid"
    assert len(lines) == 1 + 11
    assert float(lines[-1].split(",")[0]) == pytest.approx(0.1)
    assert [row[0] for row in result["seen"]] == pytest.approx([0.0, 1e-3, 2e-3, 3e-3])


def test_ctrl_c_keeps_the_rows_already_written(toys, tmp_path):
    csv_path = tmp_path / "rows.csv"
    result = _run(
        toys,
        f"""
class Interrupting(CsvRecorder):
    # Presses Ctrl-C right after the 50th row.

    rows = 0

    def record(self, time, values):
        super().record(time, values)
        self.rows += 1
        if self.rows == 50:
            raise KeyboardInterrupt

with Master(system()) as master:
    try:
        master.run(stop_time=1.0, step_size=1e-3, recorder=Interrupting({str(csv_path)!r}))
        outcome = "finished"
    except KeyboardInterrupt:
        outcome = "interrupted"
    rerun = master.run(stop_time=0.01, step_size=1e-3).steps
result = {{"outcome": outcome, "rerun": rerun}}
""",
    )
    assert result == {"outcome": "interrupted", "rerun": 10}
    assert len(csv_path.read_text().splitlines()) == 1 + 50


def test_slave_failure_names_instance_call_and_time(toys):
    result = _run(
        toys,
        """
try:
    with Master(system(filt={"fail_above_um": 15.0})) as master:
        master.run(stop_time=1.0, step_size=1e-3)
    error = None
except SlaveError as e:
    error = {"instance": e.instance, "call": e.call, "time": e.time, "text": str(e)}
try:
    with Master(system(plant={"width_s": 0.0})) as master:
        master.run(stop_time=1.0, step_size=1e-3)
except SlaveError as e:
    init_error = str(e)
result = {"error": error, "init_error": init_error}
""",
    )
    error = result["error"]
    # With zero noise the plant output first exceeds 15 um at t = 0.501 s; Gauss-Seidel hands it
    # to the filter in the step that starts at 0.500 s.
    assert error["instance"] == "filt" and error["call"] == "fmi2DoStep"
    assert error["time"] == pytest.approx(0.5, abs=1e-12)
    assert "filt" in error["text"] and "t = 0.5 s" in error["text"]
    assert "above fail_above_um" in error["text"]
    assert "'plant'" in result["init_error"] and "fmi2ExitInitializationMode" in result["init_error"]
    assert "width_s must lie in" in result["init_error"]


def test_bad_system_descriptions_are_clear_input_errors(toys, tmp_path):
    corrupt = tmp_path / "Corrupt.fmu"
    corrupt.write_bytes(b"not a zip")
    result = _run(
        toys,
        f"""
def message(make):
    try:
        make()
    except SystemDescriptionError as e:
        return str(e)
    return None
result = {{
    "connector": message(lambda: Master(system(connections=[
        Connection("plant", "y_um", "filt", "x9_um")]))),
    "causality": message(lambda: Master(system(connections=[
        Connection("filt", "y_um", "plant", "y_um")]))),
    "missing": message(lambda: Master(SystemDescription([FmuSpec("a", "/nonexistent/A.fmu")]))),
    "corrupt": message(lambda: Master(SystemDescription([FmuSpec("a", {str(corrupt)!r})]))),
    "parameter": message(lambda: Master(system(plant={{"no_such": 1.0}}))),
    "step": message(lambda: Master(system()).run(stop_time=1.0, step_size=0.3)),
    "method": message(lambda: Master(system()).run(stop_time=1.0, step_size=0.1, method="x")),
    "ambiguous": message(lambda: Master(SystemDescription(
        [FmuSpec("p1", PLANT), FmuSpec("p2", PLANT), FmuSpec("filt", FILT)]))),
}}
""",
    )
    assert "'filt'" in result["connector"] and "'x9_um'" in result["connector"]
    assert "'y_um'" in result["connector"]  # lists the inputs it does have
    assert "not an output" in result["causality"]
    assert "does not exist" in result["missing"]
    assert "corrupt" in result["corrupt"]
    assert "'no_such'" in result["parameter"]
    assert "multiple" in result["step"]
    assert "method" in result["method"]
    assert "filt.y_um" in result["ambiguous"] and "['p1', 'p2']" in result["ambiguous"]


def test_start_time_reaches_the_slaves(toys):
    result = _run(
        toys,
        """
with Master(system()) as master:
    run = master.run(start_time=0.5, stop_time=0.6, step_size=0.05, record=["plant.y_true_um"])
a = run.recorder.arrays()
result = {"time": a["time"].tolist(), "y": a["plant.y_true_um"].tolist(), "steps": run.steps,
          "simulated": run.simulated_s}
""",
    )
    assert result["time"] == pytest.approx([0.5, 0.55, 0.6])
    # y_true(t_center = 0.5 s) is the sigmoid's midpoint, (10 + 20) / 2 um.
    assert result["y"][0] == 15.0
    assert result["steps"] == 2 and result["simulated"] == pytest.approx(0.1)


def test_two_instances_of_one_fmu_are_independent_and_explicit_connections_work(toys):
    result = _run(
        toys,
        """
system2 = SystemDescription(
    [FmuSpec("p1", PLANT, {"noise_um": 0.5, "seed": 1}),
     FmuSpec("p2", PLANT, {"noise_um": 0.5, "seed": 2}),
     FmuSpec("filt", FILT)],
    connections=[Connection("p2", "y_um", "filt", "y_um")])
with Master(system2) as master:
    a = master.run(stop_time=0.05, step_size=1e-3,
                   record=["p1.y_um", "p2.y_um", "filt.u_seen_um"]).recorder.arrays()
result = {"differ": bool(np.all(a["p1.y_um"] != a["p2.y_um"])),
          "from_p2": bool(np.array_equal(a["filt.u_seen_um"][1:], a["p2.y_um"][1:]))}
""",
    )
    assert result == {"differ": True, "from_p2": True}
