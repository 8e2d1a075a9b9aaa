"""The machine-file reference (oilwatch.models.machine_keys) against the readers: every key they read is
declared, every declared key is read, a declared lower bound is refused by its reader naming the key, and the
documentation page holds the table generated from the declarations."""

from __future__ import annotations

import copy
import tomllib
from pathlib import Path

import pytest

from oilwatch.models.machine import machine_from_dict
from oilwatch.models.machine_keys import MACHINE_KEYS, keys_of, markdown_table
from oilwatch.models.probes import DEFAULTS, RUNOUT_KEYS, read_probes
from oilwatch.models.validation import InputError
from oilwatch.records.probes import probe_setup

TURBINE = Path(__file__).resolve().parents[1] / "models" / "turbine.toml"
MACHINE_SECTIONS = ("machine", "material", "shaft", "discs[]", "unbalance", "bearings", "oil", "lubrication",
                    "rotor_damping")  # fmt: skip


class Recording(dict):
    """A TOML table that notes the keys a reader looks up (``t[k]``, ``t.get(k)``, ``k in t``)."""

    def __init__(self, data: dict, section: str, seen: set[str]) -> None:
        super().__init__(data)
        self.section, self.seen = section, seen

    def _note(self, key) -> None:
        self.seen.add(f"{self.section}.{key}")

    def __getitem__(self, key):
        self._note(key)
        return super().__getitem__(key)

    def get(self, key, default=None):
        self._note(key)
        return super().get(key, default)

    def __contains__(self, key) -> bool:
        self._note(key)
        return super().__contains__(key)


def _recorded(data: dict, seen: set[str]) -> dict:
    out = {}
    for section, value in data.items():
        if isinstance(value, dict):
            out[section] = Recording(value, section, seen)
        elif isinstance(value, list) and value and all(isinstance(v, dict) for v in value):
            out[section] = [Recording(v, f"{section}[]", seen) for v in value]
        else:
            out[section] = value
    return out


def _turbine() -> dict:
    return tomllib.loads(TURBINE.read_text())


def _variants() -> list[dict]:
    """The bundled turbine, and the alternatives a file may choose: the oil by two measured points, no [oil]
    (the viscosity given directly), and shaft damping left out."""
    grade = _turbine()
    points = copy.deepcopy(grade)
    for key in ("iso_vg_grade", "viscosity_index"):
        del points["oil"][key]
    points["oil"]["kinematic_viscosity_points_c_cst"] = [[40.0, 68.0], [100.0, 8.732]]
    no_oil = copy.deepcopy(grade)
    del no_oil["oil"]
    no_oil["bearings"]["viscosity_pa_s"] = 0.094
    return [grade, points, no_oil]


def test_the_machine_readers_read_exactly_the_declared_keys():
    seen: set[str] = set()
    for data in _variants():
        machine_from_dict(_recorded(data, seen), "variant.toml")
    declared = {k.name for k in MACHINE_KEYS if k.section in MACHINE_SECTIONS}
    read = {name for name in seen if name.split(".")[0] in MACHINE_SECTIONS}
    assert read - declared == set(), "read but not declared: add them to oilwatch/models/machine_keys.py"
    assert declared - read == set(), "declared but never read"


def test_the_probe_readers_accept_exactly_the_declared_keys():
    assert set(DEFAULTS) | {"layout"} <= set(keys_of("probes"))
    assert set(RUNOUT_KEYS) <= set(keys_of("probes.<probe>"))
    table = {
        key: "x" for key in ("time_column", "speed_column", "oil_temperature_column", "keyphasor_column")
    }
    table |= {"layout": "api670", "noise_um": 0.5, "keyphasor_edge": "rising", "keyphasor_threshold_v": -2.0,
              "keyphasor_angle_deg": 40.0, "offset_prior_std_um": 25.0, "offset_random_walk_um_sqrt_s": 0.2,
              "offset_drift_um_per_day": 0.1, "scale_factor_tolerance_pct": 5.0}  # fmt: skip
    probe = {"column": "c", "angle_deg": 45.0, "unit": "V", "zero_um": 0.0, "sensitivity_v_per_mm": 7.87,
             "rest_gap_v": -9.0} | {key: 0.0 for key in RUNOUT_KEYS}  # fmt: skip
    assert set(table) == set(keys_of("probes")) and set(probe) == set(keys_of("probes.<probe>"))
    for name in ("x1", "y1", "x2", "y2"):
        table[name] = dict(probe, angle_deg=45.0 if name[0] == "x" else 135.0)
    probe_setup(table)  # every declared key accepted
    with pytest.raises(InputError, match="unknown key"):
        probe_setup({"undeclared_key": 1})
    with pytest.raises(InputError, match="unknown key"):
        probe_setup({"x1": {"undeclared_key": 1}})


def _bad_value(allowed: str) -> float | None:
    """A value just outside a declared lower bound of 0 (None when the key has no such bound)."""
    if allowed.startswith(">= 0"):
        return -1.0
    if allowed.startswith("> 0"):
        return 0.0
    return None


BOUNDED = [
    k
    for k in MACHINE_KEYS
    if k.section in (*MACHINE_SECTIONS, "probes")
    and k.section != "discs[]"
    and _bad_value(k.allowed) is not None
]


@pytest.mark.parametrize("key", BOUNDED, ids=[k.name for k in BOUNDED])
def test_a_declared_lower_bound_is_refused_by_its_reader_naming_the_key(key):
    data = _variants()[2] if key.name == "bearings.viscosity_pa_s" else _turbine()
    section = data.setdefault(key.section, {})
    section[key.key] = _bad_value(key.allowed)
    with pytest.raises(InputError, match=key.key):
        machine = machine_from_dict(data, "bad.toml")
        if key.section == "probes":
            read_probes(machine)
            probe_setup(machine.raw["probes"])


def test_the_reference_page_holds_the_generated_table():
    page = (Path(__file__).resolve().parents[1] / "docs" / "machine-file.md").read_text()
    assert markdown_table() in page, (
        "regenerate it: python -m oilwatch.cli.docs_tables --page docs/machine-file.md"
    )
