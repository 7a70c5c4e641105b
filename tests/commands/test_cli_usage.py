"""Usage mistakes on the command line (issue 29 item 8; README "Exit status"): a typo'd option or command is
named first, before whatever else it made go wrong (a required option then missing), with the nearest
spelling, as one line and exit status 2, for every subcommand. Options are spelled in full: a prefix is
an unknown option too (argparse's ``allow_abbrev`` is off, so that a script's options keep their meaning
when a command gains options)."""

from __future__ import annotations

import argparse
from pathlib import Path

import pytest

from tests.commands.test_cli_errors import vcran
from vcran import cli


def _long_options(command: str) -> list[str]:
    """Every ``--option`` of ``vcran COMMAND``, as its parser has them (``--help`` at least)."""
    parser = cli.build_parser(command)
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction)).choices[command]
    return [o for a in sub._actions for o in a.option_strings if o.startswith("--")]


def test_the_issues_two_typos_are_named_with_the_option_meant(capsys: pytest.CaptureFixture[str],
                                                               tmp_path: Path) -> None:
    """The issue's words: ``--outt`` was reported as a missing ``--out``; ``--quite`` is ``--quiet``."""
    out = str(tmp_path / "x")
    assert vcran(capsys, "run", "demo", "--outt", out) == (
        2, "", "vcran run: unknown option --outt (did you mean --out?) (see vcran run --help)\n")
    assert vcran(capsys, "run", "demo", "--out", out, "--quite") == (
        2, "", "vcran run: unknown option --quite (did you mean --quiet?) (see vcran run --help)\n")
    assert not Path(out).exists()  # nothing ran


@pytest.mark.parametrize("command", list(cli.COMMANDS))
def test_every_commands_options_typod_are_named_first(capsys: pytest.CaptureFixture[str], command: str) -> None:
    """Each option of each command with its last letter doubled (``--out`` -> ``--outt``), given alone so
    that the command's required arguments are missing too: the typo is what the line names, and the
    option it came from is the suggestion (the doubled letter is the only difference)."""
    prefix = [command, "init"] if command == "orion" else [command]  # orion's action comes first
    options = _long_options(command)
    assert options, command
    for option in options:
        typo = option + option[-1]
        code, out, err = vcran(capsys, *prefix, typo)
        assert (code, out) == (2, ""), (command, option)
        assert err == f"vcran {command}: unknown option {typo} (did you mean {option}?) (see vcran {command} --help)\n"


def test_an_option_far_from_every_other_is_named_without_a_guess(capsys: pytest.CaptureFixture[str]) -> None:
    assert vcran(capsys, "run", "demo", "--xyzzy") == (
        2, "", "vcran run: unknown option --xyzzy (see vcran run --help)\n")


def test_two_unknown_options_are_both_named(capsys: pytest.CaptureFixture[str]) -> None:
    assert vcran(capsys, "gen", "--robotss", "2", "--hourz=1")[2] == (
        "vcran gen: unknown options --robotss (did you mean --robots?), --hourz (did you mean --hours?) "
        "(see vcran gen --help)\n")


def test_an_abbreviation_is_an_unknown_option(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    """``--ou`` for ``--out`` ran before (argparse's allow_abbrev); now it is named, with what it is short
    for, and nothing runs."""
    out = tmp_path / "x"
    assert vcran(capsys, "run", "demo", "--ou", str(out), "--quiet") == (
        2, "", "vcran run: unknown option --ou (did you mean --out?) (see vcran run --help)\n")
    assert not out.exists()


def test_values_that_look_like_options_are_not_named(capsys: pytest.CaptureFixture[str]) -> None:
    """``-`` (stdin), a negative number and anything after ``--`` are values, as argparse takes them: the
    error is argparse's own."""
    assert vcran(capsys, "gen", "--robots", "-2", "--hours", "1")[2] == (
        "vcran gen: --robots must be at least 1, got -2\n")
    code, _, err = vcran(capsys, "report", "--out", "r", "--", "--not-an-option")
    assert code == 2 and "unknown option" not in err


def test_a_typod_command_is_named_with_the_command_meant(capsys: pytest.CaptureFixture[str]) -> None:
    assert vcran(capsys, "rn", "demo", "--out", "x") == (
        2, "", "vcran: unknown command 'rn' (did you mean 'run'?) (see vcran --help)\n")
    assert vcran(capsys, "frobnicate") == (2, "", "vcran: unknown command 'frobnicate' (see vcran --help)\n")


def test_a_typod_choice_is_named_with_the_choice_meant(capsys: pytest.CaptureFixture[str]) -> None:
    """The positional choices: ``orion init|delete``, ``schema scenario``, ``--format png|svg``."""
    assert vcran(capsys, "orion", "int", "demo", "--orion", "http://127.0.0.1:9")[2] == (
        "vcran orion: argument action: invalid choice: 'int' (did you mean 'init'? choose from 'init', 'delete') "
        "(see vcran orion --help)\n")
    assert vcran(capsys, "schema", "scenarios")[2] == (
        "vcran schema: argument format: invalid choice: 'scenarios' (did you mean 'scenario'? choose from "
        "'scenario') (see vcran schema --help)\n")


def test_an_unknown_option_before_the_command_is_vcrans(capsys: pytest.CaptureFixture[str]) -> None:
    assert vcran(capsys, "--verison", "run", "demo") == (
        2, "", "vcran: unknown option --verison (did you mean --version?) (see vcran --help)\n")
