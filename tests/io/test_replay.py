"""Replay and verification (SPEC §6): a run's own trace reproduces it; any tampering is found and named."""

from __future__ import annotations

import json
import struct

import pytest

from tests.conftest import ROOT, run_scenario
from tests.sim.test_scenarios import action, cancel, motion, script
from vcran.cli import main
from vcran.io.scenario_file import load


@pytest.fixture
def demo_run(tmp_path):
    out = tmp_path / "rec"
    run_scenario(load(ROOT / "scenarios" / "demo.toml"), out)
    return out


def replay(trace, out, *extra):
    return main(["replay", str(trace), "--out", str(out), "--verify", "--quiet", *extra])


def test_demo_trace_replays_identically(demo_run, tmp_path):
    assert replay(demo_run / "trace.jsonl", tmp_path / "rep") == 0
    for name in ("trace.jsonl", "telemetry.bin", "events.jsonl", "summary.json"):
        if name == "trace.jsonl":  # the header's options name the transport; every record matches
            a = (demo_run / name).read_text().splitlines()[1:]
            b = (tmp_path / "rep" / name).read_text().splitlines()[1:]
            assert a == b
        else:
            assert (demo_run / name).read_bytes() == (tmp_path / "rep" / name).read_bytes()


def test_rejections_timeouts_and_cancels_replay_identically(run_toml, tmp_path):
    out = run_toml(script(
        motion(1, "A", "A_m1", 1, 3, 5, 0), motion(1, "A", "A_m2", 2, 3, 5, 5), action(2, "A", "A_a1", 3, 3),
        motion(2, "B", "B_m1", 1, 2, 1, 0),  # times out
        cancel(3, "A"), cancel(4, "nope"), motion(5, "nope", "n_m1", 1, 1, 0, 0),
        motion(6, "C", "C_m1", 1, 2, 0, 0), motion(6, "C", "C_m1", 1, 2, 0, 0), action(6, "C", "C_a1", 2, 2),
    ))
    assert out.summary["errors"] == 2
    assert replay(out.dir / "trace.jsonl", tmp_path / "rep") == 0


def rewrite(path, change):
    lines = path.read_text().splitlines()
    for i, line in enumerate(lines[1:], start=1):
        record = json.loads(line)
        if change(record):
            lines[i] = json.dumps(record)
            break
    else:
        raise AssertionError("nothing changed")
    path.write_text("\n".join(lines) + "\n")


def test_tampered_outbound_record_is_the_first_difference(demo_run, tmp_path, capsys):
    def change(r):
        if r.get("attr") == "assignment_status" and r["t"] > 20:
            r["value"]["last_finished_motion"]["description"] = "forged"
            return True
        return False

    rewrite(demo_run / "trace.jsonl", change)
    assert replay(demo_run / "trace.jsonl", tmp_path / "rep") == 1
    err = capsys.readouterr().err
    assert "robot=robot_1" in err and "attribute=assignment_status" in err
    assert "value.last_finished_motion.description" in err and '"forged"' in err


def test_tampered_telemetry_names_tick_robot_and_field(demo_run, tmp_path, capsys):
    path = demo_run / "telemetry.bin"
    data = bytearray(path.read_bytes())
    row = 6 * 8  # t + 5 fields, one robot
    offset = 10 * row + 2 * 8  # tick 10, field y
    data[offset:offset + 8] = struct.pack("<d", 123.0)
    path.write_bytes(bytes(data))
    assert replay(demo_run / "trace.jsonl", tmp_path / "rep") == 1
    assert "telemetry.bin: first difference at t=10.0 robot=robot_1 attribute=current_motion field y" in capsys.readouterr().err


def test_tampered_state_transition_is_found(demo_run, tmp_path, capsys):
    path = demo_run / "events.jsonl"
    text = path.read_text().replace('"to":"ACTION"', '"to":"MOTION"', 1)
    path.write_text(text)
    assert replay(demo_run / "trace.jsonl", tmp_path / "rep") == 1
    assert "events.jsonl" in capsys.readouterr().err


def cut_off(run, t_cut: float, tamper: bool = False) -> None:
    """Leave ``run`` as a killed live run leaves its folder: everything up to ``t_cut``, then half a line
    of trace and events and half a telemetry row, and no end record (issue 12 item 8)."""
    for name in ("trace.jsonl", "events.jsonl"):
        path = run / name
        text = path.read_text().splitlines(keepends=True)
        keep = [line for i, line in enumerate(text) if (name == "trace.jsonl" and i == 0)
                or ("t" in json.loads(line) and json.loads(line).get("dir") != "end" and json.loads(line)["t"] <= t_cut)]
        rest = text[len(keep)]
        if tamper and name == "trace.jsonl":
            keep[-1] = keep[-1].replace('"robot_1"', '"robot_9"')
        path.write_text("".join(keep) + rest[: len(rest) // 2])
    data = (run / "telemetry.bin").read_bytes()
    rows = [data[i:i + 48] for i in range(0, len(data), 48)]  # t + 5 fields of the one robot
    whole = [row for row in rows if struct.unpack("<d", row[:8])[0] <= t_cut]
    (run / "telemetry.bin").write_bytes(b"".join(whole) + rows[len(whole)][:20])


def test_a_killed_recording_replays_and_verifies_as_far_as_it_goes(demo_run, tmp_path, capsys):
    cut_off(demo_run, 40.0)
    assert main(["replay", str(demo_run / "trace.jsonl"), "--out", str(tmp_path / "rep"), "--verify"]) == 0
    out, err = capsys.readouterr()
    assert "no end record" in err and "t=40" in err and "as far as it goes" in out
    replayed = [json.loads(line) for line in (tmp_path / "rep" / "trace.jsonl").read_text().splitlines()[1:]]
    assert replayed[-1] == {"t": 40.0, "dir": "end"}  # up to the last recorded instant, not beyond


def test_a_killed_recording_still_shows_a_difference(demo_run, tmp_path, capsys):
    cut_off(demo_run, 40.0, tamper=True)
    assert replay(demo_run / "trace.jsonl", tmp_path / "rep") == 1
    assert "trace.jsonl: first difference" in capsys.readouterr().err


def test_malformed_inbound_record_names_the_line(demo_run, tmp_path, capsys):
    rewrite(demo_run / "trace.jsonl", lambda r: r.get("dir") == "in" and bool(r["value"].pop("sequence")))
    assert replay(demo_run / "trace.jsonl", tmp_path / "rep") == 2
    err = capsys.readouterr().err
    assert "trace.jsonl:" in err and "sequence" in err and "missing" in err


def test_recording_without_duration_replays(demo_run, tmp_path):
    """A live run of a scenario with no duration records until_idle false and no duration (live runs
    until a signal); its end record alone says when to stop (review finding)."""
    path = demo_run / "trace.jsonl"
    lines = path.read_text().splitlines()
    header = json.loads(lines[0])
    header["fleet"]["simulation"].pop("duration", None)
    header["fleet"]["simulation"]["until_idle"] = False
    path.write_text("\n".join([json.dumps(header), *lines[1:]]) + "\n")
    assert replay(path, tmp_path / "rep") == 0
