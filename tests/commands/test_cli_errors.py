"""The CLI's one error boundary (README "Exit status"; issue 13 item 5, issue 16): every bad input ends as
one line ``vcran COMMAND: message`` and exit status 2, never a traceback; a bug is one line and 70."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from tests.conftest import ROOT
from tests.io.test_scenario_jobs import FLEET, job
from vcran import __version__, cli

DEMO = str(ROOT / "scenarios" / "demo.toml")

#: One robot, one motion at ``t`` seconds, a run of ``duration`` seconds; ``extra`` is appended.
SCENARIO = """\
[simulation]
duration = {duration}
[[robots]]
id = "r1"
[[script]]
t = {t}
robot = "r1"
kind = "motion"
task = "T"
id = "T_m1"
seq = [1, 1]
point = [1.0, 0.0, 0.0]
{extra}"""


def vcran(capsys: pytest.CaptureFixture[str], *argv: str) -> tuple[int, str, str]:
    """``vcran ARGV`` in this process: exit status, stdout, stderr."""
    try:
        code = cli.main(list(argv))
    except SystemExit as exc:  # argparse's own exits (--help, --version, usage errors)
        code = exc.code if isinstance(exc.code, int) else 1
    out, err = capsys.readouterr()
    return code, out, err


def scenario_file(tmp_path: Path, *, t: float = 1.0, duration: float = 60.0, extra: str = "") -> Path:
    path = tmp_path / "s.toml"
    path.write_text(SCENARIO.format(t=t, duration=duration, extra=extra), encoding="utf-8")
    return path


def read_only_folder(tmp_path: Path) -> Path:
    """A folder nobody may create anything in. root ignores permission bits, so as root it is /sys
    (mounted read-only for new entries on Linux)."""
    if os.geteuid() == 0:
        return Path("/sys")
    folder = tmp_path / "locked"
    folder.mkdir()
    folder.chmod(0o500)
    return folder


def _bad_inputs(tmp_path: Path) -> list[tuple[list[str], str, str]]:
    """(argv, command, what the message must say); each a mistake a user has made."""
    a_file = tmp_path / "a_file"
    a_file.write_text("x", encoding="utf-8")
    not_utf8 = tmp_path / "latin1.toml"
    not_utf8.write_bytes('[simulation]\nname = "café"\n'.encode("latin-1"))
    empty = tmp_path / "empty"
    empty.mkdir()
    huge = "9" * 5000
    for sub in ("raw_text", "late"):
        (tmp_path / sub).mkdir()
    raw_text = scenario_file(tmp_path / "raw_text", extra=f"""
[[script]]
t = 2.0
robot = "r1"
kind = "raw"
attribute = "motion_assignment"
value = '{{"type": "x", "value": {huge}}}'
""")
    bom = tmp_path / "bom.toml"  # what Notepad saves as "UTF-8"
    bom.write_bytes(b"\xef\xbb\xbf" + (ROOT / "scenarios" / "demo.toml").read_bytes())
    raw_toml = tmp_path / "raw_toml.toml"
    raw_toml.write_text(f"[simulation]\nduration = 1.0\nx = {huge}\n", encoding="utf-8")
    late = scenario_file(tmp_path / "late", t=61.0, duration=60.0)
    (tmp_path / "far").mkdir()
    far = scenario_file(tmp_path / "far", t=1e308, duration=60.0)  # t * 1e9 overflowed: exit 70
    stalling = tmp_path / "stalling.toml"  # simulated time stopped: faults at one instant forever
    stalling.write_text(SCENARIO.format(t=1.0, duration=60.0, extra='[[random_faults]]\nkind = "motion_failure"\n'
                                                                   'mtbf = 1e-300\n'), encoding="utf-8")
    bad_ip = ["--orion", "http://256.0.0.1:1026"]  # urlsplit takes it, httpx refuses it (exit 70)
    orion = ["--orion", "http://127.0.0.1:9"]
    out = str(tmp_path / "out")
    recording = tmp_path / "recording"
    assert cli.main(["run", DEMO, "--out", str(recording), "--quiet"]) == 0
    locked = read_only_folder(tmp_path)
    return [
        (["replay", str(recording), "--out", str(locked / "vcran-out")], "replay", "vcran-out: "),
        (["replay", str(recording), "--out", str(a_file)], "replay", f"{a_file}: exists and is not a folder"),
        (["report", str(recording), "--out", str(locked / "vcran-out")], "report", "vcran-out: "),
        (["report", str(recording), "--out", str(a_file / "sub")], "report", f"{a_file / 'sub'}: Not a directory"),
        (["run", DEMO, "--out", out, "--manager", "vcran.managers:Dispatcher"], "run",
         "has a [[script]] that would play it too"),
        (["run", DEMO, "--out", out, "--manager", "no colon"], "run", "expected 'module:Class'"),
        (["run", str(tmp_path), "--out", out], "run", f"{tmp_path}: is a folder, not a scenario file"),
        (["run", str(not_utf8), "--out", out], "run", f"{not_utf8}: not UTF-8 text"),
        (["run", str(bom), "--out", out], "run", f"{bom}: starts with a byte-order mark, which TOML does not allow"),
        (["run", DEMO, "--out", out, "--fast"], "run", "unknown option --fast (see vcran run --help)"),
        (["run", DEMO, "again", "--out", out], "run", "unrecognized arguments: again (see vcran run --help)"),
        (["run", DEMO, "--out", str(a_file)], "run", f"{a_file}: exists and is not a folder"),
        (["run", DEMO, "--out", str(a_file / "sub")], "run",
         f"{a_file / 'sub'}: cannot create sub.incomplete beside it to write the run in: Not a directory"),
        (["run", DEMO, "--out", str(locked / "vcran-out")], "run", "vcran-out: "),
        (["replay", str(empty), "--out", out], "replay", f"{empty}: a folder without trace.jsonl.zst"),
        (["run", str(raw_text), "--out", out], "run", "field 'value': not valid JSON: Exceeds the limit (4300 digits)"),
        (["run", str(raw_toml), "--out", out], "run", f"{raw_toml}: not valid TOML: Exceeds the limit (4300 digits)"),
        (["run", str(late), "--out", out], "run", "the entry is sent at t = 61, after the run ends (duration = 60)"),
        (["run", str(far), "--out", out], "run",
         "script[0]: field 't': 1e+308 s is later than a message's time stamp can say (int32 seconds"),
        (["run", str(stalling), "--out", out], "run",
         "random_faults[0]: field 'mtbf': must be at least 1e-06 s (R14: instants closer than 1 µs are one instant), "
         "got 1e-300"),
        (["live", DEMO, *bad_ip, "--out", out], "live", "not a valid URL (Invalid IPv4 address: '256.0.0.1')"),
        (["send", DEMO, *bad_ip], "send", "not a valid URL (Invalid IPv4 address: '256.0.0.1')"),
        (["orion", "init", DEMO, *bad_ip], "orion", "not a valid URL (Invalid IPv4 address: '256.0.0.1')"),
        (["manage", "warehouse", *bad_ip], "manage", "not a valid URL (Invalid IPv4 address: '256.0.0.1')"),
        (["live", DEMO, *orion, "--out", out, "--notify-url", "http://256.0.0.1:8000/n"], "live",
         "--notify-url 'http://256.0.0.1:8000/n': not a valid URL (Invalid IPv4 address"),
        # inf divided by zero (live --factor: exit 70, an .incomplete folder left) or overflowed the poll loop
        (["live", DEMO, *orion, "--out", out, "--factor", "inf"], "live", "--factor must be a finite number above 0, got inf"),
        (["live", DEMO, *orion, "--out", out, "--factor", "nan"], "live", "--factor must be a finite number above 0, got nan"),
        (["live", DEMO, *orion, "--out", out, "--poll-interval", "inf"], "live",
         "--poll-interval must be a finite number above 0, got inf"),
        # docs/live.md: an inbound option that would do nothing is refused by live --orion as by manage --orion
        (["live", DEMO, *orion, "--out", out, "--listen", "0.0.0.0"], "live",
         "--listen is where the notification listener binds: it needs --notify-url"),
        (["live", DEMO, *orion, "--out", out, "--notify-url", "http://127.0.0.1:8765/n", "--poll-interval", "1"], "live",
         "--poll-interval is the polling period: without --notify-url only"),
        (["manage", "warehouse", *orion, "--listen", "0.0.0.0"], "manage",
         "--listen is where the notification listener binds: it needs --notify-url"),
        (["manage", "warehouse", *orion, "--factor", "inf"], "manage", "--factor must be a finite number above 0, got inf"),
        (["manage", "warehouse", *orion, "--poll-interval", "inf"], "manage",
         "--poll-interval must be a finite number above 0, got inf"),
        (["send", DEMO, *orion, "--factor", "inf"], "send", "--factor must be a finite number above 0, got inf"),
        (["gen", "--robots", "2", "--hours", "inf", "--seed", "1"], "gen", "--hours must be a finite number above 0, got inf"),
        (["gen", "--robots", "2", "--hours", "nan", "--seed", "1"], "gen", "--hours must be a finite number above 0, got nan"),
        # a run shorter than the fleet's first cycle starts: vcran gen printed a file vcran run refused
        (["gen", "--robots", "2", "--hours", "0.0001", "--seed", "1"], "gen",
         "--hours 0.0001 is 0.36 s of simulated time; the fleet's first cycles start until 1.02 s: give at least that"),
        (["decode", str(empty)], "decode", f"{empty}: Is a directory"),
        (["live", DEMO, "--orion", "http://127.0.0.1:9", "--out", out, "--token-file", str(tmp_path / "no-token")],
         "live", f"cannot read --token-file {tmp_path / 'no-token'}: No such file or directory"),
        # Orion refuses every request of such a tenant or path (400): live ran to its end with "Orion down",
        # send failed each message at its time and orion init at the first; vcran knows Orion's rules
        (["send", DEMO, *orion, "--service-path", "factory"], "send",
         "--service-path 'factory': Only /absolute/ Service Paths allowed [a service path must begin with /]"),
        (["live", DEMO, *orion, "--out", out, "--service-path", "/factory/#"], "live",
         "--service-path '/factory/#': Bad Character in Service-Path (vcran writes entities: one plain path)"),
        (["orion", "init", DEMO, *orion, "--service-path", "/a,/b"], "orion",
         "--service-path '/a,/b': Bad Character in Service-Path (vcran writes entities: one plain path)"),
        (["manage", "warehouse", *orion, "--service", "plant-a"], "manage",
         "--service 'plant-a': bad character in tenant name - only underscore and alphanumeric characters are allowed"),
        (["run", str(tmp_path / "nope.toml"), "--out", out], "run", "nope.toml: no such file"),
        (["run", DEMO], "run", "the following arguments are required: --out"),
    ]


def test_every_bad_input_is_one_line_and_exit_2(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    for argv, command, message in _bad_inputs(tmp_path):
        code, out, err = vcran(capsys, *argv)
        assert (code, out) == (2, ""), (argv, code, out, err)
        assert err.startswith(f"vcran {command}: ") and err.count("\n") == 1, (argv, err)
        assert message in err, (argv, err)
        assert "Traceback" not in err


def test_nothing_is_written_for_a_scenario_that_does_not_load(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    late = scenario_file(tmp_path, t=61.0, duration=60.0)
    assert vcran(capsys, "run", str(late), "--out", str(tmp_path / "out"))[0] == 2
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("where, key", [
    ("simulation", "seed"), ("simulation", "history_limit"), ("robots[0]", "capacity"), ("stations[0]", "produce_limit"),
])
@pytest.mark.parametrize("value", [2**63, -(2**63) - 1, 10**20])
def test_an_integer_past_tomls_64_bits_is_refused_at_load(capsys: pytest.CaptureFixture[str], tmp_path: Path,
                                                          where: str, key: str, value: int) -> None:
    """TOML's integers are 64-bit; tomllib reads longer ones, which the trace header (orjson) cannot write:
    ``seed = 99999999999999999999`` was "a bug in vcran" (exit 70) and left ``out.incomplete`` behind."""
    tables = {"simulation": "[simulation]\nduration = 60.0\n", "robots[0]": '[[robots]]\nid = "r1"\n',
              "stations[0]": '[[stations]]\nid = "s"\nposition = [0.0, 0.0]\n'}
    tables[where] += f"{key} = {value}\n"
    path = tmp_path / "s.toml"
    path.write_text("".join(tables.values()), encoding="utf-8")
    code, out, err = vcran(capsys, "run", str(path), "--out", str(tmp_path / "out"))
    assert (code, out) == (2, ""), err
    assert err == f"vcran run: {path}: {where}: field {key!r}: {value} is outside TOML's 64-bit integer range\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["s.toml"]  # no out, no out.incomplete


def test_nothing_is_written_for_a_run_refused_for_its_fleet_manager(capsys: pytest.CaptureFixture[str],
                                                                    tmp_path: Path) -> None:
    """A script and a manager, or jobs and none: refused before the output folder exists."""
    jobs_only = tmp_path / "jobs.toml"
    jobs_only.write_text(FLEET + job(1, "j1"), encoding="utf-8")
    for argv, says in [(["run", DEMO, "--manager", "vcran.managers:Dispatcher"], "would play it too"),
                       (["run", str(jobs_only)], "no fleet manager to give them to")]:
        code, _, err = vcran(capsys, *argv, "--out", str(tmp_path / "out"))
        assert code == 2 and says in err, err
        assert not (tmp_path / "out").exists()


def test_an_entry_at_the_last_instant_still_loads(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    """The bound is inclusive: a message at exactly ``duration`` is played (inbound first within an instant)."""
    code, _, err = vcran(capsys, "run", str(scenario_file(tmp_path, t=60.0, duration=60.0)), "--out", str(tmp_path / "o"), "--quiet")
    assert (code, err) == (0, "")


def test_a_real_process_shows_no_traceback(tmp_path: Path) -> None:
    """The same boundary when run as a program (stderr as the user's terminal gets it)."""
    result = subprocess.run([sys.executable, "-m", "vcran", "run", str(tmp_path), "--out", str(tmp_path / "o")],
                            capture_output=True, text=True, timeout=60)
    assert (result.returncode, result.stdout) == (2, "")
    assert result.stderr == f"vcran run: {tmp_path}: is a folder, not a scenario file\n"


def test_bare_vcran_prints_help_and_exits_0(capsys: pytest.CaptureFixture[str]) -> None:
    code, out, err = vcran(capsys)
    assert (code, err) == (0, "")
    assert out.startswith("usage: vcran") and "Exit status:" in out
    assert all(name in out for name in cli.COMMANDS)


def test_version(capsys: pytest.CaptureFixture[str]) -> None:
    assert vcran(capsys, "--version") == (0, f"vcran {__version__}\n", "")


def test_a_bug_is_one_line_exit_70_and_debug_shows_it(capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch,
                                                      tmp_path: Path) -> None:
    def broken(*_args: object, **_kw: object) -> None:
        raise KeyError("oops")

    monkeypatch.setattr("vcran.api.execute", broken)
    code, out, err = vcran(capsys, "run", DEMO, "--out", str(tmp_path / "o"))
    assert (code, out) == (70, "")
    assert err == "vcran run: internal error (a bug in vcran; VCRAN_DEBUG=1 shows where): KeyError: 'oops'\n"
    monkeypatch.setenv("VCRAN_DEBUG", "1")
    with pytest.raises(KeyError):
        cli.main(["run", DEMO, "--out", str(tmp_path / "o")])


def test_a_fleet_manager_that_raises_is_its_bug_not_vcrans(capsys: pytest.CaptureFixture[str],
                                                           monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    """One line naming the hook and the time, exit 1 (the run found a failure), not 'a bug in vcran' (70)."""
    argv = ["run", "warehouse", "--out", str(tmp_path / "o"), "--manager", "tests.testing.loop_managers:Raising", "--quiet"]
    code, out, err = vcran(capsys, *argv)
    assert (code, out) == (1, "")
    assert err.startswith("vcran run: the fleet manager raised RuntimeError: my bug (in fleet manager Raising: "
                          "on_job at t=") and err.endswith("; VCRAN_DEBUG=1 shows the traceback)\n")
    assert err.count("\n") == 1
    monkeypatch.setenv("VCRAN_DEBUG", "1")
    with pytest.raises(RuntimeError, match="my bug"):
        cli.main(argv)


def test_a_fleet_manager_that_calls_sys_exit_fails_its_run_like_any_bug(capsys: pytest.CaptureFixture[str],
                                                                         tmp_path: Path) -> None:
    """A hook's sys.exit(3) ended vcran run with exit 3 and no word, its folder left incomplete (a fresh
    user's review): the manager's bug, one line and exit 1 as for a raise (docs/contract.md §9)."""
    argv = ["run", "warehouse", "--out", str(tmp_path / "o"), "--manager", "tests.testing.loop_managers:Exiting", "--quiet"]
    code, out, err = vcran(capsys, *argv)
    assert (code, out) == (1, "")
    assert err.startswith("vcran run: the fleet manager raised RuntimeError: on_job called sys.exit(3) (in fleet "
                          "manager Exiting: on_job at t=")
    assert err.count("\n") == 1


def test_interrupt_is_130(capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    def interrupted(*_args: object, **_kw: object) -> None:
        raise KeyboardInterrupt

    monkeypatch.setattr("vcran.api.execute", interrupted)
    assert vcran(capsys, "run", DEMO, "--out", str(tmp_path / "o")) == (130, "", "vcran run: interrupted\n")


def test_a_closed_pipe_is_no_error() -> None:
    """``vcran gen ... | head -1``: the reader stopped reading; exit 0 and nothing on stderr."""
    result = subprocess.run(f"{sys.executable} -m vcran gen --robots 200 --hours 1 --seed 1 | head -1",
                            shell=True, capture_output=True, text=True, timeout=60,
                            executable="/bin/bash", env={**os.environ, "PYTHONUNBUFFERED": "0"})
    assert result.stdout.count("\n") == 1
    assert result.stderr == ""


def test_an_unknown_option_before_the_command_is_vcrans_not_the_commands(capsys: pytest.CaptureFixture[str]) -> None:
    code, out, err = vcran(capsys, "--bogus", "run", DEMO, "--out", "never")
    assert (code, out, err) == (2, "", "vcran: unknown option --bogus (see vcran --help)\n")
    assert not Path("never").exists()
