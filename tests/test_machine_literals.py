"""No number of the bundled machine's data is typed into the code: it comes from the machine file.

The numbers are read from the machine file itself (nominal flowrate in ml/min and as 1e-6 of it, viscosity,
clearance, journal radius and length, the bearing load and the rotor weight) and searched among the numeric
tokens (not comments or docstrings) of the code folders. The nominal speed (75 Hz) is not searched: 75 is also
the study's and the scenarios' 75 % of nominal. Tests hold reference values and are not searched.
"""

from __future__ import annotations

import ast
import io
import tokenize
from pathlib import Path

from oilwatch.models.bearing.supply import ML_MIN_PER_M3_S
from oilwatch.models.machine import load_machine
from oilwatch.models.rotor.assembly import Rotor

REPO = Path(__file__).resolve().parent.parent
FOLDERS = ("models", "estimator", "fmu_src", "oilwatch", "benchmarks")
ALLOWED = {
    "models/system/reproduction.py": "the paper's published figures, which results are compared against",
    "oilwatch/cli/validate.py": "0.07 Pa s is a viscosity of bearing-map's check points, not a length",
}


def machine_numbers() -> dict[str, float]:
    machine = load_machine()
    rotor = Rotor.from_machine(machine)
    nominal_ml_min = machine.shared_nominal_flowrate_m3_s("this test") * ML_MIN_PER_M3_S
    bearing = machine.bearing
    return {
        "nominal flowrate [ml/min]": nominal_ml_min,
        "nominal flowrate [1e-6 ml/min]": nominal_ml_min * 1e-6,
        "viscosity [Pa s]": bearing.viscosity_pa_s,
        "clearance [m]": bearing.clearance_m,
        "journal radius [m]": bearing.radius_m,
        "journal length [m]": bearing.length_m,
        "bearing load [N]": float(rotor.bearing_static_loads_n[0]),
        "rotor weight [N]": float(rotor.weight_n),
    }


def literal_hits(numbers: dict[str, float]) -> dict[str, list[str]]:
    hits: dict[str, list[str]] = {}
    for folder in FOLDERS:
        for path in sorted((REPO / folder).rglob("*.py")):
            text = path.read_text(encoding="utf-8")
            for token in tokenize.generate_tokens(io.StringIO(text).readline):
                if token.type != tokenize.NUMBER or token.string.lower().endswith("j"):
                    continue
                value = float(ast.literal_eval(token.string))
                for name, number in numbers.items():
                    if value and abs(value - number) <= 1e-4 * abs(number):
                        where = str(path.relative_to(REPO))
                        hits.setdefault(where, []).append(f"line {token.start[0]}: {token.string} ({name})")
    return hits


def test_no_machine_number_is_typed_into_the_code():
    numbers = machine_numbers()
    assert 596.2 < numbers["nominal flowrate [ml/min]"] < 596.4  # the search looks for the right numbers
    hits = literal_hits(numbers)
    unexpected = {path: lines for path, lines in hits.items() if path not in ALLOWED}
    assert not unexpected, unexpected
