"""The package's layout: README's "Layout" table names every file of the package, and only those (issue 9); one
way to wire a run, and no long module that is not one named concept (issue 30)."""

from __future__ import annotations

import ast
import re
import subprocess

from tests.conftest import ROOT


def _readme_files() -> set[str]:
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    section = text[text.index("## Layout"):]
    section = section[:section.index("\n## ", 1)]
    files = set()
    for folder, modules in re.findall(r"^\| `(vcran/[^`]*)` \| ([^|]+) \|", section, flags=re.M):
        for name in re.findall(r"`([^`]+)`", modules):
            # `name.ext` is a file, `name/` a link to a folder (git lists it as one entry), `name` a module
            files.add(folder + (name if "." in name else name[:-1] if name.endswith("/") else name + ".py"))
    return files


def _package_files() -> set[str]:
    out = subprocess.run(["git", "ls-files", "vcran"], cwd=ROOT, capture_output=True, text=True, check=True)
    return set(out.stdout.split())


def test_readme_layout_lists_exactly_the_package_files():
    readme, package = _readme_files(), _package_files()
    assert package, "git ls-files vcran found nothing"
    assert sorted(package - readme) == [], "files missing from README's Layout table"
    assert sorted(readme - package) == [], "README's Layout table names files that do not exist"


def test_one_way_to_wire_a_run():
    """Issue 30 item 1: one function builds and runs the model (vcran.runner.execute), and one module stages,
    writes and publishes a run's folder (vcran.io.sinks); every entry point (the commands, vcran.simulate,
    sweeps, fuzzing, replay) goes through them. A second place doing either is how the three copies began."""
    out = subprocess.run(["git", "grep", "-n", "-E", r"\bModel\(|\bstaging\(|write_summary\(|publish\(work",
                          "--", "vcran", "transports"], cwd=ROOT, capture_output=True, text=True, check=True)
    where = sorted({line.split(":", 1)[0] for line in out.stdout.splitlines()
                    if not line.split(":", 2)[2].lstrip().startswith(("def ", "#"))})
    # the sweep's folder is a sweep's, staged with what="sweep" by the same vcran.io.runfolder
    assert where == ["vcran/io/sinks.py", "vcran/runner.py", "vcran/sweep/folder.py"]


def test_a_module_over_450_lines_names_its_one_concept():
    """Issue 30 item 4: no file of the package (or of transports/) is longer than 450 lines unless it is one
    concept, named as such in its docstring ("One concept ..."): a long module is a choice written down, not
    one that grew."""
    out = subprocess.run(["git", "ls-files", "vcran", "transports"], cwd=ROOT, capture_output=True, text=True,
                         check=True)
    unnamed = []
    for name in out.stdout.split():
        if not name.endswith(".py"):
            continue
        text = (ROOT / name).read_text(encoding="utf-8")
        if text.count("\n") > 450 and "one concept" not in (ast.get_docstring(ast.parse(text)) or "").lower():
            unnamed.append(name)
    assert unnamed == [], "modules over 450 lines whose docstring names no one concept: split them, or name it"
