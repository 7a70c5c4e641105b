"""Speed figures in README.md and docs/*.md are measured (issue 29 item 13): a paragraph (or table row)
that says how long something takes in wall-clock or CPU time, or how much faster one way is than another,
names the benchmark that measured it, ``benchmarks/bench_*.py``, which must exist; the paragraph says on
what it ran. docs/library.md said the warehouse hour runs "well under a second", measured at 1.1-1.3 s.
An example's inputs that merely look like a measurement say so: "made-up figures".

Only prose is read (code blocks are output or commands); the patterns are the ways these files state
speed: "takes about 15 s", "in 6 wall seconds", "20 CPU-minutes", "under a second", "140x real time",
"several times faster", "installs in seconds"."""

from __future__ import annotations

import re

import pytest

from tests.conftest import ROOT

CLAIMS = re.compile("|".join(f"(?:{p})" for p in (
    r"\bunder\s+a\s+(wall\s+)?second\b",
    r"\b(takes?|took|taking)\s+(about\s+|under\s+|less\s+than\s+|roughly\s+|around\s+|only\s+)?\d[\d,.]*\s*"
    r"(µs|ms|s|seconds?|minutes?|min|hours?|CPU[- ]minutes?|CPU[- ]seconds?)\b",
    r"\d[\d,.]*x\s+real\s+time",
    r"\b(installs?|starts?|runs?|finish(es)?)\s+in\s+(seconds|milliseconds|under\b|about\s+\d|\d)",
    r"\b\d[\d,.]*\s*(CPU[- ])?(µs|ms|s|seconds?|minutes?|min|hours?)\s+(of\s+)?(wall\b|CPU\b|test\s+time|on\s+(one|two|\d+)\s+"
    r"(shared\s+)?(cores?|CPUs?))",
    r"\b\d[\d,.]*\s+wall\s+seconds?\b",
    r"\b(several|\d[\d,.]*)\s*(times|x)\s+(faster|slower)\b",
)), re.I)
BENCHMARK = re.compile(r"benchmarks/(bench_\w+\.py)")
FILES = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]


def paragraphs(text: str) -> list[str]:
    """Prose paragraphs and table rows, code blocks blanked out."""
    text = re.sub(r"^```.*?^```", lambda m: "\n" * m.group(0).count("\n"), text, flags=re.S | re.M)
    return [part for block in re.split(r"\n\s*\n", text)
            for part in (block.splitlines() if block.lstrip().startswith("|") else [block])]


@pytest.mark.parametrize("path", FILES, ids=lambda p: p.name)
def test_every_speed_figure_names_its_benchmark(path):
    unmeasured = []
    for paragraph in paragraphs(path.read_text(encoding="utf-8")):
        claim = CLAIMS.search(paragraph)
        if claim is None or "made-up figures" in paragraph:
            continue
        named = BENCHMARK.findall(paragraph)
        if not named:
            unmeasured.append(paragraph[max(0, claim.start() - 60):claim.end() + 30].replace("\n", " "))
        for name in named:
            assert (ROOT / "benchmarks" / name).is_file(), f"{path.name} names benchmarks/{name}, which does not exist"
    assert unmeasured == [], f"{path.name}: speed figures without the benchmark that measured them"


def test_the_patterns_catch_what_they_should():
    """Each way of stating speed these files used is caught, and plain simulated durations are not."""
    for caught in ("runs well under a second", "the fuzz tests take about 15 s on two cores", "took about 20 CPU-minutes",
                   "840 s of it done in 6 wall seconds", "140x real time", "several times faster than json",
                   "a checkout installs in\nseconds"):
        assert CLAIMS.search(caught), caught
    for fine in ("a 20 m leg is 2 s up", "full after 11 s", "F times faster than the wall clock",
                 "takes about 130 runs", "every 60 s", "parts faster than the jobs take them"):
        assert not CLAIMS.search(fine), fine
