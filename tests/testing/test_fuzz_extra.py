"""Without the ``fuzz`` extra, the hypothesis-based helpers of vcran.testing name the install they need
(issue 16: a plain ``pip install vcran`` has no hypothesis)."""

from __future__ import annotations

import subprocess
import sys

import pytest

#: Run in a fresh interpreter where ``import hypothesis`` fails as it does without the extra.
PROBE = """
import sys
sys.modules["hypothesis"] = None  # import hypothesis -> ModuleNotFoundError
try:
    import {module}
except ModuleNotFoundError as exc:
    print(exc.name, "|", exc)
else:
    print("imported")
"""


@pytest.mark.parametrize("module", ["vcran.testing.strategies", "vcran.testing.plans", "vcran.testing.scripts",
                                    "vcran.testing.stateful", "vcran.testing.loop"])
def test_a_helper_without_hypothesis_names_the_extra(module: str) -> None:
    out = subprocess.run([sys.executable, "-c", PROBE.format(module=module)], capture_output=True, text=True,
                         check=True).stdout.strip()
    assert out == f"hypothesis | {module} needs hypothesis, which the 'fuzz' extra installs: pip install 'vcran[fuzz]'"


def test_the_helpers_without_hypothesis_still_import() -> None:
    # the rule checks and the reference model are plain Python: usable without the extra
    out = subprocess.run([sys.executable, "-c", PROBE.format(module="vcran.testing.checks, vcran.testing.model")],
                         capture_output=True, text=True, check=True).stdout.strip()
    assert out == "imported"
