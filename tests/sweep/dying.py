"""Jobs whose process dies, for tests of the local pool (docs/contract.md §10): importable by its worker processes."""

from __future__ import annotations

import os
from pathlib import Path


def square_or_die(i: int, dies: bool, once: str | None = None) -> int:
    """``i * i``, unless ``dies``: then the process ends at once (os._exit, as a crash or the out-of-memory
    killer ends it, with no exception to report), every time, or with ``once`` (a file's path) only the
    first time, when that file does not exist yet."""
    if dies and (once is None or not Path(once).exists()):
        if once is not None:
            Path(once).write_text("died once")
        os._exit(9)
    return i * i
