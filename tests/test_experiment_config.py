"""The run and study settings: defaults and ranges defined once (oilwatch/experiment_config.py), read by the
scenario and study code, and the CLI options and help generated from them; study errors name the flags."""

from __future__ import annotations

import argparse
import inspect
from dataclasses import fields

import pytest

from oilwatch.cli import run as run_cli
from oilwatch.cli import study as study_cli
from oilwatch.cli.config_options import option_help
from oilwatch.experiment_config import SCENARIO_DEFAULTS, STUDY_DEFAULTS, ScenarioConfig, StudyConfig, flag
from oilwatch.models.validation import InputError
from oilwatch.scenarios import make_run
from oilwatch.study import make_cases
from oilwatch.study.case_cosim import case_labels, case_parameters
from oilwatch.study.grid import Case


def _parser(module) -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="oilwatch")
    module.register(parser.add_subparsers())
    return parser


@pytest.mark.parametrize("module, config", [(run_cli, ScenarioConfig), (study_cli, StudyConfig)])
def test_cli_options_and_help_come_from_the_configuration(module, config):
    command = module.__name__.rsplit(".", 1)[-1]
    parser = _parser(module)
    arguments = ["constant"] if command == "run" else []
    parsed = parser.parse_args([command, *arguments])
    (sub,) = [action for action in parser._subparsers._group_actions[0].choices.values()]
    text = sub.format_help()
    for spec in fields(config):
        assert getattr(parsed, spec.name) == getattr(config(), spec.name), spec.name
        assert flag(spec.name) in text, spec.name
        first_words = spec.metadata["description"].split()[0]
        assert first_words in text, spec.name
    assert "(default: 1; 0.001 to 50 um)" in option_help(next(f for f in fields(ScenarioConfig)))


def test_scenario_and_study_code_defaults_are_the_configuration_defaults():
    run = make_run("constant")
    assert (run.noise_um, run.duration_s, run.seed) == (
        SCENARIO_DEFAULTS.noise_um,
        SCENARIO_DEFAULTS.duration_s,
        SCENARIO_DEFAULTS.seed,
    )
    defaults = inspect.signature(make_cases).parameters
    assert defaults["duration_s"].default == STUDY_DEFAULTS.duration_s
    assert defaults["discard_s"].default == STUDY_DEFAULTS.discard_s
    case = Case(100.0, 100.0, 1.0)
    assert (case.duration_s, case.discard_s) == (STUDY_DEFAULTS.duration_s, STUDY_DEFAULTS.discard_s)


@pytest.mark.parametrize(
    "settings, message",
    [
        ({"noise_um": 0.0}, "--noise-um must lie in [0.001, 50] um, got 0 um"),
        ({"duration_s": 5000.0}, "--duration-s must lie in [1, 3600] s"),
        ({"seed": 1.5}, "--seed must be an integer in [0, 2147483647], got 1.5"),
        ({"seed": -1}, "--seed must be an integer in [0, 2147483647], got -1"),
        ({"q1_pct": 300.0}, "--q1-pct must lie in [1, 200] %"),
        ({"q2_pct": float("nan")}, "--q2-pct must be finite"),
    ],
)
def test_scenario_settings_outside_their_range_name_the_flag(settings, message):
    with pytest.raises(InputError) as error:
        make_run("constant", **settings)
    assert str(error.value).startswith(message), str(error.value)


def test_study_case_parameters_are_labelled_with_the_users_flags():
    (case,) = [c for c in make_cases([2.0], grid_step_pct=25.0) if (c.q1_pct, c.q2_pct) == (75.0, 100.0)]
    parameters, labels = case_parameters(case), case_labels(case)
    for role, values in parameters.items():
        assert set(values) <= set(labels[role]), role
    assert labels["plant"]["seed"] == "--seeds" and labels["plant"]["noise_um"] == "--noise-um"
    assert labels["plant"]["q1_final_ml_min"] == "the study grid's q1 = 75 % of its nominal"
    assert labels["ekf"]["machine_file"] == "--machine"
    assert (
        case.settings_text == "--noise-um 2, q1 = 75 %, q2 = 100 % of each bearing's nominal, --seeds index 0"
    )
