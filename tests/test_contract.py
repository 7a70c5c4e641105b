"""docs/contract.md is the behaviour contract that code, tests and docs cite (issue 30 item 6).

A citation is ``docs/contract.md §N`` (one form: the path, so that a reader finds the file, and the section),
optionally continued as a list or a range (``docs/contract.md §4, §9``, ``docs/contract.md §3–§6``). Rules
are cited by number alone (``R8``). These tests read the contract's own headings and rule definitions, so
they fail when a citation names a section the contract lacks, when a rule is cited that it does not define,
or when the contract loses a section or a rule that citations rely on.
"""

from __future__ import annotations

import re
import subprocess
from pathlib import Path

import pytest

from tests.conftest import ROOT

CONTRACT = ROOT / "docs" / "contract.md"
TEXT_SUFFIXES = {".py", ".md", ".toml", ".txt", ".cfg", ".ini", ".yml", ".yaml"}

_SECTION_HEAD = re.compile(r"^## §(\d+)\. \S", re.M)
_RULE_DEFINITION = re.compile(r"^- \*\*(R\d+) ", re.M)
# The path, a section, then any further sections joined by a comma, "and" or a range dash.
_CITATION = re.compile(r"docs/contract\.md §(\d+)((?:\s*(?:,|and|[–-])\s*§\d+)*)")
_RULE = re.compile(r"\bR(\d+)\b")


def sections(text: str) -> list[int]:
    return [int(n) for n in _SECTION_HEAD.findall(text)]


def rules(text: str) -> list[str]:
    return _RULE_DEFINITION.findall(text)


def cited_sections(text: str) -> list[int]:
    """Every section number a ``docs/contract.md §N`` citation in ``text`` names, ranges expanded."""
    cited: list[int] = []
    for match in _CITATION.finditer(text):
        numbers = [int(match[1])]
        for joiner, n in re.findall(r"\s*(,|and|[–-])\s*§(\d+)", match[2]):
            numbers += range(numbers[-1] + 1, int(n) + 1) if joiner in "–-" else [int(n)]
        cited += numbers
    return cited


def repository_texts() -> list[Path]:
    """The repository's tracked text files (code, tests, docs, scenarios, configuration)."""
    out = subprocess.run(["git", "ls-files", "-z"], cwd=ROOT, capture_output=True, text=True, check=True)
    files = [ROOT / name for name in out.stdout.split("\0") if name]
    assert files, "git ls-files found nothing"
    return [f for f in files if f.suffix in TEXT_SUFFIXES and f.is_file()]


# --- the readers above, on text written by hand ------------------------------------------------------------


def test_the_citation_reader_expands_lists_and_ranges() -> None:
    text = "see docs/contract.md §4, §9 and docs/contract.md §3–§6; also docs/contract.md §10 and §12, R7"
    assert cited_sections(text) == [4, 9, 3, 4, 5, 6, 10, 12]


def test_the_heading_and_rule_readers_take_only_definitions() -> None:
    text = "## §2. Wire\n### §3. not a section\n- **R1 Task queue.** ...\n  - **R2 nested** no\n- R3 cited, not defined\n"
    assert sections(text) == [2] and rules(text) == ["R1"]


# --- the contract itself -------------------------------------------------------------------------------------


def test_the_contract_has_sections_1_to_13_in_order() -> None:
    """The same numbers as the contract the code was written against, so that every earlier citation maps
    one to one."""
    assert sections(CONTRACT.read_text(encoding="utf-8")) == list(range(1, 14))


def test_the_contract_defines_rules_r1_to_r14_once_each_in_order() -> None:
    assert rules(CONTRACT.read_text(encoding="utf-8")) == [f"R{n}" for n in range(1, 15)]


def test_the_contracts_own_section_references_exist() -> None:
    text = CONTRACT.read_text(encoding="utf-8")
    known = set(sections(text))
    referenced = {int(n) for n in re.findall(r"§(\d+)", text)}
    assert sorted(referenced - known) == []


# --- citations anywhere in the repository -------------------------------------------------------------------


@pytest.fixture(scope="module")
def texts() -> dict[Path, str]:
    return {path: path.read_text(encoding="utf-8", errors="replace") for path in repository_texts()}


def test_every_citation_names_a_section_that_exists(texts: dict[Path, str]) -> None:
    known = set(sections(CONTRACT.read_text(encoding="utf-8")))
    wrong = sorted(f"{path.relative_to(ROOT)}: §{n}" for path, text in texts.items()
                   for n in cited_sections(text) if n not in known)
    assert wrong == []


def test_the_contract_is_cited_by_its_path_only(texts: dict[Path, str]) -> None:
    """One citation form: ``contract §N`` or ``contract.md §N`` without ``docs/`` would be a second."""
    short = re.compile(r"(?<!docs/)\bcontract(?:\.md)? §\d+")
    wrong = sorted(f"{path.relative_to(ROOT)}: {m[0]!r}" for path, text in texts.items() for m in short.finditer(text))
    assert wrong == []


def test_every_rule_cited_is_defined(texts: dict[Path, str]) -> None:
    defined = set(rules(CONTRACT.read_text(encoding="utf-8")))
    wrong = sorted({f"{path.relative_to(ROOT)}: R{n}" for path, text in texts.items()
                    for n in _RULE.findall(text) if f"R{n}" not in defined})
    assert wrong == []
