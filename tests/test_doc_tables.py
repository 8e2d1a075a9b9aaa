"""The generated tables of the README and the docs are what their commands write now (each regenerated into a
copy of its page and compared), and the output-block generator (oilwatch.cli.docs_tables)."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest
from fixtures.doc_blocks import block_body, comparison_column

from oilwatch.cli import machine_comparison, main
from oilwatch.cli.docs_tables import main as docs_tables
from oilwatch.cli.docs_tables import output_blocks, run_outputs, without_machine_load
from oilwatch.cli.validate import MAP_POINTS, near_threshold_table
from oilwatch.estimator.ekf_config import DEFAULT_PRESET, PRESETS
from oilwatch.models.bearing.grid import Mesh
from oilwatch.models.bearing.operating_table import OperatingTable, operating_table_path
from oilwatch.models.machine import BUNDLED_MACHINES, load_machine
from oilwatch.models.rotor.assembly import Rotor
from oilwatch.scenarios import SCENARIOS
from oilwatch.study.readme_tables import main as study_tables

REPO = Path(__file__).resolve().parents[1]


def _regenerated(page: str, names: tuple[str, ...], tmp_path: Path, run) -> None:
    copy = tmp_path / Path(page).name
    shutil.copyfile(REPO / page, copy)
    run(str(copy))
    for name in names:
        assert block_body(copy.read_text(), name) == block_body((REPO / page).read_text(), name), (
            f"{page}: block {name} is stale; rerun the command in its marker"
        )


def test_the_study_table_is_its_summary_files(tmp_path):
    folder = REPO / "docs" / "results" / "study" / "identification_5pct_grid"
    _regenerated("docs/validation.md", ("study-nuisances",), tmp_path,
                 lambda copy: study_tables(["--readme", copy, f"known, 5 % grid={folder}"]))  # fmt: skip


@pytest.mark.slow
@pytest.mark.parametrize("page", ["README.md", "docs/validation.md"])
def test_the_paper_comparison_is_what_oilwatch_report_prints(page, tmp_path):
    names = ("report-summary",) if page == "README.md" else ("report-summary", "report-tables")
    _regenerated(page, names, tmp_path, lambda copy: main(["report", "--readme", copy]))


@pytest.mark.slow
def test_the_robustness_table_is_its_result_files(tmp_path):
    files = [str(REPO / "docs" / "results" / "robustness" / name / "robustness.json")
             for name in ("offsets_unbalance_runout_probes", "offsets_step", "operating_point")]  # fmt: skip
    _regenerated("docs/validation.md", ("robustness",), tmp_path,
                 lambda copy: main(["robustness", "--from-json", *files, "--readme", copy]))  # fmt: skip


@pytest.mark.slow
def test_the_compressor_robustness_table_is_its_result_file(tmp_path):
    result = str(REPO / "docs" / "results" / "robustness" / "compressor" / "robustness.json")
    _regenerated("docs/compressor.md", ("robustness",), tmp_path,
                 lambda copy: main(["robustness", "--from-json", result, "--readme", copy]))  # fmt: skip


@pytest.mark.slow
@pytest.mark.parametrize(
    ("folder", "block"), [("model_structure", "robustness"), ("side_load", "robustness-side-load")]
)
def test_the_model_structure_robustness_tables_are_their_result_files(folder, block, tmp_path):
    result = str(REPO / "docs" / "results" / "robustness" / folder / "robustness.json")
    arguments = ["robustness", "--from-json", result, "--block", block, "--readme"]
    _regenerated("docs/robustness.md", (block,), tmp_path, lambda copy: main([*arguments, copy]))


@pytest.mark.slow
def test_the_published_table_comparison_is_what_oilwatch_validate_prints(tmp_path):
    _regenerated("docs/validation-bearing.md", ("lund-worst", "ocvirk", "lund-rows"), tmp_path,
                 lambda copy: main(["validate", "bearing-tables", "--readme", copy]))  # fmt: skip


@pytest.mark.slow
def test_the_near_threshold_table_holds_a_recomputed_point():
    """The 60 Hz rows of docs/bearings.md's quasi-static table, recomputed (the command in the block's
    marker recomputes both points of both tables)."""
    body = block_body((REPO / "docs" / "bearings.md").read_text(), "near-threshold-quasi-static")
    machine = load_machine()
    table = OperatingTable.load(operating_table_path(machine.source_path, "quasi-static"))
    load = float(Rotor.from_machine(machine).bearing_static_loads_n[0])
    mesh = Mesh(**table.metadata["mesh"])
    rows = near_threshold_table(table, machine.bearing, load, mesh, (MAP_POINTS[0][:2],)).splitlines()
    assert len(rows) == 4
    for row in rows:
        assert row in body.splitlines(), f"docs/bearings.md: {row} is stale; rerun the command in its marker"


def test_validate_refuses_readme_where_it_writes_nothing(capsys):
    for arguments in (["bearing-map", "--readme", "x.md"], ["reduction", "--readme", "x.md"],
                      ["bearing-map", "--near-threshold", "--one-sided", "--readme", "x.md"]):  # fmt: skip
        assert main(["validate", *arguments]) == 2
        message = capsys.readouterr().err.strip()
        assert "\n" not in message and "--readme" in message


@pytest.mark.parametrize("name", list(BUNDLED_MACHINES))
def test_the_machine_comparison_holds_each_machines_file_and_robustness_counts(name):
    """The rows docs/compressor.md's comparison takes from the machine file and the committed robustness
    results, recomputed (the demo's rows: the demo tests; the quick start's: its command)."""
    column = comparison_column(name)
    facts = machine_comparison.machine_rows(load_machine(BUNDLED_MACHINES[name]))
    labels = machine_comparison.MACHINE_LABELS
    assert column[: len(labels)] == facts
    assert column[-1] == machine_comparison.robustness_counts(turbine=name == "turbine")


def test_the_machine_comparison_runs_the_readmes_quick_start():
    commands = machine_comparison.quick_start_commands()
    assert [words[0] for words in commands] == ["run", "coast-down", "baseline", "run", "estimate"]
    assert all("#" not in word for words in commands for word in words)


def test_the_presets_table_is_the_presets_declaration(tmp_path):
    _regenerated("docs/model-mismatch.md", ("presets",), tmp_path,
                 lambda copy: docs_tables(["--page", copy]))  # fmt: skip
    body = block_body((REPO / "docs" / "model-mismatch.md").read_text(), "presets")
    rows = [line for line in body.splitlines() if line.startswith("| `")]
    assert [row.split("|")[1].strip() for row in rows] == [f"`{p.name}`" for p in PRESETS]
    assert rows[0].split("|")[2].strip() == "yes" and PRESETS[0].name == DEFAULT_PRESET


def test_the_scenarios_table_is_the_scenarios_declaration(tmp_path):
    _regenerated("docs/guide/simulation.md", ("scenarios",), tmp_path,
                 lambda copy: docs_tables(["--page", copy]))  # fmt: skip
    body = block_body((REPO / "docs" / "guide" / "simulation.md").read_text(), "scenarios")
    assert [line.split("|")[1].strip() for line in body.splitlines() if line.startswith("| `")] == [
        f"`{name}`" for name in SCENARIOS
    ]


def test_an_output_block_is_its_commands_output_without_the_machine_load(tmp_path):
    page = tmp_path / "page.md"
    command = "python -c \"print('a, load 12.5'); print('load average at the start: 3 2 1'); print('b')\""
    page.write_text(f"x\n<!-- generated output-demo: {command} -->\n<!-- /generated output-demo -->\n")
    assert output_blocks(page) == {"output-demo": command}
    assert run_outputs(page, []) == ["output-demo"]
    assert block_body(page.read_text(), "output-demo") == "```text\na\nb\n```\n"
    assert without_machine_load("(medians; 1-min load average 14.9-14.9)") == "(medians)"
    assert without_machine_load("force 5 N (load 3273 N)") == "force 5 N (load 3273 N)"  # a bearing's load


def test_a_bad_page_or_block_name_is_one_line_naming_it(tmp_path, capsys):
    page = tmp_path / "page.md"
    page.write_text("# a page without blocks\n", encoding="utf-8")
    assert docs_tables(["--page", str(page), "--outputs", "output-nothing"]) == 2
    message = capsys.readouterr().err.strip()
    assert "\n" not in message and "output-nothing" in message
    assert docs_tables(["--page", str(tmp_path / "missing.md")]) == 2
    message = capsys.readouterr().err.strip()
    assert "\n" not in message and "missing.md" in message
    assert docs_tables(["--page", str(page)]) == 2  # no generated table to write
    message = capsys.readouterr().err.strip()
    assert "\n" not in message and "presets" in message
