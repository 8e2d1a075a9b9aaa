"""Speed and oil-temperature profiles of `oilwatch run` and of the scenarios (issue 13 item 3)."""

import pytest

from oilwatch.scenarios import make_run
from tests.test_misuse import one_line_error

ROLES = {"plant": "plant", "ekf": "ekf"}


def test_constant_nominal_scenarios_carry_no_profile_and_keep_todays_tables():
    run = make_run("sudden-drop")
    assert not run.follows_operating_point and run.input_signals(ROLES) == {}
    assert "bearing_table" not in run.plant_parameters() and "bearing_table" not in run.ekf_parameters()


def test_operating_ramps_feed_both_fmus_the_issues_ramps_on_the_dimensionless_table():
    run = make_run("operating-ramps", q1_pct=80.0, q2_pct=90.0)
    signals = run.input_signals(ROLES)
    assert set(signals) == {
        "plant.speed_hz",
        "ekf.speed_hz",
        "plant.oil_temperature_c",
        "ekf.oil_temperature_c",
    }
    speed, temperature = signals["ekf.speed_hz"], signals["ekf.oil_temperature_c"]
    assert (speed(0.0), speed(5.0), speed(15.0)) == pytest.approx((72.0, 75.0, 78.0))
    assert temperature(60.0) - temperature(0.0) == pytest.approx(10.0)
    assert run.plant_parameters()["bearing_table"] == run.ekf_parameters()["bearing_table"] == 1
    assert run.q1_ml_min[0] == pytest.approx(0.8 * run.nominal_ml_min[0])


def test_command_line_profiles_replace_the_scenarios():
    run = make_run("constant", speed_profile="step:75:70:2", oil_temperature_profile="constant:+5")
    signals = run.input_signals(ROLES)
    assert signals["plant.speed_hz"](1.0) == 75.0 and signals["plant.speed_hz"](2.0) == 70.0
    assert signals["ekf.oil_temperature_c"](0.0) == pytest.approx(run_nominal_temperature() + 5.0)


def run_nominal_temperature():
    from oilwatch.models.machine import load_machine

    return load_machine().nominal_oil_temperature_c


@pytest.mark.parametrize(
    ("flag", "text", "message"),
    [
        (
            "--speed-profile",
            "ramp:72:78:0",
            "--speed-profile must be constant:V, ramp:V0:V1:START_S:DURATION_S",
        ),
        ("--speed-profile", "ramp:-80:+3:0:10", "--speed-profile must stay within [1, 1000] Hz"),
        ("--speed-profile", "ramp:72:78:0:0", "--speed-profile: a ramp's duration_s must be > 0 s"),
        ("--oil-temperature-profile", "step:40:abc:3", "--oil-temperature-profile: 'abc' is not a number"),
        (
            "--oil-temperature-profile",
            "constant:200",
            "--oil-temperature-profile must stay within [-50, 150]",
        ),
    ],
)
def test_bad_profiles_are_one_line_errors_naming_the_flag(capsys, tmp_path, flag, text, message):
    line = one_line_error(capsys, ["run", "constant", flag, text, "--out", str(tmp_path / "out")])
    assert message in line, line
