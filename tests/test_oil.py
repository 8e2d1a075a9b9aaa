"""The oil model against published data: ASTM D2270 Table 1 and examples, ISO 3448 grades, ASTM D341."""

import math

import pytest

from oilwatch.models.machine import load_machine, machine_from_dict
from oilwatch.models.oil import Oil, nu100_from_viscosity_index, reference_oils_l_h, viscosity_index
from oilwatch.models.validation import InputError

# ASTM D2270 Table 1: Y = nu(100 degC), L and H = nu(40 degC) of the VI 0 and VI 100 oils [cSt].
D2270_TABLE_1 = [
    (2.0, 7.994, 6.394),
    (3.0, 15.49, 12.15),
    (4.0, 25.32, 19.56),
    (5.0, 40.23, 28.49),
    (6.0, 57.97, 38.19),
    (6.8, 73.48, 46.44),
    (7.0, 78.00, 48.57),
    (8.0, 100.0, 59.60),
    (9.0, 123.3, 71.10),
    (10.0, 147.7, 82.87),
    (12.0, 201.9, 108.0),
    (15.0, 296.5, 149.7),
    (20.0, 493.2, 229.5),
    (30.0, 1023.0, 421.7),
]


@pytest.mark.parametrize(("y", "low", "high"), D2270_TABLE_1)
def test_reference_oils_reproduce_d2270_table_1(y, low, high):
    l_value, h_value = reference_oils_l_h(y)
    assert l_value == pytest.approx(low, rel=3e-3)
    assert h_value == pytest.approx(high, rel=3e-3)


def test_viscosity_index_reproduces_the_d2270_examples():
    # D2270 sec. 7 examples: VI <= 100 and VI > 100.
    assert round(viscosity_index(73.30, 8.86)) == 92
    assert round(viscosity_index(22.83, 5.05)) == 156


@pytest.mark.parametrize(
    ("grade", "nu100_table"),
    # nu(100 degC) of the VI 100 oil of each ISO 3448 mid-point, interpolated in Table 1's H column.
    [
        (32, 5.3 + 0.1 * (32 - 31.40) / (32.37 - 31.40)),
        (46, 6.7 + 0.1 * (46 - 45.33) / (46.44 - 45.33)),
        (68, 8.7 + 0.1 * (68 - 67.64) / (68.79 - 67.64)),
        (100, 11.3 + 0.1 * (100 - 98.97) / (100.2 - 98.97)),
    ],
)
def test_grade_and_viscosity_index_give_the_tabulated_100c_viscosity(grade, nu100_table):
    oil = Oil.from_grade(grade, 100, 860.0)
    assert oil.kinematic_viscosity_cst(40.0) == pytest.approx(grade, rel=1e-9)
    assert oil.kinematic_viscosity_cst(100.0) == pytest.approx(nu100_table, rel=5e-4)
    assert nu100_from_viscosity_index(grade, 100) == pytest.approx(nu100_table, rel=5e-4)
    # VI 0 is the L column: Y with L(Y) = grade.
    y0 = nu100_from_viscosity_index(grade, 0)
    assert reference_oils_l_h(y0)[0] == pytest.approx(grade, rel=1e-9)


def test_walther_law_is_a_straight_line_through_its_points():
    oil = Oil.from_points(((40.0, 68.0), (100.0, 8.73)), 860.0)
    assert oil.kinematic_viscosity_cst(40.0) == pytest.approx(68.0, rel=1e-12)
    assert oil.kinematic_viscosity_cst(100.0) == pytest.approx(8.73, rel=1e-12)

    def walther(t_c):
        return math.log10(math.log10(oil.kinematic_viscosity_cst(t_c) + 0.7))

    x = [math.log10(t + 273.15) for t in (20.0, 60.0, 90.0)]
    w = [walther(t) for t in (20.0, 60.0, 90.0)]
    slope = (w[1] - w[0]) / (x[1] - x[0])
    assert (w[2] - w[0]) / (x[2] - x[0]) == pytest.approx(slope, rel=1e-10)
    assert oil.dynamic_viscosity_pa_s(50.0) < oil.dynamic_viscosity_pa_s(40.0)
    assert oil.density_kg_m3(15.0) == 860.0


def test_bad_oils_are_refused_with_the_input_named():
    with pytest.raises(InputError, match="ISO VG grade"):
        Oil.from_grade(50, 100, 860.0)
    with pytest.raises(InputError, match="fall as temperature rises"):
        Oil.from_points(((40.0, 10.0), (100.0, 20.0)), 860.0)
    with pytest.raises(InputError, match="oil temperature"):
        Oil.from_grade(68, 100, 860.0).kinematic_viscosity_cst(400.0)


def test_bundled_turbine_oil_has_the_papers_viscosity_at_its_stated_temperature():
    machine = load_machine()
    assert machine.oil is not None
    assert machine.bearing.viscosity_pa_s == pytest.approx(0.094, rel=1e-10)
    assert machine.oil.dynamic_viscosity_pa_s(machine.nominal_oil_temperature_c) == pytest.approx(
        0.094, rel=1e-10
    )
    assert 25.0 < machine.nominal_oil_temperature_c < 50.0


def test_machine_file_oil_by_points_and_refuses_two_viscosities():
    data = dict(load_machine().raw)
    data["oil"] = {
        "kinematic_viscosity_points_c_cst": [[40.0, 46.0], [100.0, 6.8]],
        "density_15c_kg_m3": 870.0,
        "nominal_supply_temperature_c": 45.0,
    }
    machine = machine_from_dict(data)
    assert machine.bearing.viscosity_pa_s == pytest.approx(
        Oil.from_points(((40, 46), (100, 6.8)), 870.0).dynamic_viscosity_pa_s(45.0)
    )
    data["bearings"] = {**data["bearings"], "viscosity_pa_s": 0.05}
    with pytest.raises(InputError, match="viscosity once"):
        machine_from_dict(data)
    del data["oil"]
    assert machine_from_dict(data).oil is None


def test_monotone_root_is_brents_to_its_tolerance_and_brackets_to_the_last_bit():
    """The oil's roots are found without scipy.optimize (an FMU's start-up): against brentq, increasing and
    decreasing functions, the result is within brentq's own tolerance and one of its neighbouring floats has
    the other sign (or it is a root)."""
    from scipy.optimize import brentq

    from oilwatch.models.oil import monotone_root

    for grade in (22, 46, 68, 320):
        for vi in (0.0, 95.0, 140.0):
            f = lambda y, u=float(grade), vi=vi: viscosity_index(u, y) - vi  # noqa: E731
            root = monotone_root(f, 2.0, grade * (1 - 1e-12))
            assert root == pytest.approx(brentq(f, 2.0, grade * (1 - 1e-12), xtol=1e-12), abs=2e-12)
            sides = [f(math.nextafter(root, side)) for side in (-math.inf, math.inf)]
            assert f(root) == 0.0 or any((f(root) < 0.0) != (value < 0.0) for value in sides)
    oil = Oil.from_grade(46, 100, 860.0)
    mu = oil.dynamic_viscosity_pa_s(57.3)
    assert oil.temperature_at_viscosity_c(mu) == pytest.approx(57.3, abs=1e-9)
