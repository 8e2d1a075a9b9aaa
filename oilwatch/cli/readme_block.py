"""Generated README blocks: a table between ``<!-- generated NAME: COMMAND -->`` and
``<!-- /generated NAME -->``.

The command that makes a README table writes it between its markers, so that the table is regenerated from
its result file, never retyped. A README without the block's markers is an InputError naming them.
"""

from __future__ import annotations

import re
from pathlib import Path

from oilwatch.models.validation import InputError


def replace_block(readme: str | Path, name: str, body: str, command: str) -> None:
    """Put ``body`` between the markers of block ``name`` in ``readme`` (the begin marker names
    ``command``)."""
    path = Path(readme)
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as error:
        raise InputError(f"--readme: cannot read {path}: {error}") from None
    begin = re.compile(rf"<!-- generated {re.escape(name)}: [^\n]*-->")
    end = f"<!-- /generated {name} -->"
    found = begin.search(text)
    if found is None or end not in text[found.end() :]:
        raise InputError(f"--readme {path}: no block '<!-- generated {name}: ... -->' ... '{end}'")
    tail = text[found.end() :].split(end, 1)[1]
    marker = f"<!-- generated {name}: {command} -->"
    path.write_text(f"{text[: found.start()]}{marker}\n{body.rstrip()}\n{end}{tail}", encoding="utf-8")
