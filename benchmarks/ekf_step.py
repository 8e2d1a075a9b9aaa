"""Cost of one EKF step (predict + update) of oilwatch's OilFlowEKF against filterpy's ExtendedKalmanFilter.

Prints the median microseconds per step, the real-time factor at 1 kHz (1000 us / cost) and the speed-up over
the baseline, all measured in the same run, and the OilFlowEKF FMU under fmpy (a plain ``FMU2Slave`` loop:
setReal of the four positions, doStep, getReal of the estimates and stds, getBoolean of the flags). The
baseline is filterpy's ExtendedKalmanFilter driven by the same model's transition and Jacobians with the
full-order size (168 dynamic states + 2 flowrates).

Two model families, each at the reduced and the full size; both filters only see the
:class:`oilwatch.estimator.model.AugmentedModel` protocol:

* synthetic: dense linear rotor-like systems of 30 and 168 states (lightly damped modes between 20 and 480 Hz
  mixed by a random orthogonal change of coordinates), with a transition matrix affine in the flowrates. The
  model costs little, so the figures are the filters' own cost.
* system: the rotor-bearing model of ``oilwatch.models.system`` (Craig-Bampton reduced model on its fine
flowrate
  grid; the full 168-state model on a coarse grid, which changes the accuracy but not the cost of an
  evaluation), when its coefficient table is found (``--table``, default: the machine's table next to the
  machine file). Here the model's own evaluation is part of each step, as it would be in the estimator.

The FMU is ``--fmu`` (default: built into a temporary folder with ``oilwatch.cosim.fmu_build.build_fmus``);
its line needs the
system family, whose reduced-model response feeds it. ``benchmarks/ekf_fmu_step.py`` splits the FMU's step
into the library step, the shell's Python and the FMI floor (its :class:`FmuLoop` is the loop timed here).

Under ramps (issue 13): the estimator on ``oilwatch.models.system.operating_model.OperatingAugmentedModel``
(reduced, following the measured speed and oil temperature) on the plant's record (full-order Newmark plant on
the dimensionless table, 80/90 % flow) while the speed ramps up and down between 72 and 78 Hz at 1 Hz/s and
the oil warms by 10 degC per minute for ``--ramp-s`` (60 s), fed the same speed and temperature, every step a
new operating point (its re-centrings included in the mean); beside it the same filter on the reference grid
at constant conditions, and the FMU with ``bearing_table = 1`` fed the same record through its ``speed_hz``
and ``oil_temperature_c`` inputs. The plant's record is computed once (minutes) and cached.

Latency (``--latency``, or with the ramp rows): ``benchmarks/ekf_step_latency.py``, the per-step CPU time of
the row with the viscosity factors estimated.

Beside them (library rows): the reference grid with the four probe-offset states of ``oilwatch estimate``
(per step, and through ``OilFlowEKF.run_batch`` per 1000 samples), and with the unbalance estimated too.

Here: the synthetic and system families against filterpy and the headline; the FMU loop is
``benchmarks/ekf_fmu_loop.py``, the ramp and nuisance rows ``benchmarks/ekf_step_ramps.py``, the rows' clock
``benchmarks/step_timing.py``.

Usage: ``OPENBLAS_NUM_THREADS=1 python benchmarks/ekf_step.py [--steps 3000] [--repeats 5] [--table JSON]
[--fmu OilFlowEKF.fmu] [--only-ramps [--library-only]] [--ramp-s 60] [--cpu] [--latency]``
"""

from __future__ import annotations

import argparse
import os
import tempfile

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np
from ekf_fmu_loop import bare_fmu, ekf_fmu, time_fmu
from ekf_step_ramps import operating_rows
from filterpy.kalman import ExtendedKalmanFilter
from step_timing import time_per_step, use_process_time

from oilwatch.estimator.ekf import OilFlowEKF
from oilwatch.estimator.ekf_config import EKFConfig
from oilwatch.models.machine import load_machine
from oilwatch.models.system.augmented import GridAugmentedModel
from oilwatch.models.system.factory import flowrate_table_path, load_system

_TURBINE = load_machine()
SPEED_HZ = _TURBINE.nominal_speed_hz
NOMINAL_FLOWRATE_M3_S = _TURBINE.shared_nominal_flowrate_m3_s("benchmarks/ekf_step.py")
"""The synthetic models run at the bundled turbine's speed and nominal flowrate."""


class SyntheticRotorModel:
    """A dense linear model with the AugmentedModel interface: ``s+ = A(q) s + G w_k``,
    ``A(q) = A0 + sum_i (q_i / q_nom - 1) A_i``."""

    def __init__(self, n_states: int, dt_s: float = 1.0e-3, seed: int = 0) -> None:
        rng = np.random.default_rng(seed)
        self.n_states = n_states
        self.dt_s = dt_s
        self.nominal_flowrates_m3_s = np.full(2, NOMINAL_FLOWRATE_M3_S)
        self.speed_hz = SPEED_HZ
        self.bearing_flowrate_bounds_m3_s = np.array([(0.45, 1.4), (0.45, 1.4)]) * NOMINAL_FLOWRATE_M3_S
        modes = n_states // 2
        base = np.zeros((n_states, n_states))
        for j, frequency in enumerate(np.linspace(20.0, 480.0, modes)):
            radius = np.exp(-0.05 * 2 * np.pi * frequency * dt_s)
            angle = 2 * np.pi * frequency * dt_s
            c, s = radius * np.cos(angle), radius * np.sin(angle)
            base[2 * j : 2 * j + 2, 2 * j : 2 * j + 2] = [[c, -s], [s, c]]
        mixing, _ = np.linalg.qr(rng.standard_normal((n_states, n_states)))
        self._a0 = mixing @ base @ mixing.T
        self._a_q = [1e-4 * rng.standard_normal((n_states, n_states)) for _ in range(2)]
        self._inputs = 1e-6 * rng.standard_normal((n_states, 3))
        self.output_matrix = rng.standard_normal((4, n_states))
        self.velocity_output_matrix = 300.0 * rng.standard_normal((4, n_states))
        self._omega_dt = 2 * np.pi * SPEED_HZ * dt_s
        self._a = np.empty_like(self._a0)
        self._flow_jacobian = np.empty((n_states, 2))

    def transition(self, state, flowrate_m3_s, step):
        r = np.asarray(flowrate_m3_s) / NOMINAL_FLOWRATE_M3_S - 1.0
        np.copyto(self._a, self._a0)
        self._a += r[0] * self._a_q[0]
        self._a += r[1] * self._a_q[1]
        phase = self._omega_dt * step
        next_state = self._a @ state + self._inputs @ np.array([1.0, np.cos(phase), np.sin(phase)])
        self._flow_jacobian[:, 0] = self._a_q[0] @ state / NOMINAL_FLOWRATE_M3_S
        self._flow_jacobian[:, 1] = self._a_q[1] @ state / NOMINAL_FLOWRATE_M3_S
        return next_state, self._a, self._flow_jacobian

    def physical_covariance(self, displacement_std_m, velocity_std_m_s):
        half = self.n_states // 2
        return np.diag([displacement_std_m**2] * half + [velocity_std_m_s**2] * half)


def measurements(model: SyntheticRotorModel, steps: int, seed: int = 1) -> np.ndarray:
    """A (steps, 4) record from the model's own response at 80 % flow, with 1 um noise."""
    rng = np.random.default_rng(seed)
    state = np.zeros(model.n_states)
    q = np.full(2, 0.8 * NOMINAL_FLOWRATE_M3_S)
    record = np.empty((steps, 4))
    for k in range(steps):
        record[k] = model.output_matrix @ state + 1e-6 * rng.standard_normal(4)
        state = model.transition(state, q, k)[0]
    return record


class FilterpyBaseline:
    """filterpy's ExtendedKalmanFilter on the augmented state [s; q/q_nom], displacement channels only."""

    def __init__(self, model: SyntheticRotorModel, config: EKFConfig) -> None:
        n = model.n_states
        self.model = model
        self.n = n
        ekf = ExtendedKalmanFilter(dim_x=n + 2, dim_z=4)
        ekf.x = np.zeros(n + 2)
        ekf.x[n:] = 1.0
        ekf.P = np.eye(n + 2) * 1e-8
        ekf.Q = np.zeros((n + 2, n + 2))
        ekf.Q[:n, :n] = model.physical_covariance(
            config.displacement_process_std_m, config.velocity_process_std_m_s
        )
        ekf.Q[n:, n:] = (config.flowrate_process_std_m3_s / NOMINAL_FLOWRATE_M3_S) ** 2 * np.eye(2)
        ekf.R = config.noise_std_m**2 * np.eye(4)
        self.observation = np.zeros((4, n + 2))
        self.observation[:, :n] = model.output_matrix
        self.ekf = ekf
        self.k = 0

    def step(self, z: np.ndarray) -> None:
        ekf, n = self.ekf, self.n
        if self.k > 0:
            q = ekf.x[n:] * NOMINAL_FLOWRATE_M3_S
            next_state, state_jac, flow_jac = self.model.transition(ekf.x[:n], q, self.k - 1)
            jacobian = np.eye(n + 2)
            jacobian[:n, :n] = state_jac
            jacobian[:n, n:] = flow_jac * NOMINAL_FLOWRATE_M3_S
            ekf.F = jacobian
            ekf.x = np.concatenate([next_state, ekf.x[n:]])
            ekf.P = ekf.F @ ekf.P @ ekf.F.T + ekf.Q
        observation = self.observation
        ekf.update(z, lambda _x: observation, lambda x: observation @ x)
        self.k += 1


class _ModelOnly:
    """Calls only the model's transition, to separate the model's cost from the filter's."""

    def __init__(self, model) -> None:
        self.model = model
        self.state = np.zeros(model.n_states)
        self.flowrate = np.full(2, 0.8 * NOMINAL_FLOWRATE_M3_S)
        self.k = 0

    def step(self, _z: np.ndarray) -> None:
        self.model.transition(self.state, self.flowrate, self.k)
        self.k += 1


def make_models(table: str | None) -> dict[str, dict[str, object]]:
    """Model families to time, each {"reduced": model, "full": model}."""
    families: dict[str, dict[str, object]] = {
        "synthetic": {"reduced": SyntheticRotorModel(30), "full": SyntheticRotorModel(168)}
    }
    turbine = load_machine()
    path = table if table is not None else flowrate_table_path(turbine, turbine.nominal_speed_hz)
    if os.path.exists(path):
        families["system"] = {
            "reduced": GridAugmentedModel(load_system(reduced=True, table_path=path)),
            "full": GridAugmentedModel(load_system(reduced=False, table_path=path), subdivisions=1),
        }
    else:
        print(f"no coefficient table at {path}: timing the synthetic models only\n")
    return families


def print_rows(rows) -> None:
    """The table of median and minimum cost per step and the real-time factor at 1 kHz."""
    print(f"{'step (model included unless alone)':<70} {'median us':>10} {'min us':>8} {'RTF@1kHz':>9}")
    for label, (median, best) in rows:
        print(f"{label:<70} {median:10.1f} {best:8.1f} {1000.0 / median:9.1f}")
    print("(RTF from the median; machine shared, so the minimum is the better cost estimate)\n")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=3000)
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--table", default=None, help="bearing coefficient table JSON for the system model")
    parser.add_argument("--fmu", default=None, help="OilFlowEKF.fmu to time (default: build one)")
    parser.add_argument("--only-ramps", action="store_true", help="only the rows under speed/oil ramps")
    parser.add_argument("--ramp-s", type=float, default=60.0, help="length of the plant's ramp record [s]")
    parser.add_argument(
        "--library-only", action="store_true", help="with --only-ramps: the library rows, no FMU built"
    )
    parser.add_argument("--cpu", action="store_true", help="library rows in process CPU time, not wall time")
    parser.add_argument("--latency", action="store_true", help="only the per-step latency figures")
    args = parser.parse_args()
    if args.latency:
        from ekf_step_latency import latency_rows

        latency_rows(args)
        return
    if args.cpu:
        use_process_time()
        print("library rows in process CPU time (the FMU rows in wall time)\n")
    if args.only_ramps:
        record = measurements(GridAugmentedModel(load_system(reduced=True)), args.steps)
        print_rows(operating_rows(args, record))
        from ekf_step_latency import latency_rows

        latency_rows(args)
        return

    rows = []
    headline = []
    families = make_models(args.table)
    for family, models in families.items():
        costs = {}
        for size, model in models.items():
            label = f"{family} {size} ({model.n_states} states)"
            record = measurements(model, args.steps)
            cost = time_per_step(lambda m=model: _ModelOnly(m), record, args.repeats)
            rows.append((f"model transition alone, {label}", cost))
            for mode in ("displacement-only", "paper"):
                config = EKFConfig(velocity_noise=mode, gate_tail_probability=0.0)
                OilFlowEKF(model, config).run(record[:10])  # compile the kernels outside the timing
                cost = time_per_step(lambda m=model, c=config: OilFlowEKF(m, c), record, args.repeats)
                rows.append((f"OilFlowEKF, {label}, {mode}", cost))
                costs[(size, mode)] = cost[0]
            steps = min(args.steps, 1000)
            cost = time_per_step(
                lambda m=model: FilterpyBaseline(m, EKFConfig()), record[:steps], args.repeats
            )
            rows.append((f"filterpy EKF, {label}, 4 channels", cost))
            costs[(size, "filterpy")] = cost[0]
        if family == "system":
            with tempfile.TemporaryDirectory(prefix="oilwatch_bench_") as folder:
                record = measurements(models["reduced"], args.steps)
                # built before any FMU runs here: a running FMU's bundled pythonfmu would stand in for the
                # builder's own, which then finds no slave class in the script
                bare = bare_fmu(folder)
                cost = time_fmu(ekf_fmu(args.fmu, folder), record, args.repeats)
                rows.append(("OilFlowEKF FMU under fmpy, with setReal/getReal, 4 channels", cost))
                costs[("fmu", "fmpy")] = cost[0]
                cost = time_fmu(bare, record, args.repeats)
                rows.append(("bare FMU under fmpy (doStep does nothing), same calls", cost))
        headline.append((family, costs))

    rows += (
        operating_rows(args, measurements(families["system"]["reduced"], args.steps))
        if ("system" in families)
        else []
    )
    print_rows(rows)
    for family, costs in headline:
        baseline = costs[("full", "filterpy")]
        ours = costs[("reduced", "displacement-only")]
        same = costs[("full", "displacement-only")]
        print(
            f"{family}: filterpy on the full model {baseline:.0f} us/step; OilFlowEKF on the reduced model "
            f"{ours:.1f} us/step: {baseline / ours:.1f}x faster (same full model: {baseline / same:.1f}x)"
        )
        if ("fmu", "fmpy") in costs:
            fmu = costs[("fmu", "fmpy")]
            print(
                f"{family}: the OilFlowEKF FMU under fmpy {fmu:.1f} us/step (real-time factor "
                f"{1000.0 / fmu:.1f} at 1 kHz), {fmu / ours:.1f}x the library's cost, {baseline / fmu:.1f}x "
                "faster than filterpy on the full model"
            )


if __name__ == "__main__":
    main()
