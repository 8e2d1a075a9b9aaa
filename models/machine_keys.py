"""Every key of a machine file, with its unit, whether it is required, its default and its allowed values:
the readers' key metadata, from which the machine-file reference of the documentation is generated.

The readers (:mod:`oilwatch.models.machine`, :mod:`oilwatch.models.machine_sections`,
:mod:`oilwatch.models.probes`, :mod:`oilwatch.records.probes`) check what is written here;
``tests/test_machine_keys.py`` reads machine files through them and fails when a reader reads a key that
is not declared here, when a declared key is never read, or when a declared lower bound is not refused by its
reader. A new key is declared here first.

``section`` is the TOML table: ``probes.<probe>`` stands for each of ``probes.x1``, ``probes.y1``,
``probes.x2``, ``probes.y2`` and ``discs[]`` for each ``[[discs]]`` entry.
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class MachineKey:
    """One key of a machine file.

    Attributes
    ----------
    section : the TOML table that holds it (module docstring).
    key : its name; the unit is in the name (``_mm``, ``_hz``, ...).
    required : whether a file must give it (else ``default`` applies, or the key is one of alternatives that
        ``allowed`` names).
    default : the value a file without the key gets, as text ("" when there is none).
    allowed : the values the reader accepts, as text.
    description : what it is, in the field's words.
    """

    section: str
    key: str
    required: bool
    default: str
    allowed: str
    description: str

    @property
    def name(self) -> str:
        return f"{self.section}.{self.key}"


def _key(section: str, key: str, allowed: str, description: str, default: str | None = None) -> MachineKey:
    return MachineKey(section, key, default is None, default or "", allowed, description)


MACHINE_KEYS: tuple[MachineKey, ...] = (
    _key("machine", "name", "text", "The machine's name in reports and FMU descriptions.", "the file's stem"),
    _key(
        "machine", "nominal_speed_hz", "> 0", "Nominal spin speed: the scenarios, tables and FMUs run at it."
    ),
    _key(
        "machine",
        "gravity_m_s2",
        ">= 0",
        "Gravitational acceleration (the rotor's weight loads the bearings).",
    ),
    _key("material", "youngs_modulus_pa", "> 0", "Young's modulus E of shaft and discs."),
    _key("material", "poisson_ratio", "-1 < nu < 0.5", "Poisson's ratio (the Timoshenko shear modulus)."),
    _key("material", "density_kg_m3", "> 0", "Density of shaft and discs."),
    _key(
        "shaft",
        "element_length_mm",
        "list of numbers > 0",
        "Length of each Timoshenko element; element k joins node k to node k + 1 (nodes from 1).",
    ),
    _key(
        "shaft",
        "element_diameter_mm",
        "list of numbers > 0, as many as the lengths",
        "Outer diameter of each element (solid shaft).",
    ),
    _key("discs[]", "node", "a node number 1..n", "Node of a rigid disc.", "no disc"),
    _key("discs[]", "width_mm", "> 0", "Axial width of the disc.", "no disc"),
    _key(
        "discs[]",
        "outer_diameter_mm",
        "> the shaft diameter at its node",
        "Outer diameter; the bore is the shaft diameter at the node (an annulus).",
        "no disc",
    ),
    _key(
        "static_forces[]",
        "node",
        "a node number 1..n",
        "Node of a steady force on the rotor (a gear mesh at a pinion, a belt on a pulley, a process force): "
        "each bearing's static load, magnitude and direction, is then its weight share plus its support "
        "reaction to the forces. Not with a bearing's own static_load_n or load_angle_deg.",
        "no force",
    ),
    _key("static_forces[]", "force_n", "> 0", "Magnitude of the force.", "no force"),
    _key(
        "static_forces[]",
        "angle_deg",
        "any number",
        "Direction of the force, as a groove's angle (from the top, with the rotation; 180 is down).",
        "no force",
    ),
    _key(
        "unbalance",
        "iso_grade_mm_s",
        ">= 0",
        "ISO 1940 balance grade G: eccentricity e = G / Omega at the nominal speed, moment = rotor mass x e.",
    ),
    _key("unbalance", "node", "a node number 1..n", "Node where the unbalance acts."),
    _key("unbalance", "phase_deg", "any number", "Phase phi of the unbalance force (Eqs. 5-6 of the paper)."),
    _key("bearings", "nodes", "distinct node numbers", "Nodes of the fluid-film bearings (bearing 1 first)."),
    _key(
        "bearings",
        "load_split",
        '"equal" or "reactions"',
        "How the rotor's weight loads the bearings: equal halves (the paper) or the static reactions.",
    ),
    _key(
        "bearings", "radius_mm", "> 0, the shaft radius at each bearing node within 1 %", "Journal radius R."
    ),
    _key("bearings", "length_mm", "> 0", "Bearing length L."),
    _key("bearings", "radial_clearance_um", "> 0, < radius_mm", "Radial clearance c."),
    _key(
        "bearings",
        "groove_angle_deg",
        "any number",
        "Angular position of the supply groove's centre (0: top, opposite the load).",
        "[[bearings.grooves]] instead",
    ),
    _key(
        "bearings",
        "groove_circumferential_mm",
        "> 0, <= pi R",
        "Circumferential width of the groove.",
        "[[bearings.grooves]] instead",
    ),
    _key(
        "bearings",
        "groove_axial_mm",
        "> 0, <= length_mm",
        "Axial length of the groove.",
        "[[bearings.grooves]] instead",
    ),
    _key(
        "bearings",
        "grooves",
        "a non-empty array of tables; not with the groove_* keys",
        "Any number of axial grooves, all fed from the bearing's one supply (docs/bearings.md), instead of "
        "the three groove_* keys.",
        "the groove_* keys",
    ),
    _key("bearings.grooves[]", "angle_deg", "any number", "Centre of one axial groove (0: top).", "-"),
    _key("bearings.grooves[]", "circumferential_mm", "> 0, <= pi R", "Its circumferential width.", "-"),
    _key("bearings.grooves[]", "axial_mm", "> 0, <= length_mm", "Its axial length, centred.", "-"),
    _key(
        "bearings",
        "circumferential_groove_axial_mm",
        "> 0, < length_mm",
        "Axial width of a full circumferential groove at the mid-plane (two lands), fed with the grooves.",
        "none",
    ),
    _key(
        "bearings",
        "override",
        "an array of tables, at most one per bearing node",
        "Per-bearing geometry, load and nominal flowrate: each [[bearings.override]] gives the keys of "
        "bearings.override[] in which one bearing differs from [bearings] and [lubrication] (a drive-end "
        "bearing of another size, clearance, grooves, load or supply).",
        "every bearing has the [bearings] geometry",
    ),
    _key(
        "bearings",
        "load_angle_deg",
        "any number",
        "Direction of each bearing's static load, as a groove's angle (from the top, with the rotation): "
        "180 is straight down, the weight. Another direction (a gear mesh, a belt, a process force) is "
        "taken as given: the rotor carries the external force that turns its weight share into it.",
        "180",
    ),
    _key("bearings.override[]", "node", "one of bearings.nodes", "The bearing the override is for.", "-"),
    _key(
        "bearings.override[]",
        "radius_mm",
        "> 0, the shaft radius at its node within 1 %",
        "Its journal radius R.",
        "bearings.radius_mm",
    ),
    _key("bearings.override[]", "length_mm", "> 0", "Its bearing length L.", "bearings.length_mm"),
    _key(
        "bearings.override[]",
        "radial_clearance_um",
        "> 0, < its radius",
        "Its radial clearance c.",
        "bearings.radial_clearance_um",
    ),
    _key(
        "bearings.override[]",
        "groove_angle_deg",
        "any number; with the other two groove_* keys",
        "Its one groove's centre: an override that gives grooves replaces the [bearings] grooves whole.",
        "the [bearings] grooves",
    ),
    _key(
        "bearings.override[]",
        "groove_circumferential_mm",
        "> 0, <= pi R",
        "Its one groove's circumferential width.",
        "the [bearings] grooves",
    ),
    _key(
        "bearings.override[]",
        "groove_axial_mm",
        "> 0, <= its length",
        "Its one groove's axial length.",
        "the [bearings] grooves",
    ),
    _key(
        "bearings.override[]",
        "grooves",
        "as [[bearings.grooves]]; not with the groove_* keys",
        "Its axial grooves ([[bearings.override.grooves]]), instead of the three groove_* keys.",
        "the [bearings] grooves",
    ),
    _key(
        "bearings.override[]",
        "circumferential_groove_axial_mm",
        "> 0, < its length",
        "Its circumferential groove.",
        "bearings.circumferential_groove_axial_mm",
    ),
    _key(
        "bearings.override[]",
        "load_angle_deg",
        "any number",
        "Direction of its static load (as bearings.load_angle_deg).",
        "bearings.load_angle_deg",
    ),
    _key(
        "bearings.override[]",
        "static_load_n",
        "> 0",
        "Magnitude of its static load when it is not its share of the weight (a gear mesh, a belt, a "
        "process force): the rotor carries the external force that makes the load so.",
        "its share of the weight (bearings.load_split)",
    ),
    _key(
        "bearings.override[]",
        "nominal_flowrate_ml_min",
        "> 0",
        "Its own nominal supply flowrate: its percentages of flow, the estimator's start and the alarm's "
        "levels refer to it.",
        "lubrication.nominal_flowrate_ml_min",
    ),
    _key(
        "bearings",
        "viscosity_pa_s",
        "> 0; only without [oil]",
        "Film viscosity when the file has no [oil] section (then no oil temperature input).",
        "from [oil]",
    ),
    _key(
        "bearings",
        "dynamic_coefficients",
        '"synchronous" or "quasi-static"',
        "Linearized film coefficients: synchronous = K(Omega), C(Omega) of the transient film for the 1x "
        "response (the free dynamics on the quasi-static table); quasi-static = the frozen-content table "
        "for both.",
        '"synchronous"',
    ),
    _key(
        "oil",
        "iso_vg_grade",
        "> 0 (with viscosity_index)",
        "ISO 3448 viscosity grade (kinematic viscosity at 40 degC, cSt).",
        "or kinematic_viscosity_points_c_cst",
    ),
    _key(
        "oil",
        "viscosity_index",
        "any number (with iso_vg_grade)",
        "ASTM D2270 viscosity index.",
        "or kinematic_viscosity_points_c_cst",
    ),
    _key(
        "oil",
        "kinematic_viscosity_points_c_cst",
        "two [temperature degC, viscosity cSt] pairs",
        "Two measured points of the ASTM D341 (Walther) law, instead of grade and index.",
        "or iso_vg_grade and viscosity_index",
    ),
    _key("oil", "density_15c_kg_m3", "> 0", "Density at 15 degC."),
    _key("oil", "thermal_expansion_per_k", ">= 0", "Volumetric thermal expansion of the density.", "6.4e-4"),
    _key(
        "oil",
        "nominal_supply_temperature_c",
        "within the oil law's range",
        "Nominal supply temperature: the bearings' viscosity is the oil's there.",
    ),
    _key(
        "lubrication",
        "nominal_supply_pressure_bar",
        ">= 0",
        "Nominal groove pressure; without nominal_flowrate_ml_min the flowrate is solved at it.",
        "or nominal_flowrate_ml_min",
    ),
    _key(
        "lubrication",
        "nominal_flowrate_ml_min",
        "> 0",
        "Nominal supply flowrate of each bearing without its own (bearings.override[]): a bearing's "
        "percentages of flow are percentages of its nominal.",
        "solved at nominal_supply_pressure_bar for each bearing",
    ),
    _key(
        "lubrication",
        "table_min_fraction_of_threshold",
        "> 0",
        "Lower end of the coefficient tables, as a fraction of the flooded threshold q_t.",
    ),
    _key(
        "lubrication",
        "table_max_fraction_of_threshold",
        "> table_min_fraction_of_threshold",
        "Upper end of the coefficient tables, as a fraction of q_t.",
    ),
    _key(
        "rotor_damping",
        "stiffness_proportional_s",
        ">= 0",
        "Stiffness-proportional shaft damping C = beta K (not in the paper).",
        "0",
    ),
    _key(
        "reduced_model",
        "cutoff_hz",
        "> 0",
        "The reduced (Craig-Bampton) model of the estimator and the reduced plant keeps the fixed-interface "
        "modes below this frequency; raise it until `oilwatch validate reduction` shows a flow-equivalent "
        "error far below the estimator's std.",
        "500",
    ),
    _key(
        "probes",
        "layout",
        '"xy" or "api670"',
        "Probe mounting: xy = X at 0 deg, Y at 90 deg from horizontal; api670 = 45 and 135 deg.",
        '"xy"',
    ),
    _key(
        "probes",
        "noise_um",
        "> 0",
        "Std of the probes' white noise (the estimator's measurement noise).",
        "1.0",
    ),
    _key("probes", "time_column", "text", "Record column of the time [s].", '"time_s"'),
    _key("probes", "speed_column", "text", "Record column of the spin speed [Hz].", '"speed_hz"'),
    _key(
        "probes",
        "oil_temperature_column",
        "text",
        "Record column of the oil supply temperature [degC].",
        '"oil_temperature_c"',
    ),
    _key(
        "probes",
        "keyphasor_column",
        "text",
        "Record column of the once-per-revolution pulse [V].",
        '"" (none)',
    ),
    _key(
        "probes",
        "keyphasor_edge",
        '"falling" or "rising"',
        "Which crossing of the pulse marks the mark.",
        '"falling"',
    ),
    _key(
        "probes",
        "keyphasor_threshold_v",
        "any number",
        "Crossing level of the pulse.",
        "halfway between the first chunk's extremes",
    ),
    _key("probes", "keyphasor_angle_deg", "any number", "Rotor angle (Eqs. 5-6) at the pulse.", "0"),
    _key(
        "probes", "offset_prior_std_um", ">= 0", "Std of each probe's zero offset before any baseline.", "25"
    ),
    _key(
        "probes",
        "offset_random_walk_um_sqrt_s",
        ">= 0",
        "Drift of the offsets within a run [um/sqrt(s)].",
        "0.2",
    ),
    _key(
        "probes",
        "offset_drift_um_per_day",
        ">= 0",
        "Bound on the zero drift since a commissioning baseline: widens the baseline's offsets by its age.",
        "0.1",
    ),
    _key(
        "probes",
        "scale_factor_tolerance_pct",
        "0..50",
        "Tolerance of each probe's scale factor (API 670: +-5 % per probe, cable and driver set); the "
        "estimator's published std includes what it can cost in flow (0: probes calibrated as a set).",
        "5",
    ),
    _key(
        "probes.<probe>", "column", "text", "Record column of the probe.", "x1_um ... (x1_v ... with unit V)"
    ),
    _key(
        "probes.<probe>",
        "angle_deg",
        "any number",
        "Direction from the bearing centre to the probe, counter-clockwise from horizontal.",
        "from layout",
    ),
    _key(
        "probes.<probe>",
        "unit",
        '"um" or "V"',
        "um: displacement along the probe axis; V: gap voltage (negative).",
        '"um"',
    ),
    _key(
        "probes.<probe>",
        "zero_um",
        "any number",
        "Reading with the shaft at the bearing centre (unit um).",
        "0",
    ),
    _key(
        "probes.<probe>",
        "sensitivity_v_per_mm",
        "0.1..100",
        "Scale factor (unit V; API 670: 200 mV/mil).",
        "7.87",
    ),
    _key(
        "probes.<probe>",
        "rest_gap_v",
        "-24 <= v < 0",
        "Gap voltage at cold rest, journal on the bottom (unit V).",
        "required with unit V",
    ),
    _key(
        "probes.<probe>", "runout_1x_um", "0..100", "Slow-roll 1x runout amplitude along the probe axis.", "0"
    ),
    _key("probes.<probe>", "runout_1x_phase_deg", "-360..360", "Its phase from the keyphasor.", "0"),
    _key("probes.<probe>", "runout_1x_std_um", "0..100", "Std of each component (enters the noise).", "0"),
    _key("probes.<probe>", "runout_2x_um", "0..100", "Slow-roll 2x runout amplitude.", "0"),
    _key("probes.<probe>", "runout_2x_phase_deg", "-360..360", "Its phase from the keyphasor.", "0"),
    _key("probes.<probe>", "runout_2x_std_um", "0..100", "Std of each component.", "0"),
)


def keys_of(section: str) -> tuple[str, ...]:
    """The key names declared for ``section``, in declaration order."""
    return tuple(k.key for k in MACHINE_KEYS if k.section == section)


def markdown_table() -> str:
    """The reference table of every key (section, key, required or default, allowed values, description)."""
    lines = ["| key | required / default | allowed | what |", "|---|---|---|---|"]
    for k in MACHINE_KEYS:
        need = "required" if k.required else f"default: {k.default}"
        cells = (f"`{k.name}`", need, k.allowed, k.description)
        lines.append("| " + " | ".join(cell.replace("|", "\\|") for cell in cells) + " |")
    return "\n".join(lines)
