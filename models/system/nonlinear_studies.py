"""Direct simulations with the transient films: unbalance orbits, whirl growth rates, a starvation transient.

Each study runs :class:`oilwatch.models.system.nonlinear.NonlinearRotorBearing` and reduces its record to the
figures the linear models are judged by:

* ``unbalance_orbits``: the 1x orbit at the bearings (least-squares harmonic fit over the last
  periods, after the start transient has decayed) against the linear orbit with each bearing
  coefficient model, all linearized about the same nonlinear static equilibrium;
* ``whirl_growth_rate``: from the static equilibrium kicked by a small journal velocity, the growth
  (> 0) or decay rate of the subsynchronous whirl, fitted to the per-period amplitudes once the
  other modes have died out; a sign change over speed brackets the instability threshold;
* ``starvation_transient``: a sudden supply drop with the unbalance on; how long the film content,
  the side leakage and the mean journal position take to settle.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from ..bearing.dynamic import FilmImpedance
from ..bearing.equilibrium import coefficients_at
from ..bearing.film import solve_film
from ..bearing.grid import Mesh
from ..bearing.supply import SupplyFlow
from ..machine import Machine
from .nonlinear import NonlinearRotorBearing, block_diagonal

COEFFICIENT_MODELS = ("full-film", "everywhere", "frequency-dependent")
SAMPLE_STEPS = 64


def harmonic_fit(
    time_s: np.ndarray, signals: np.ndarray, omega_rad_s: float
) -> tuple[np.ndarray, np.ndarray]:
    """Complex amplitudes X and means of ``signals`` (m, k) ~ mean + Re(X exp(i omega t)) (least squares)."""
    basis = np.column_stack(
        [np.cos(omega_rad_s * time_s), np.sin(omega_rad_s * time_s), np.ones(time_s.size)]
    )
    c = np.linalg.lstsq(basis, signals, rcond=None)[0]
    return c[0] - 1j * c[1], c[2]


def linear_orbit(sim: NonlinearRotorBearing, coefficients) -> np.ndarray:
    """Bearing (x1, y1, x2, y2) complex 1x amplitudes of the reduced rotor on linear films ``[(K, C)]``."""
    rot = sim.rotor
    w = sim.omega
    kb = block_diagonal([k for k, _ in coefficients])
    cb = block_diagonal([c for _, c in coefficients])
    p = sim.selector
    dynamic = rot.stiffness + p.T @ kb @ p - w * w * rot.mass + 1j * w * (rot.damping + p.T @ cb @ p)
    return p @ np.linalg.solve(dynamic, rot.unbalance)


def _film_models(sim: NonlinearRotorBearing, positions, flowrate_m3_s: float) -> dict:
    """(K, C) per bearing for each coefficient model, about the journals' nonlinear static positions."""
    supply = SupplyFlow(flowrate_m3_s)
    out = {name: [] for name in COEFFICIENT_MODELS}
    for bearing, eq, e in zip(sim.bearings, sim.equilibria, positions, strict=True):
        film = solve_film(bearing, sim.speed_hz, tuple(e), supply, mesh=sim.mesh, warm_start=eq.film)
        at = type(eq)(
            e,
            eq.eccentricity_ratio,
            eq.attitude_deg,
            film.supply_pressure_pa,
            film.supply_flow_m3_s,
            film.side_leakage_m3_s,
            film.regime,
            0,
            film,
        )
        out["full-film"].append(coefficients_at(bearing, at, sim.speed_hz, supply, sim.mesh))
        out["everywhere"].append(
            coefficients_at(bearing, at, sim.speed_hz, supply, sim.mesh, squeeze="everywhere")
        )
        out["frequency-dependent"].append(FilmImpedance(film, e, sim.speed_hz).coefficients(sim.omega))
    return out


def orbit_setup(
    machine: Machine,
    mesh: Mesh,
    flowrate_m3_s: float,
    steps_per_revolution: int = 64,
    dt_s: float | None = None,
    **options,
):
    """(simulation, static state, start on the frequency-dependent linear orbit, film models) of a run
    with ``steps_per_revolution`` steps per revolution (or the step ``dt_s`` [s]); ``options`` go to
    :class:`NonlinearRotorBearing`."""
    speed = machine.nominal_speed_hz
    h = 1.0 / speed / steps_per_revolution if dt_s is None else dt_s
    sim = NonlinearRotorBearing(machine, speed, mesh, h, reference_flowrate_m3_s=flowrate_m3_s, **options)
    flows = (flowrate_m3_s, flowrate_m3_s)
    static = sim.static_state(flows)
    models = _film_models(sim, (sim.selector @ static.r).reshape(-1, 2), flowrate_m3_s)
    return sim, static, sim.orbit_start(static, models["frequency-dependent"], flows), models


def unbalance_orbits(
    machine: Machine,
    mesh: Mesh,
    flowrate_m3_s: float,
    *,
    steps_per_revolution: int = 64,
    duration_s: float = 0.6,
    fit_periods: int = 10,
    progress: Callable[[int], None] | None = None,
    **options,
) -> dict:
    """Nonlinear 1x orbit at the nominal speed against the linear models (see the module docstring).

    The run starts on the frequency-dependent linear orbit (so that little start transient is left);
    ``settling`` is the largest change of any amplitude [%] between the last two fit windows.
    ``options`` go to :class:`NonlinearRotorBearing` (e.g. the coupling and film tolerances).
    """
    sim, static, start, models = orbit_setup(machine, mesh, flowrate_m3_s, steps_per_revolution, **options)
    speed = sim.speed_hz
    flows = (flowrate_m3_s, flowrate_m3_s)
    linear = {name: linear_orbit(sim, kc) for name, kc in models.items()}
    n = round(duration_s / sim.h)
    _, record = sim.run(start, n, lambda t: flows, progress)
    t = record["time_s"]
    x = record["bearing_positions_m"].reshape(n, -1) - sim.selector @ static.r
    window = fit_periods / speed
    last = t > t[-1] - window
    before = (t > t[-1] - 2 * window) & ~last
    orbit, mean = harmonic_fit(t[last], x[last], sim.omega)
    previous, _ = harmonic_fit(t[before], x[before], sim.omega)
    result = {
        "flowrate_ml_min": flowrate_m3_s * 6e7,
        "channels": ["x1", "y1", "x2", "y2"],
        "nonlinear_amplitude_um": (np.abs(orbit) * 1e6).tolist(),
        "nonlinear_phase_deg": np.angle(orbit, deg=True).tolist(),
        "nonlinear_mean_shift_um": (mean * 1e6).tolist(),
        "settling_pct": float(100.0 * np.max(np.abs(np.abs(orbit) / np.abs(previous) - 1.0))),
        "steps_per_revolution": steps_per_revolution,
        "duration_s": duration_s,
        "position_tolerance_m": sim.tolerance,
        "film_residual_tolerance": sim.films[0].residual_tolerance,
        "sweeps_per_film_step": sim.films[0].sweep_count / n,
        # Bearing positions after SAMPLE_STEPS steps: a short rerun reproduces them (tests).
        "sample_positions_um": (record["bearing_positions_m"][SAMPLE_STEPS - 1].ravel() * 1e6).tolist(),
        "linear": {},
    }
    for name, amplitude in linear.items():
        result["linear"][name] = {
            "amplitude_um": (np.abs(amplitude) * 1e6).tolist(),
            "phase_deg": np.angle(amplitude, deg=True).tolist(),
            "amplitude_error_pct": (100.0 * (np.abs(amplitude) / np.abs(orbit) - 1.0)).tolist(),
            "phase_error_deg": np.angle(amplitude / orbit, deg=True).tolist(),
        }
    return result


def linear_orbits(machine: Machine, mesh: Mesh, flowrate_m3_s: float) -> dict:
    """The linear models' 1x bearing orbits about the nonlinear static equilibrium on ``mesh`` (no time
    stepping: cheap on any mesh, for the mesh convergence of the orbits)."""
    sim, static, _, models = orbit_setup(machine, mesh, flowrate_m3_s)
    out = {
        "flowrate_ml_min": flowrate_m3_s * 6e7,
        "static_position_um": (sim.selector @ static.r * 1e6).tolist(),
    }
    for name, kc in models.items():
        amplitude = linear_orbit(sim, kc)
        out[name] = {
            "amplitude_um": (np.abs(amplitude) * 1e6).tolist(),
            "phase_deg": np.angle(amplitude, deg=True).tolist(),
        }
    return out


def mesh_changes(by_mesh: dict, reference: str) -> dict:
    """Per mesh and model: the largest |amplitude change| [%] and |phase change| [deg] of the orbit against
    the ``reference`` mesh's, and the largest static position change [um]."""
    ref = by_mesh[reference]
    out = {}
    for key, run in by_mesh.items():
        row = {
            "static_position_change_um": float(
                np.abs(np.subtract(run["static_position_um"], ref["static_position_um"])).max()
            )
        }
        for name in COEFFICIENT_MODELS:
            a, b = np.array(run[name]["amplitude_um"]), np.array(ref[name]["amplitude_um"])
            phase = (np.array(run[name]["phase_deg"]) - ref[name]["phase_deg"] + 180.0) % 360.0 - 180.0
            row[name] = {
                "max_amplitude_change_pct": float(100.0 * np.abs(a / b - 1.0).max()),
                "max_phase_change_deg": float(np.abs(phase).max()),
            }
        out[key] = row
    return out


def whirl_growth_rate(
    machine: Machine,
    mesh: Mesh,
    speed_hz: float,
    flowrate_m3_s: float,
    *,
    dt_s: float = 2e-4,
    duration_s: float = 0.4,
    kick_m_s: float = 2e-4,
    progress: Callable[[int], None] | None = None,
) -> dict:
    """Growth rate [1/s] of the free subsynchronous whirl about the static equilibrium at ``speed_hz``.

    Both journals get a vertical velocity ``kick_m_s``; the whirl frequency is the spectral peak of
    the second half; its per-period amplitudes over the second half give the rate (log-linear fit).
    """
    sim = NonlinearRotorBearing(
        machine, speed_hz, mesh, dt_s, unbalance=False, reference_flowrate_m3_s=flowrate_m3_s
    )
    flows = (flowrate_m3_s, flowrate_m3_s)
    state = sim.static_state(flows)
    equilibrium = sim.selector @ state.r
    kick = np.zeros(sim.selector.shape[0])
    kick[1::2] = kick_m_s
    state.v = np.linalg.lstsq(sim.selector, kick, rcond=None)[0]
    n = round(duration_s / dt_s)
    _, record = sim.run(state, n, lambda t: flows, progress)
    t = record["time_s"]
    x = record["bearing_positions_m"].reshape(n, -1) - equilibrium
    half = t > 0.5 * t[-1]
    spectrum = np.abs(np.fft.rfft(x[half] * np.hanning(half.sum())[:, None], n=16 * half.sum(), axis=0)).sum(
        1
    )
    freqs = np.fft.rfftfreq(16 * half.sum(), dt_s)
    whirl_hz = float(freqs[np.argmax(spectrum)])
    period = 1.0 / whirl_hz
    edges = np.arange(0.5 * t[-1], t[-1] - period + 1e-12, period)
    centres, amplitudes = [], []
    for a in edges:
        sel = (t >= a) & (t < a + period)
        amp, _ = harmonic_fit(t[sel], x[sel], 2.0 * np.pi * whirl_hz)
        centres.append(a + 0.5 * period)
        amplitudes.append(np.linalg.norm(amp))
    rate, _ = np.polyfit(np.array(centres), np.log(amplitudes), 1)
    return {
        "speed_hz": float(speed_hz),
        "growth_rate_1_s": float(rate),
        "whirl_frequency_hz": whirl_hz,
        "log_decrement": float(-rate / whirl_hz),
        "final_amplitude_um": float(amplitudes[-1] * 1e6),
        "dt_s": dt_s,
        "duration_s": duration_s,
    }


def starvation_transient(
    machine: Machine,
    mesh: Mesh,
    from_m3_s: float,
    to_m3_s: float,
    *,
    steps_per_revolution: int = 64,
    before_s: float = 0.05,
    after_s: float = 0.5,
    progress: Callable[[int], None] | None = None,
) -> dict:
    """A sudden supply drop at ``before_s`` on the unbalanced rotor: settling times [s] (98 % of the change).

    Film content and side leakage of bearing 1 and its 1x-averaged (one revolution) mean position.
    """
    speed = machine.nominal_speed_hz
    sim = NonlinearRotorBearing(
        machine, speed, mesh, 1.0 / speed / steps_per_revolution, reference_flowrate_m3_s=from_m3_s
    )
    state = sim.static_state((from_m3_s, from_m3_s))
    flows = lambda t: (from_m3_s, from_m3_s) if t <= before_s + 1e-12 else (to_m3_s, to_m3_s)  # noqa: E731
    start = sim.orbit_start(
        state,
        _film_models(sim, (sim.selector @ state.r).reshape(-1, 2), from_m3_s)["frequency-dependent"],
        (from_m3_s, from_m3_s),
    )
    n = round((before_s + after_s) / sim.h)
    _, record = sim.run(start, n, flows, progress)
    return settling_times(record, before_s, steps_per_revolution, from_m3_s, to_m3_s)


def settling_times(record: dict, drop_time_s: float, per_revolution: int, from_m3_s: float, to_m3_s: float):
    """Settling times [s] after the drop of bearing 1's film content, side leakage and mean position.

    Each signal is averaged over one revolution (a moving mean: the 1x orbit ripples all three);
    settled = within 2 % of the change from its final value (the last revolution's mean; the supply
    for the leakage) for good. The record (every 4th step) is kept for plots.
    """
    t = record["time_s"] - drop_time_s
    kernel = np.ones(per_revolution) / per_revolution
    t_mean = t[per_revolution - 1 :]

    def averaged(values):
        return np.convolve(values, kernel, mode="valid")

    def settling(values, final):
        initial = values[np.searchsorted(t_mean, 0.0) - 1]
        outside = np.abs(values - final) > 0.02 * abs(final - initial)
        late = np.flatnonzero(outside & (t_mean >= 0.0))
        return float(t_mean[late[-1]]) if late.size else 0.0

    content = averaged(record["content_m3"][:, 0])
    leak = averaged(record["side_leakage_m3_s"][:, 0])
    mean_y = averaged(record["bearing_positions_m"][:, 0, 1])
    last = slice(-per_revolution, None)
    return {
        "from_ml_min": from_m3_s * 6e7,
        "to_ml_min": to_m3_s * 6e7,
        "settling_time_content_s": settling(content, content[last].mean()),
        "settling_time_leakage_s": settling(leak, to_m3_s),
        "settling_time_mean_position_s": settling(mean_y, mean_y[last].mean()),
        "content_change_mm3": float((content[last].mean() - content[np.searchsorted(t_mean, 0.0) - 1]) * 1e9),
        "mean_y_shift_um": float((mean_y[last].mean() - mean_y[np.searchsorted(t_mean, 0.0) - 1]) * 1e6),
        "final_leakage_ml_min": float(leak[last].mean() * 6e7),
        "record": {
            "time_s": t[::4].tolist(),
            "content_mm3": (record["content_m3"][::4, 0] * 1e9).tolist(),
            "side_leakage_ml_min": (record["side_leakage_m3_s"][::4, 0] * 6e7).tolist(),
            "y1_um": (record["bearing_positions_m"][::4, 0, 1] * 1e6).tolist(),
        },
    }
