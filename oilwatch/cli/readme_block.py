"""Generated blocks of the README and the documentation pages (docs/*.md): a table between
``<!-- generated NAME: COMMAND -->`` and ``<!-- /generated NAME -->``.

The command that makes a table writes it between its markers, so that the table is regenerated from its
result file or its run, never retyped. A file without the block's markers is an InputError naming them.
The COMMAND in the marker is what was run, with paths relative to the repository's top: a block never names
a folder of the machine it was made on.
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


def replace_blocks(readme: str | Path, bodies: dict[str, str], command: str) -> list[str]:
    """Put each of ``bodies`` between its markers in ``readme`` where the file has them; return the names
    written. A file with none of the blocks is an InputError naming them."""
    path = Path(readme)
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as error:
        raise InputError(f"--readme: cannot read {path}: {error}") from None
    present = [name for name in bodies if f"<!-- /generated {name} -->" in text]
    if not present:
        names = ", ".join(f"'<!-- generated {name}: ... -->'" for name in bodies)
        raise InputError(f"--readme {path}: none of the blocks {names}")
    for name in present:
        replace_block(path, name, bodies[name], command)
    return present
