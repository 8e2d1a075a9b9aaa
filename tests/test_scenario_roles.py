"""``oilwatch run`` finds the plant and the estimator among an SSP's FMU instances by their outputs, from the
FMUs the master loaded (their model descriptions are read once, by the master)."""

from types import SimpleNamespace

import pytest

from oilwatch.cosim.errors import SystemDescriptionError
from oilwatch.scenarios.runner import ROLES, _roles


def _slave(*outputs: str, inputs: tuple[str, ...] = ()):
    variables = {n: SimpleNamespace(causality="output") for n in outputs}
    variables.update({n: SimpleNamespace(causality="input") for n in inputs})
    return SimpleNamespace(variables=variables)


def test_roles_come_from_the_loaded_slaves_outputs():
    slaves = {
        "filter": _slave(ROLES["ekf"], inputs=("x1_um",)),
        "rig": _slave(ROLES["plant"], "x1_um"),
    }
    assert _roles(slaves, "system.ssp") == {"plant": "rig", "ekf": "filter"}


def test_a_missing_role_names_the_output_it_looks_for():
    # an input of the marker's name is not the role
    slaves = {"rig": _slave(ROLES["plant"]), "other": _slave(inputs=(ROLES["ekf"],))}
    with pytest.raises(SystemDescriptionError, match=r"system\.ssp: no FMU instance with the output"):
        _roles(slaves, "system.ssp")
