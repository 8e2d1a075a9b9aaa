"""Every example of README.md and docs/*.md runs, or is generated from a run (the markers of
tests/doc_examples.py): the fast tier runs the short examples and parses the long commands; the slow tier runs
the examples that build the FMUs or co-simulate. Shown output is compared with what the command prints."""

from __future__ import annotations

import os
import re
import shlex
import subprocess
import sys
from pathlib import Path

import pytest
from fixtures.doc_examples import KINDS, REPO, Block, all_blocks, blocks, output_pattern, pages

from oilwatch.cli import build_parser

DEVELOPMENT_PATHS = re.compile(r"(?<![\w.])/(work|root|home)/")
"""Folders of a development machine: no page may name one (a generated block neither)."""
LINKED = ("models", "tests", "benchmarks")


def test_every_fenced_block_is_run_generated_or_marked():
    unmarked = [f"{b.where} ({b.language or 'no language'})" for b in all_blocks() if b.kind is None]
    assert unmarked == [], "add <!-- example: KIND --> before these fences (tests/doc_examples.py)"
    unknown = [f"{b.where}: {b.kind}" for b in all_blocks() if b.kind not in (*KINDS, "generated")]
    assert unknown == []


def test_no_page_names_a_folder_of_a_development_machine():
    found = []
    for path in pages():
        for number, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
            if DEVELOPMENT_PATHS.search(line):
                found.append(f"{path.relative_to(REPO)}:{number}: {line.strip()[:80]}")
    assert found == []


def test_the_long_commands_parse():
    parser = build_parser()
    checked = 0
    for block in all_blocks():
        if block.kind != "parse":
            continue
        for line in _command_lines(block.text):
            words = shlex.split(line, comments=True)
            if not words or not (words[0] == "oilwatch" or words[0].endswith("/bin/oilwatch")):
                continue
            try:
                parser.parse_args(words[1:])
            except SystemExit as stop:
                pytest.fail(f"{block.where}: {line!r} does not parse (exit {stop.code})")
            checked += 1
    assert checked > 0


def _command_lines(text: str) -> list[str]:
    """Commands of a shell block (continuation lines joined, ``&&`` chains split); environment assignments
    and ``nice`` dropped."""
    joined = text.replace("\\\n", " ")
    out = []
    for command in (part for line in joined.splitlines() for part in line.split("&&")):
        words = command.split()
        while words and (re.fullmatch(r"[A-Z_]+=\S*", words[0]) or words[0] in ("nice", "-n", "10")):
            words = words[1:]
        out.append(" ".join(words))
    return out


def _page_ids(slow: bool) -> list[str]:
    wanted = ("run", "slow") if slow else ("run",)
    return [str(p.relative_to(REPO)) for p in pages() if any(b.kind in wanted for b in blocks(p))]


def _run_page(page: str, folder: Path, slow: bool) -> None:
    for name in LINKED:
        (folder / name).symlink_to(REPO / name)
    environment = dict(os.environ, MPLBACKEND="Agg", OPENBLAS_NUM_THREADS="1")
    environment["PATH"] = f"{Path(sys.executable).parent}{os.pathsep}{environment.get('PATH', '')}"
    executed: tuple[Block, str] | None = None
    for block in blocks(REPO / page):
        if block.kind == "file":
            (folder / block.argument).write_text(block.text, encoding="utf-8")
        elif block.kind in ("run", "slow"):
            if block.kind == "slow" and not slow:
                executed = None
                continue
            executed = (block, _execute(block, folder, environment))
        elif block.kind == "output" and executed is not None:
            source, stdout = executed
            text = "\n".join(line.rstrip() for line in stdout.splitlines()) + "\n"
            assert output_pattern(block.text).fullmatch(text), (
                f"{block.where}: the output shown differs from what {source.where} prints:\n{stdout}"
            )


def _execute(block: Block, folder: Path, environment: dict) -> str:
    if block.language == "python":
        script = folder / f"example_{block.line}.py"
        script.write_text(block.text, encoding="utf-8")
        command = [sys.executable, script.name]
    elif block.language in ("sh", "bash", "console"):
        command = ["bash", "-euo", "pipefail", "-c", block.text]
    else:
        raise AssertionError(f"{block.where}: cannot run a block of language {block.language!r}")
    done = subprocess.run(command, cwd=folder, env=environment, capture_output=True, text=True, timeout=1500)
    assert done.returncode == 0, f"{block.where} exited {done.returncode}:\n{done.stdout}\n{done.stderr}"
    return done.stdout


@pytest.mark.parametrize("page", _page_ids(slow=False))
def test_the_fast_examples_of_a_page_run(page, tmp_path):
    _run_page(page, tmp_path, slow=False)


@pytest.mark.slow
@pytest.mark.parametrize(
    "page",
    # each page its own unit under pytest-xdist (tests/fixtures/xdist_units.py): the pages share no fixture,
    # and together they would keep one worker busy for the whole suite
    [pytest.param(p, marks=pytest.mark.xdist_group(f"doc-examples {p}")) for p in _page_ids(slow=True)],
)
def test_every_example_of_a_page_runs(page, tmp_path):
    _run_page(page, tmp_path, slow=True)
