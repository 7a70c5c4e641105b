"""The compiled core: which modules mypyc compiles to C at install time, and whether this process runs them.

Why: a run's time is the interpreter executing vcran's own simulation code (the per-robot processes, the
state machine, the fleet tick), spread over the whole design with no hot spot left to cut in Python
(benchmarks/README.md, sixth to eighth rounds). mypyc compiles the same, type-checked modules to C: a
10-robot hour in about 0.7x the time, with the design unchanged (issue 14). What is compiled is the
simulation's inner loop and nothing a user extends: no transport, no file format, no command.

The rules this module enforces, all of them at ``import vcran``:

* **Same results.** Compiled and pure modules write the same bytes (tests/test_native.py compares them on the
  bundled scenarios and a generated fleet). Nothing here is required: without a C compiler, or with
  ``VCRAN_PURE=1`` at install time, the package is pure Python and behaves the same, only slower.
* **``VCRAN_PURE=1`` at run time** runs the pure modules whatever is built: for py-spy or a debugger (neither
  sees inside compiled code), and for tests that patch a compiled class.
* **Never stale.** In an editable install (``pip install -e .``) the compiled modules sit beside their
  sources; after an edit they would go on running the old code. The build records a digest of the sources
  it compiled (:data:`BUILD_FILE`); when the sources differ, or only part of the build is there, the pure
  modules run (:data:`REASON` says why; ``tests/test_native.py`` fails until you reinstall).

Both cases go through one import hook, installed only when there is a build to bypass: it makes
``import vcran.sim.robot`` load ``robot.py`` instead of the extension beside it. All modules switch
together, because compiled modules call each other directly, not through the import system.
"""

from __future__ import annotations

import hashlib
import importlib.abc
import importlib.machinery
import importlib.util
import json
import os
import sys
from collections.abc import Mapping
from pathlib import Path
from types import ModuleType

#: The compiled modules: the run's inner loop (issue 14). Each must stay valid for mypyc: no class
#: extending a built-in or a slotted Python class, no module ``__getattr__`` (LocalProtocolError in
#: vcran.core.effects and Published in vcran.core.incidents moved out of them for this).
MODULES = (
    "vcran.core.collisions",
    "vcran.core.motion",
    "vcran.core.ranlogic",
    "vcran.core.tasks",
    "vcran.sim.contacts",
    "vcran.sim.mailbox",
    "vcran.sim.model",
    "vcran.sim.ran",
    "vcran.sim.robot",
    "vcran.sim.timing",
)
#: mypyc's group: the shared library all compiled modules live in (``vcran/_core__mypyc.*.so``).
GROUP = "vcran._core"
#: Written by the build beside this file: the digest of the sources it compiled.
BUILD_FILE = "_native_build.json"
#: Set at run time to skip the compiled modules.
PURE_ENV = "VCRAN_PURE"

#: What this process runs: "compiled", or "pure" (then :data:`REASON` says why, "" if nothing is built).
MODE = "pure"
REASON = ""


def source(package: Path, module: str) -> Path:
    """The ``.py`` file of ``module`` (one of :data:`MODULES`) in the package folder ``package``."""
    return package.joinpath(*module.split(".")[1:]).with_suffix(".py")


def sources(package: Path) -> list[Path]:
    return [source(package, m) for m in MODULES]


def digest(package: Path) -> str:
    """What the build records and the import compares: every compiled module's name and bytes."""
    h = hashlib.sha256()
    for module in MODULES:
        data = source(package, module).read_bytes()
        h.update(f"{module}\0{len(data)}\0".encode())
        h.update(data)
    return h.hexdigest()


def _extension(folder: Path, name: str) -> bool:
    return any((folder / (name + suffix)).is_file() for suffix in importlib.machinery.EXTENSION_SUFFIXES)


def built(package: Path) -> tuple[int, int]:
    """How many of the build's extension files are there, of how many (each module's and the group's)."""
    wanted = [(source(package, m).parent, m.rsplit(".", 1)[1]) for m in MODULES]
    wanted.append((package, GROUP.rsplit(".", 1)[1] + "__mypyc"))
    return sum(_extension(folder, name) for folder, name in wanted), len(wanted)


def decide(package: Path, environ: Mapping[str, str]) -> tuple[str, str]:
    """``("compiled", "")``, or ``("pure", why)``: why is "" when there is no build at all (a pure install)."""
    present, total = built(package)
    if present == 0:
        return "pure", ""
    if environ.get(PURE_ENV, "") not in ("", "0"):
        return "pure", f"{PURE_ENV}={environ[PURE_ENV]}"
    if present < total:
        return "pure", f"only {present} of the compiled core's {total} files are installed"
    try:
        recorded = json.loads((package / BUILD_FILE).read_text())["digest"]
    except (OSError, ValueError, KeyError, TypeError):
        return "pure", f"{BUILD_FILE} is missing or unreadable"
    if recorded != digest(package):
        return "pure", "its sources changed since it was compiled"
    return "compiled", ""


class _PureFinder(importlib.abc.MetaPathFinder):
    """Loads the compiled modules from their ``.py`` files."""

    def __init__(self, package: Path) -> None:
        self.package = package

    def find_spec(self, name: str, path: object = None, target: ModuleType | None = None) -> importlib.machinery.ModuleSpec | None:
        if name not in MODULES:
            return None
        return importlib.util.spec_from_file_location(name, source(self.package, name))


def use(package: Path) -> None:
    """Decide for this process, once, before any of :data:`MODULES` is imported (``vcran/__init__.py``).

    Silently: a stale build only costs speed (the pure modules are the sources), and a line on every
    command's stderr would break what scripts read there. :data:`REASON` says why; ``tests/test_native.py``
    fails on it, so a checkout's suite never passes on other code than the install's."""
    global MODE, REASON
    MODE, REASON = decide(package, os.environ)
    if MODE == "pure" and REASON:  # a build to bypass (without one, REASON is "" and .py files load anyway)
        sys.meta_path.insert(0, _PureFinder(package))
