"""Recorded data (issue 15): probe conventions, the anti-alias resampler, the keyphasor, the readers, and a
one-line error for each bad record (or a bridged, reported gap)."""

from __future__ import annotations

import math
import re

import numpy as np
import pytest

from oilwatch.cli import main
from oilwatch.models.validation import InputError
from oilwatch.records import PositionConverter, RecordStream, probe_setup
from oilwatch.records.signal import GridResampler, Keyphasor, anti_alias_taps
from oilwatch.records.writers import write_record

CLEARANCE_M = 120e-6


# ------------------------------------------------------------------------------------------ conventions
def test_api670_gap_voltages_give_the_shaft_position_and_cold_rest_is_the_bottom_of_the_clearance():
    items = ["layout=api670"] + [
        f"{n}.{k}" for n in ("x1", "y1", "x2", "y2") for k in ("unit=V", "rest_gap_v=-10")
    ]
    setup = probe_setup({}, items)
    assert [p.angle_deg for p in setup.probes] == [45.0, 135.0, 45.0, 135.0]
    converter = PositionConverter(setup, (CLEARANCE_M, CLEARANCE_M))
    # at cold rest every probe reads its rest gap: the journal at (0, -c), each bearing's own c
    at_rest = converter.positions_m(np.full((1, 4), -10.0))
    np.testing.assert_allclose(at_rest[0], [0.0, -CLEARANCE_M, 0.0, -CLEARANCE_M], atol=1e-12)
    wider = PositionConverter(setup, (CLEARANCE_M, 1.5 * CLEARANCE_M)).positions_m(np.full((1, 4), -10.0))
    np.testing.assert_allclose(wider[0], [0.0, -CLEARANCE_M, 0.0, -1.5 * CLEARANCE_M], atol=1e-12)
    # the shaft 20 um up and 10 um right of the bearing centre: each probe sees its projection; moving
    # towards a probe shrinks its gap, so its (negative) voltage rises by 7.87 V/mm
    x, y = 10e-6, 20e-6
    volts = []
    for angle in (45.0, 135.0):
        a = math.radians(angle)
        u, u_rest = x * math.cos(a) + y * math.sin(a), -CLEARANCE_M * math.sin(a)
        volts.append(-10.0 + 7870.0 * (u - u_rest))
    position = converter.positions_m(np.array([volts + volts]))
    np.testing.assert_allclose(position[0], [x, y, x, y], atol=1e-12)
    assert volts[0] > -10.0  # moved towards the X probe


def test_a_missing_reading_blanks_only_the_coordinates_it_enters():
    readings = np.array([[1.0, 2.0, 3.0, np.nan]])
    along_axes = PositionConverter(probe_setup(), (CLEARANCE_M, CLEARANCE_M)).positions_m(readings)
    np.testing.assert_array_equal(np.isnan(along_axes[0]), [False, False, False, True])
    inclined = PositionConverter(probe_setup({"layout": "api670"}), (CLEARANCE_M, CLEARANCE_M)).positions_m(
        readings
    )
    np.testing.assert_array_equal(np.isnan(inclined[0]), [False, False, True, True])


def test_square_probe_pairs_at_one_angle_feed_the_estimator_along_their_axes_as_the_fmu():
    """API 670 (or any square pairs at one angle): the estimator takes the readings along the probes' axes
    with EKFConfig.probe_angle_deg = the X probes' angle, as the estimator FMU does (the innovation gate and
    the fault checks are per probe: fed (x, y), a gap-voltage record alarmed 33 ms after the FMU on the same
    samples); any other mounting gives (x, y) positions."""
    from oilwatch.estimator.measurement import probe_rotation

    api670 = PositionConverter(probe_setup({"layout": "api670"}), (CLEARANCE_M, CLEARANCE_M))
    assert api670.pair_angle_deg == 45.0
    assert PositionConverter(probe_setup(), (CLEARANCE_M, CLEARANCE_M)).pair_angle_deg == 0.0
    odd = probe_setup({}, ["x1.angle_deg=30", "y1.angle_deg=120", "x2.angle_deg=45", "y2.angle_deg=135"])
    assert PositionConverter(odd, (CLEARANCE_M, CLEARANCE_M)).pair_angle_deg is None
    not_square = probe_setup({}, ["y1.angle_deg=100"])
    assert PositionConverter(not_square, (CLEARANCE_M, CLEARANCE_M)).pair_angle_deg is None
    positions = np.array([[10e-6, 20e-6, -5e-6, 7e-6]])
    along = api670.along_axis_m(api670.readings(positions))
    np.testing.assert_allclose(along, positions @ probe_rotation(math.radians(45.0)).T, atol=1e-15)
    np.testing.assert_allclose(api670.positions_from_axes_m(along), positions, atol=1e-15)


def test_probe_keys_from_the_machine_file_are_checked_and_overridden_on_the_command_line():
    setup = probe_setup({"x1": {"column": "ch0"}, "noise_um": 2.0}, ["x1.column=ch9", "y2.angle_deg=80"])
    assert setup.probe("x1").column == "ch9" and setup.noise_um == 2.0 and setup.probe("y2").angle_deg == 80.0
    assert probe_setup({"offset_prior_std_um": 25.0}).extra == {"offset_prior_std_um": 25.0}  # issue 14's
    for table, text in (
        ({"x1": {"colour": "red"}}, "probes.x1.colour: unknown key"),
        ({"x1": {"unit": "mm"}}, "probes.x1.unit must be one of um, V"),
        ({"x1": {"unit": "V"}}, "probes.x1.rest_gap_v is required"),
        ({"x1": {"unit": "V", "rest_gap_v": 3.0}}, "gap voltage is negative"),
        ({"y1": {"angle_deg": 5.0}}, "at least 10 deg from parallel"),
        ({"layout": "api"}, "probes.layout must be one of"),
        ({"speed": 1}, "probes.speed: unknown key"),
    ):
        with pytest.raises(InputError, match=text):
            probe_setup(table)


# ------------------------------------------------------------------------------------------- resampling
def _sine(t):
    return 12.0 + 2.5 * np.cos(2 * np.pi * 75.0 * t + 0.3) + 0.4 * np.sin(2 * np.pi * 150.0 * t)


def _resample(rate, t, values, chunk):
    resampler = GridResampler(rate, 1e-3, np.array([True, False]))
    ks, out = [], []
    for start in range(0, t.size, chunk):
        k, v = resampler.push(t[start : start + chunk], values[start : start + chunk])
        ks.append(k)
        out.append(v)
    return np.concatenate(ks), np.vstack(out), resampler


def test_anti_alias_resampling_keeps_the_1x_and_static_position_removes_aliases_and_ignores_chunking():
    rate = 5000.0
    t = np.arange(1, 15001) / rate
    alias = 0.8 * np.cos(2 * np.pi * 1150.0 * t)  # would fold onto 150 Hz at 1 kHz
    values = np.column_stack([_sine(t) + alias, t])
    k, out, resampler = _resample(rate, t, values, 4096)
    assert np.all(np.diff(k) == 1) and k[0] == 1
    ok = k > 200  # after the filter's start
    assert np.abs(out[ok, 0] - _sine(k[ok] * 1e-3)).max() < 2e-3  # 1x, 2x and DC kept, alias gone
    np.testing.assert_allclose(out[:, 1], k * 1e-3, atol=1e-12)  # the unfiltered column: delay compensated
    assert anti_alias_taps(rate, 1000.0).sum() == pytest.approx(1.0, abs=1e-12)
    k2, out2, _ = _resample(rate, t, values, 777)
    np.testing.assert_array_equal(k, k2)
    np.testing.assert_allclose(out, out2, rtol=0, atol=1e-12)
    # a missing sample spoils only the outputs whose window holds it
    values[7000, 0] = np.nan
    _, out3, _ = _resample(rate, t, values, 4096)
    bad = np.flatnonzero(~np.isfinite(out3[:, 0]))
    assert 0 < bad.size <= math.ceil(resampler.taps.size / 5) + 1


def test_a_record_at_the_grid_rate_passes_through_unchanged_and_a_slower_one_is_refused():
    t = np.arange(1, 2001) * 1e-3
    values = np.column_stack([_sine(t), t])
    _k, out, _ = _resample(1000.0, t, values, 300)
    np.testing.assert_array_equal(out[:, 0], values[:, 0])
    with pytest.raises(InputError, match="below the estimator's 1000 Hz"):
        GridResampler(500.0, 1e-3, np.array([True]))


def test_keyphasor_pulses_are_found_between_samples_and_give_the_speed():
    import sys
    from pathlib import Path

    sys.path.insert(0, str(Path(__file__).parent))
    from fixtures.plant_records import keyphasor

    t = np.arange(0, 20000) / 5000.0
    volts = keyphasor(t, angle_deg=40.0)
    detector = Keyphasor("falling", None)
    pulses = np.concatenate(
        [detector.push(t[i : i + 3000], volts[i : i + 3000]) for i in range(0, t.size, 3000)]
    )
    expected = (np.arange(pulses.size) + 40.0 / 360.0) / 75.0
    assert pulses.size == 300
    # a 0.4 ms edge sampled at 0.2 ms: the interpolated crossing is within 8.5 us (0.23 deg at 75 Hz)
    assert np.abs(pulses - expected).max() < 1e-5
    np.testing.assert_allclose(detector.speed_hz(t[-10:]), 75.0, rtol=2e-4)


# -------------------------------------------------------------------------------------------- bad records
def _csv(tmp_path, rows, header="time_s,x1_um,y1_um,x2_um,y2_um", name="rec.csv"):
    path = tmp_path / name
    path.write_text(header + "\n" + "\n".join(rows) + "\n")
    return path


def _good_rows(n=50, start=1, dt=1e-3, extra=""):
    return [f"{(start + i) * dt:.6f},{10 + math.sin(i)},{-12 + math.cos(i)},9.5,-11{extra}" for i in range(n)]


@pytest.mark.parametrize(
    ("change", "message"),
    [
        (
            lambda r: [*r[:10], r[11], r[10], *r[12:]],
            "column 'time_s', row 12: time goes backwards (unsorted): 0.011 s after 0.012 s",
        ),
        (lambda r: [*r[:10], r[10], r[10], *r[12:]], "column 'time_s', row 12: duplicate time"),
        (lambda r: [*r[:5], "0.006,abc,1,2,3", *r[6:]], "column 'x1_um', row 6: not a number: 'abc'"),
        (lambda r: [*r[:5], "0.006,1,2", *r[6:]], "row 6 has 3 fields, the header 5"),
        (lambda r: [*r[:20], "nan,1,2,3,4", *r[21:]], "column 'time_s', row 21: time is not finite"),
    ],
)
def test_each_bad_record_gets_one_line_naming_the_column_and_row(tmp_path, capsys, change, message):
    path = _csv(tmp_path, change(_good_rows()))
    assert main(["estimate", str(path), "--out", str(tmp_path / "out"), "--no-progress"]) == 2
    error = capsys.readouterr().err.strip()
    assert message in error and len(error.splitlines()) == 1, error


@pytest.mark.parametrize(
    ("header", "rows", "args", "message"),
    [
        ("time_s,x1_um,y1_um,x2_um", None, [], "missing column 'y2_um' (probes.y2.column)"),
        (None, [f"{i * 1e-3:.6f},{1e-8 * i},0,0,0" for i in range(1, 40)], [], "every reading is below 1 nm"),
        (
            None,
            [f"{i * 1e-3:.6f},{0.01 * i},0,0,0" for i in range(1, 40)],
            ["--probe", "x1.zero_um=-5000"],
            "exceeds 20 radial clearances",
        ),
        (None, [f"{i:.6f},1,2,3,4" for i in range(1, 40)], [], "sample interval 1 s cannot be right"),
        (
            "time_s,x1_um,y1_um,x2_um,y2_um,speed_hz",
            _good_rows(extra=",4500"),
            [],
            "column 'speed_hz', row 1: 4500 cannot be right (expected 0 to 2000 Hz)",
        ),
        (
            "time_s,x1_um,y1_um,x2_um,y2_um,oil_temperature_c",
            _good_rows(extra=",320"),
            [],
            "column 'oil_temperature_c', row 1: 320 cannot be right",
        ),
        (
            "time_s,x1_um,y1_um,x2_um,y2_um",
            _good_rows(),
            ["--probe", "x1.unit=V", "--probe", "x1.rest_gap_v=-9", "--probe", "x1.column=x1_um"],
            "column 'x1_um', rows from 1: median 10.01 V cannot be a proximity probe's gap voltage",
        ),
    ],
)
def test_columns_that_are_missing_or_in_a_unit_that_cannot_be_right(
    tmp_path, capsys, header, rows, args, message
):
    path = _csv(
        tmp_path, rows if rows is not None else _good_rows(), header or "time_s,x1_um,y1_um,x2_um,y2_um"
    )
    assert main(["estimate", str(path), "--out", str(tmp_path / "out"), "--no-progress", *args]) == 2
    error = capsys.readouterr().err.strip()
    assert message in error and len(error.splitlines()) == 1, error


def test_a_missing_record_file_or_an_output_that_is_a_file_is_one_line(tmp_path, capsys):
    assert main(["estimate", str(tmp_path / "none.csv"), "--no-progress"]) == 2
    assert "none.csv: no such record file" in capsys.readouterr().err
    assert main(["estimate", str(tmp_path / "none.csv")]) == 2  # with its progress bar: no empty bar first
    error = capsys.readouterr().err.strip()
    assert error.endswith("none.csv: no such record file") and len(error.splitlines()) == 1, error
    record, blocker = _csv(tmp_path, _good_rows()), tmp_path / "file"
    blocker.write_text("")
    assert main(["estimate", str(record), "--out", str(blocker), "--no-progress"]) == 2
    assert "is an existing file; give a folder" in capsys.readouterr().err


def test_a_gap_is_bridged_with_missing_samples_and_reported(tmp_path):
    rows = _good_rows(300)
    path = _csv(tmp_path, rows[:100] + rows[140:])
    stream = RecordStream(str(path), probe_setup(), (CLEARANCE_M, CLEARANCE_M), 1e-3, 75.0, chunk_rows=64)
    blocks = list(stream.blocks())
    k = np.concatenate([b.k for b in blocks])
    position = np.vstack([b.position_m for b in blocks])
    np.testing.assert_array_equal(k, np.arange(1, 301))
    assert np.isnan(position[100:140]).all() and np.isfinite(position[:100]).all()
    assert np.isfinite(position[140:]).all()
    assert stream.gaps == [{"row": 101, "from_s": 0.1, "to_s": 0.141, "missing_samples": 40}]
    assert stream.rows == 260


def test_parquet_and_tdms_readers_give_the_csv_reader_s_samples(tmp_path):
    t = np.arange(1, 3001) * 1e-3
    columns = {
        "time_s": t,
        "x1_um": 10 + np.sin(t * 400),
        "y1_um": -12 + np.cos(t * 400),
        "x2_um": 9.5 + 0 * t,
        "y2_um": -11 + 0.1 * np.sin(t * 30),
    }
    results = {}
    for suffix in ("csv", "parquet", "tdms"):
        path = write_record(
            tmp_path / f"r.{suffix}", columns, units={n: "um" for n in columns if n != "time_s"}
        )
        stream = RecordStream(
            str(path), probe_setup(), (CLEARANCE_M, CLEARANCE_M), 1e-3, 75.0, chunk_rows=1000
        )
        results[suffix] = np.vstack([b.position_m for b in stream.blocks()])
        assert stream.rows == 3000
    np.testing.assert_array_equal(results["tdms"], results["parquet"])  # both binary doubles
    np.testing.assert_allclose(results["csv"], results["parquet"], rtol=1e-8, atol=0)  # 9 digits of text
    wrong = write_record(tmp_path / "v.tdms", columns, units={"x1_um": "V"})
    with pytest.raises(InputError, match=re.escape("column 'x1_um' is in 'V' but probes.x1.unit is 'um'")):
        RecordStream(str(wrong), probe_setup(), (CLEARANCE_M, CLEARANCE_M), 1e-3, 75.0)
    with pytest.raises(InputError, match=re.escape("unknown record format '.xlsx'")):
        RecordStream(str(tmp_path / "r.xlsx"), probe_setup(), (CLEARANCE_M, CLEARANCE_M), 1e-3, 75.0)


def test_further_fields_of_the_estimator_s_step_report_become_estimate_columns_in_field_units():
    from dataclasses import dataclass, fields

    from oilwatch.estimator.nuisance_outputs import nuisance_names
    from oilwatch.estimator.reports import StepReport
    from oilwatch.monitoring.columns import estimate_columns

    @dataclass(slots=True)
    class FurtherReport(StepReport):  # a field a later estimator may report, and a nuisance the filter gives
        offset_m: np.ndarray = None
        film_gap_m: np.ndarray = None

    base = {"q_m3_s": np.zeros(2), "q_std_m3_s": np.zeros(2), "starved": np.zeros(2, bool),
            "probe_status": np.zeros(4, int), "changing": np.zeros(2, bool),
            "starved_consistent": np.zeros(2, bool), "viscosity_factor": np.ones(2),
            "viscosity_factor_std": np.zeros(2), "filter_q_m3_s": np.zeros(2),
            "filter_q_std_m3_s": np.zeros(2), "baseline_q_m3_s": np.zeros(2),
            "baseline_q_std_m3_s": np.zeros(2)}  # fmt: skip
    values = {f.name: base.get(f.name, 0) for f in fields(StepReport)}
    report = FurtherReport(**values, offset_m=np.zeros(4), film_gap_m=np.zeros(2))
    columns, extras = estimate_columns(report)
    assert columns[:5] == ["time_s", "q1_est_ml_min", "q2_est_ml_min", "q1_std_ml_min", "q2_std_ml_min"]
    assert columns[17:] == [
        "probe_status_x1", "probe_status_y1", "probe_status_x2", "probe_status_y2", "model_consistent",
        "changing_b1", "changing_b2", "starved_consistent_b1", "starved_consistent_b2", "model_mismatch",
        "filter_q_b1_ml_min", "filter_q_b2_ml_min", "filter_q_std_b1_ml_min", "filter_q_std_b2_ml_min",
        "baseline_q_b1_ml_min", "baseline_q_b2_ml_min",
        "baseline_q_std_b1_ml_min", "baseline_q_std_b2_ml_min",
        "film_gap_b1_um", "film_gap_b2_um",
    ] + [row[0] for row in nuisance_names()]  # fmt: skip
    assert ("film_gap_m", 1e6, 2) in extras
    # nuisances (offsets, viscosity factors): estimate and std from the filter, once
    assert all(name not in dict((e[0], e) for e in extras) for name in ("offset_m", "viscosity_factor"))
    assert columns.count("viscosity_factor_b1") == 1 and "viscosity_factor_b1_std" in columns
