"""Every code block of README.md and docs/*.md runs (README "Development" says how to write one).

A fenced block says what it is, and that decides how it is tested:

- ```` ```python ````: the file's Python blocks run in order in one namespace; when one of them defines
  ``test_`` functions (or a ``Test`` class) the file's blocks run as one pytest module instead, so a test
  example gets fixtures and hypothesis as a user's test file would.
- ```` ```sh ````: run with bash (``set -e``), the test venv's ``bin`` first on PATH (``vcran`` is this
  checkout's).
- ```` ```toml ````: a scenario file; it must load, and validate against ``vcran schema scenario``.
- ```` ```text ````: output or pictures, shown as is.

All run with a working directory that looks like the repository root (every top-level entry of it linked
into a temporary folder), so ``scenarios/demo.toml`` resolves as in the docs while ``--out out/demo``
writes nothing into the checkout. A block that cannot run verbatim (a server that runs until Ctrl-C, a
fixed port, ``pip install``) follows a marker ``<!-- tested by tests/FILE.py::test_name -->`` naming
the test that does the same thing; the marker is checked to point at a test that exists.
"""

from __future__ import annotations

import ast
import io
import json
import os
import re
import subprocess
import sys
from contextlib import redirect_stdout
from dataclasses import dataclass
from pathlib import Path

import pytest

from vcran.io.scenario_file import parse

ROOT = Path(__file__).resolve().parent.parent
DOCS = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
LANGUAGES = ("python", "sh", "toml", "text")
_FENCE = re.compile(r"^(?P<indent> *)```(?P<lang>\S*)\s*$")
_MARKER = re.compile(r"^<!--\s*tested by\s+(?P<target>\S+)\s*-->\s*$")


@dataclass(frozen=True)
class Block:
    doc: Path
    line: int  # 1-based line of the first line of code (after the fence)
    lang: str
    code: str
    tested_by: str | None  # the marker's target, if the block is marked

    def __str__(self) -> str:
        return f"{self.doc.relative_to(ROOT)}:{self.line}"


def blocks(doc: Path) -> list[Block]:
    """The fenced blocks of ``doc``, each with the marker on the nearest non-blank line before it."""
    lines = doc.read_text(encoding="utf-8").splitlines()
    found: list[Block] = []
    i = 0
    while i < len(lines):
        m = _FENCE.match(lines[i])
        if m is None:
            i += 1
            continue
        start = i
        end = next((j for j in range(i + 1, len(lines)) if lines[j].strip() == "```"), None)
        assert end is not None, f"{doc.relative_to(ROOT)}:{start + 1}: a code block that is never closed"
        before = next((lines[j] for j in range(start - 1, -1, -1) if lines[j].strip()), "")
        marker = _MARKER.match(before.strip())
        code = "\n".join(line[len(m["indent"]):] for line in lines[start + 1:end]) + "\n"
        found.append(Block(doc, start + 2, m["lang"], code, marker["target"] if marker else None))
        i = end + 1
    return found


ALL = [b for doc in DOCS for b in blocks(doc)]


def _ids(items: list[Block]) -> list[str]:
    return [str(b) for b in items]


@pytest.fixture(scope="module")
def root_view(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A folder that looks like the repository root: each top-level entry linked, ``out/`` not."""
    view = tmp_path_factory.mktemp("root")
    for entry in ROOT.iterdir():
        if entry.name not in ("out", ".git"):
            (view / entry.name).symlink_to(entry)
    return view


def _env() -> dict[str, str]:
    env = dict(os.environ)
    env["PATH"] = f"{Path(sys.executable).parent}{os.pathsep}{env.get('PATH', '')}"
    env.pop("PYTHONHASHSEED", None)
    return env


# --- the docs are well formed ---------------------------------------------------------------------------


def test_every_block_says_what_it_is() -> None:
    unlabelled = [f"{b} ```{b.lang}" for b in ALL if b.lang not in LANGUAGES]
    assert not unlabelled, f"label each block as one of {LANGUAGES}: {unlabelled}"


@pytest.mark.parametrize("block", [b for b in ALL if b.tested_by], ids=_ids([b for b in ALL if b.tested_by]))
def test_marker_points_at_an_existing_test(block: Block) -> None:
    path, _, name = block.tested_by.partition("::")  # type: ignore[union-attr]
    target = ROOT / path
    assert target.is_file(), f"{block}: marker names {path}, which does not exist"
    assert name, f"{block}: the marker must name a test: {path}::test_..."
    defined = {node.name for node in ast.walk(ast.parse(target.read_text(encoding="utf-8")))
               if isinstance(node, ast.FunctionDef | ast.ClassDef)}
    assert name.split("[")[0] in defined, f"{block}: {path} defines no {name}"


def test_markers_stand_before_blocks_that_run_otherwise() -> None:
    """A marker on a ```text block says nothing (it never runs); on a runnable block it replaces running it."""
    misplaced = [str(b) for b in ALL if b.tested_by and b.lang == "text"]
    assert not misplaced


# --- the blocks run ---------------------------------------------------------------------------------------


def _python_docs() -> list[Path]:
    return [doc for doc in DOCS if any(b.lang == "python" and not b.tested_by for b in blocks(doc))]


def _as_module(doc: Path) -> str:
    """The doc's runnable Python blocks as one module, each at its own line number (tracebacks point
    into the doc)."""
    lines: list[str] = []
    for b in blocks(doc):
        if b.lang != "python" or b.tested_by:
            continue
        lines += [""] * (b.line - 1 - len(lines))
        lines += b.code.splitlines()
    return "\n".join(lines) + "\n"


def _defines_tests(source: str) -> bool:
    return any(isinstance(node, ast.FunctionDef | ast.ClassDef) and node.name.lower().startswith("test")
               for node in ast.parse(source).body)


#: The doc tests' own hypothesis profile: an example must work, not find bugs (the suite fuzzes elsewhere).
_CONFTEST = """\
from hypothesis import settings
settings.register_profile("docs", parent=settings.get_profile("vcran"), max_examples=5, stateful_step_count=10)
settings.load_profile("docs")
"""


@pytest.mark.slow
@pytest.mark.parametrize("doc", _python_docs(), ids=[str(d.relative_to(ROOT)) for d in _python_docs()])
def test_python_blocks_run(doc: Path, root_view: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    source = _as_module(doc)
    if _defines_tests(source):
        _run_as_test_module(doc, source, root_view, tmp_path)
        return
    monkeypatch.chdir(root_view)
    namespace: dict[str, object] = {"__name__": "__docs__"}
    found = blocks(doc)
    for i, b in enumerate(found):
        if b.lang != "python" or b.tested_by:
            continue
        code = compile("\n" * (b.line - 1) + b.code, str(doc), "exec")
        printed = io.StringIO()
        with redirect_stdout(printed):
            exec(code, namespace)  # noqa: S102 - the docs' own code
        shown = found[i + 1] if i + 1 < len(found) and found[i + 1].lang == "text" else None
        if printed.getvalue() and shown is not None:  # output shown right after the block is what it prints
            assert printed.getvalue().rstrip() == shown.code.rstrip(), f"{shown}: not what {b} prints"


def _run_as_test_module(doc: Path, source: str, root_view: Path, tmp_path: Path) -> None:
    name = re.sub(r"\W", "_", str(doc.relative_to(ROOT)))
    module = tmp_path / f"test_{name}.py"
    module.write_text(source, encoding="utf-8")
    (tmp_path / "conftest.py").write_text(_CONFTEST, encoding="utf-8")
    result = subprocess.run(
        [sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", "--rootdir", str(tmp_path), str(module)],
        cwd=root_view, env=_env(), capture_output=True, text=True, timeout=600,
    )
    assert result.returncode == 0, f"{doc.relative_to(ROOT)} as a test module:\n{result.stdout}\n{result.stderr}"
    assert re.search(r"\b[1-9]\d* passed\b", result.stdout), result.stdout


_SH = [b for b in ALL if b.lang == "sh" and not b.tested_by]


@pytest.mark.slow
@pytest.mark.parametrize("block", _SH, ids=_ids(_SH))
def test_sh_blocks_run(block: Block, root_view: Path) -> None:
    result = subprocess.run(["bash", "-e", "-o", "pipefail", "-c", block.code], cwd=root_view, env=_env(),
                            capture_output=True, text=True, timeout=600)
    assert result.returncode == 0, f"{block}:\n{block.code}\nexit {result.returncode}\n{result.stdout}\n{result.stderr}"


_TOML = [b for b in ALL if b.lang == "toml" and not b.tested_by]


@pytest.mark.parametrize("block", _TOML, ids=_ids(_TOML))
def test_toml_blocks_are_scenarios_that_load_and_validate(block: Block) -> None:
    import tomllib

    import jsonschema

    from vcran.io.scenario_schema import scenario_schema

    data = tomllib.loads(block.code)
    parse(data, str(block))
    jsonschema.validate(json.loads(json.dumps(data)), scenario_schema())


# --- what the docs say about the repository holds ------------------------------------------------------------


def test_the_quick_start_test_command_is_what_ci_runs() -> None:
    """README's quick start says its second command is what .ci/run calls."""
    quick_start = next(b for b in blocks(ROOT / "README.md") if b.lang == "sh")
    ci = (ROOT / ".ci" / "run").read_text(encoding="utf-8").strip().splitlines()[-1]
    assert ci in quick_start.code.splitlines()


_CITED = re.compile(r"\btests/[\w/]+\.py\b")


def test_cited_test_files_exist() -> None:
    """Docs and docstrings that name a test file name one that exists."""
    sources = [*DOCS, *sorted((ROOT / "vcran").rglob("*.py")), *sorted((ROOT / "transports").rglob("*.py"))]
    missing = sorted({f"{src.relative_to(ROOT)}: {cited}" for src in sources
                      for cited in _CITED.findall(src.read_text(encoding="utf-8")) if not (ROOT / cited).is_file()})
    assert missing == []
