"""Build step: compile vcran's simulation core with mypyc when this machine can (vcran/_native.py says which
modules, and why). Everything else is in pyproject.toml.

The compiled core is optional: ``VCRAN_PURE=1`` at install time, a missing C compiler or any failure of mypyc
leaves a pure-Python install that writes the same outputs, and a line saying so in pip's log (``pip -v``). mypyc runs inside
``build_ext`` (not when this file is read), because pip reads it several times per install and only one of
those builds.
"""

from __future__ import annotations

import json
import os
import runpy
import sys
from pathlib import Path

from setuptools import Extension, setup
from setuptools.command.build_ext import build_ext

ROOT = Path(__file__).resolve().parent
PACKAGE = ROOT / "vcran"
NATIVE = runpy.run_path(str(PACKAGE / "_native.py"))  # vcran itself cannot be imported while it is built
RECORD = PACKAGE / NATIVE["BUILD_FILE"]
PURE = os.environ.get(NATIVE["PURE_ENV"], "") not in ("", "0")


def _say(text: str) -> None:
    print(f"vcran build: {text}", file=sys.stderr)


class CompileCore(build_ext):
    """Replaces the placeholder extension with mypyc's; falls back to pure Python on any failure."""

    def finalize_options(self) -> None:
        # mypyc's extensions replace the placeholder before setuptools prepares each extension for building
        if self._in_place():
            RECORD.unlink(missing_ok=True)  # the checkout's earlier record must not vouch for this build
        self.distribution.ext_modules = self._compiled() or []
        super().finalize_options()

    def _compiled(self) -> list[Extension] | None:
        if PURE:
            _say(f"{NATIVE['PURE_ENV']} is set: pure Python, no compiled core")
            return None
        cwd = os.getcwd()
        try:
            from mypyc.build import mypycify

            os.chdir(ROOT)  # mypyc names modules after the paths given, relative to here
            return list(mypycify([str(p.relative_to(ROOT)) for p in NATIVE["sources"](PACKAGE)],
                                 group_name=NATIVE["GROUP"], opt_level="3"))
        except (Exception, SystemExit) as exc:  # mypyc missing or refusing a module (it exits on type errors)
            _fallback(exc)
            return None
        finally:
            os.chdir(cwd)

    def run(self) -> None:
        if not self.extensions:
            return
        try:
            super().run()
        except Exception as exc:  # no C compiler, or it failed: the pure install still works
            _fallback(exc)
            return
        record = json.dumps({"digest": NATIVE["digest"](PACKAGE)}) + "\n"
        # editable: the extensions run beside the sources; a wheel: its package was copied before this step
        (PACKAGE if self._in_place() else Path(self.build_lib) / "vcran").joinpath(RECORD.name).write_text(record)
        _say("compiled core built")

    def _in_place(self) -> bool:
        """An editable install (the extensions go beside the sources), not a wheel of the checkout."""
        return bool(getattr(self, "editable_mode", False) or self.inplace)


def _fallback(exc: BaseException) -> None:
    _say(f"the compiled core could not be built ({type(exc).__name__}: {exc}); installing pure Python, which "
         "writes the same outputs, only slower")


setup(
    # a placeholder, replaced by mypyc's extensions in CompileCore; none at all for a pure build (a pure wheel)
    ext_modules=[] if PURE else [Extension(NATIVE["GROUP"] + "__mypyc", sources=[])],
    cmdclass={"build_ext": CompileCore},
    # an editable install's build products beside the sources are not package data of a wheel built later
    exclude_package_data={"": ["*.so", "*.pyd", NATIVE["BUILD_FILE"]]},
)
