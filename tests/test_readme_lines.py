"""The README stays a README: at most 300 lines, the rest is the documentation site's (docs/)."""

from __future__ import annotations

from pathlib import Path

README = Path(__file__).resolve().parents[1] / "README.md"
MAX_LINES = 300


def test_the_readme_has_at_most_300_lines():
    lines = README.read_text(encoding="utf-8").splitlines()
    assert len(lines) <= MAX_LINES, f"README.md has {len(lines)} lines; move the detail into docs/"
