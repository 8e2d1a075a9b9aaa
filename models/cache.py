"""The user's oilwatch cache folder, where new tables of the bundled machine and built FMUs go."""

from __future__ import annotations

import os
from pathlib import Path


def user_cache_dir() -> Path:
    """The oilwatch cache folder: ``$OILWATCH_CACHE``, else ``~/.cache/oilwatch``."""
    configured = os.environ.get("OILWATCH_CACHE")
    return Path(configured).expanduser() if configured else Path.home() / ".cache" / "oilwatch"
