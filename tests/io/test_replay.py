"""Replay and verification (docs/contract.md §6): a run's own trace reproduces it; any tampering is found and named."""

from __future__ import annotations

import json
import math
import re
import shutil
import struct

import numpy as np
import pytest

from tests.conftest import ROOT, read_lines, run_scenario, write_lines
from tests.sim.test_scenarios import action, cancel, motion, script
from vcran.cli import main
from vcran.core.opil.ids import id_for
from vcran.io.scenario_file import load
from vcran.io.trace import open_output, trace_records


@pytest.fixture
def demo_run(tmp_path):
    out = tmp_path / "rec"
    run_scenario(load(ROOT / "scenarios" / "demo.toml"), out)
    return out


def replay(trace, out, *extra):
    return main(["replay", str(trace), "--out", str(out), "--verify", "--quiet", *extra])


def test_demo_trace_replays_identically(demo_run, tmp_path):
    assert replay(demo_run / "trace.jsonl.zst", tmp_path / "rep") == 0
    for name in ("trace.jsonl.zst", "legs.npy", "events.jsonl.zst", "summary.json"):
        if name == "trace.jsonl.zst":  # the header's options name the transport; every record matches
            assert read_lines(demo_run / name)[1:] == read_lines(tmp_path / "rep" / name)[1:]
        else:
            assert (demo_run / name).read_bytes() == (tmp_path / "rep" / name).read_bytes()


def test_format_1_recording_replays_and_verifies(tmp_path):  # docs/contract.md §6: v1 traces still replay
    v1 = tmp_path / "v1"
    shutil.copytree(ROOT / "tests" / "data" / "v1-demo", v1)
    assert replay(v1 / "trace.jsonl", tmp_path / "rep") == 0
    assert (tmp_path / "rep" / "trace.jsonl.zst").exists()  # the replay writes format 2
    assert replay(v1, tmp_path / "rep2") == 0  # the folder names its trace


def test_a_format_1_trace_name_finds_the_format_2_trace_beside_it(demo_run, tmp_path, capsys):
    # `vcran replay DIR/trace.jsonl --verify`, as docs and scripts written before format 2 say (issue 10)
    assert not (demo_run / "trace.jsonl").exists()
    assert main(["replay", str(demo_run / "trace.jsonl"), "--verify", "--quiet"]) == 0
    assert main(["replay", str(tmp_path / "nothing" / "trace.jsonl"), "--verify", "--quiet"]) == 2
    assert "nothing/trace.jsonl: No such file or directory" in capsys.readouterr().err


def test_format_1_tampered_telemetry_is_found_against_the_replayed_legs(tmp_path, capsys):
    v1 = tmp_path / "v1"
    shutil.copytree(ROOT / "tests" / "data" / "v1-demo", v1)
    data = bytearray((v1 / "telemetry.bin").read_bytes())
    row = 6 * 8  # t + 5 fields, one robot
    offset = 12 * row + 1 * 8  # tick 12, field x
    data[offset:offset + 8] = struct.pack("<d", -5.0)
    (v1 / "telemetry.bin").write_bytes(bytes(data))
    assert replay(v1 / "trace.jsonl", tmp_path / "rep") == 1
    assert "telemetry.bin: first difference at t=12.0 robot=robot_1 attribute=current_motion field x" in capsys.readouterr().err


def test_rejections_timeouts_and_cancels_replay_identically(run_toml, tmp_path):
    out = run_toml(script(
        motion(1, "A", "A_m1", 1, 3, 5, 0), motion(1, "A", "A_m2", 2, 3, 5, 5), action(2, "A", "A_a1", 3, 3),
        motion(2, "B", "B_m1", 1, 2, 1, 0),  # times out
        cancel(3, "A"), cancel(4, "nope"), motion(5, "nope", "n_m1", 1, 1, 0, 0),
        motion(6, "C", "C_m1", 1, 2, 0, 0), motion(6, "C", "C_m1", 1, 2, 0, 0), action(6, "C", "C_a1", 2, 2),
    ))
    assert out.summary["errors"] == 2
    assert replay(out.dir / "trace.jsonl.zst", tmp_path / "rep") == 0


def test_a_repeated_inbound_message_is_recorded_and_replayed(run_toml, tmp_path):
    # format 2 leaves out a published value equal to the last one, never an inbound one: the RAN reacts to
    # the repeat (here an error for the second cancel), and a replay must feed it again (fuzz finding)
    partial = cancel(2, "A") + '\nmotion = "A_m1"'
    out = run_toml(script(motion(1, "A", "A_m1", 1, 2, 5, 0), motion(1, "A", "A_m2", 2, 2, 5, 5), partial, partial))
    cancels = [json.loads(line) for line in read_lines(out.dir / "trace.jsonl.zst")
               if '"attr":"cancel_order"' in line]
    assert [c["t"] for c in cancels] == [2.0, 2.0] and cancels[1]["value"] == {}
    assert out.summary["errors"] >= 1  # the second partial cancel is refused (R13)
    assert replay(out.dir / "trace.jsonl.zst", tmp_path / "rep") == 0


def test_a_raw_payload_with_an_integer_beyond_64_bits_replays(run_toml, tmp_path):
    # orjson would read the recorded 10**30 back as the float 1e+30 and the replay would reject it in other
    # words (R12 message), a false difference; raw lines are read by the standard library (fuzz finding)
    raw = 't = 1.0\nkind = "raw"\nattribute = "cancel_order"\nvalue = \'{"type": "x", "value": {"task_id": 1%s}}\'' % ("0" * 30)
    out = run_toml(script(raw))
    (error,) = [r for r in trace_records(out.dir) if r["attr"] == "ran_error"]
    assert "1" + "0" * 30 in error["value"]["message"] or "bit integer" in error["value"]["message"]
    assert replay(out.dir, tmp_path / "rep") == 0


def rewrite(path, change):
    lines = read_lines(path)
    for i, line in enumerate(lines[1:], start=1):
        record = json.loads(line)
        if change(record):
            lines[i] = json.dumps(record)
            break
    else:
        raise AssertionError("nothing changed")
    write_lines(path, lines)


def test_tampered_outbound_record_is_the_first_difference(demo_run, tmp_path, capsys):
    def change(r):
        # format 2 writes only what changed: a record where the last finished motion changed
        if r.get("attr") == "assignment_state" and r["t"] > 20 and "last_finished_motion" in r["value"]:
            r["value"]["last_finished_motion"] = "forged"
            return True
        return False

    rewrite(demo_run / "trace.jsonl.zst", change)
    assert replay(demo_run / "trace.jsonl.zst", tmp_path / "rep") == 1
    err = capsys.readouterr().err
    assert "robot=robot_1" in err and "attribute=assignment_state" in err
    # differences are named in format 1's terms (full values, plain ids): the forged name's uuid
    assert "value.last_finished_motion.uuid" in err and f'expected "{id_for("forged").canonical}"' in err


def without_the_load(path) -> None:
    """``path`` as a vcran from before ran_status carried the load (issue 29 item 4) recorded it."""
    lines = read_lines(path)
    for i, line in enumerate(lines[1:], start=1):
        record = json.loads(line)
        if record.get("attr") == "ran_status":
            record["value"].pop("carrying", None)
            lines[i] = json.dumps(record)
    write_lines(path, lines)


def test_a_recording_made_before_ran_status_carried_the_load_verifies(demo_run, tmp_path, capsys):
    """docs/contract.md §2 added the load to ran_status; a recording without it verifies with it left out, and the
    rest of its records are still compared."""
    trace = demo_run / "trace.jsonl.zst"
    without_the_load(trace)
    assert not any('"ran_status"' in line and '"carrying"' in line for line in read_lines(trace))
    assert replay(trace, tmp_path / "rep") == 0

    def change(r):
        if r.get("attr") == "ran_status" and r["t"] > 20 and "state" in r["value"]:
            r["value"]["state"] = "WAITING" if r["value"]["state"] != "WAITING" else "ACTION"
            return True
        return False

    rewrite(trace, change)
    assert replay(trace, tmp_path / "rep2") == 1
    assert "attribute=ran_status field value.state" in capsys.readouterr().err


def test_tampered_leg_names_leg_robot_and_column(demo_run, tmp_path, capsys):
    path = demo_run / "legs.npy"
    legs = np.load(path)
    legs[1]["y"] = 123.0
    np.save(path, legs)
    assert replay(demo_run / "trace.jsonl.zst", tmp_path / "rep") == 1
    err = capsys.readouterr().err
    assert f"legs.npy: first difference at t={float(legs[1]['t'])!r} robot=robot_1 attribute=current_motion field leg 1.y" in err


def test_tampered_state_transition_is_found(demo_run, tmp_path, capsys):
    path = demo_run / "events.jsonl.zst"
    write_lines(path, [line.replace('"to":"ACTION"', '"to":"MOTION"', 1) for line in read_lines(path)])
    assert replay(demo_run / "trace.jsonl.zst", tmp_path / "rep") == 1
    # an event is named as one (it said "attribute=state")
    assert re.search(r"events\.jsonl\.zst: first difference at t=[0-9.]+ robot=robot_\d event=state field to:",
                     capsys.readouterr().err)


def cut_off(run, t_cut: float, tamper: bool = False) -> None:
    """Leave ``run`` as a killed live run leaves its folder: everything up to ``t_cut``, then half a line
    of trace and events, no end record, and a leg log whose row count was never written (issue 12 item 8)."""
    for name in ("trace.jsonl.zst", "events.jsonl.zst"):
        path = run / name
        text = [line + "\n" for line in read_lines(path)]
        keep = [line for i, line in enumerate(text) if (name == "trace.jsonl.zst" and i == 0)
                or ("t" in json.loads(line) and json.loads(line).get("dir") != "end" and json.loads(line)["t"] <= t_cut)]
        rest = text[len(keep)]
        if tamper and name == "trace.jsonl.zst":
            keep[-1] = keep[-1].replace('"robot_1"', '"robot_9"')
        with open_output(path) as f:
            f.write(("".join(keep) + rest[: len(rest) // 2]).encode())
    legs = np.load(run / "legs.npy")
    kept = legs[legs["t"] <= t_cut].tobytes()
    data = (run / "legs.npy").read_bytes()
    header = data[: len(data) - legs.nbytes].replace(f"({len(legs)},)".encode(), b"(0,)".ljust(len(f"({len(legs)},)")))
    (run / "legs.npy").write_bytes(header + kept + legs[len(kept) // legs.itemsize:].tobytes()[:20])


def test_a_killed_recording_replays_and_verifies_as_far_as_it_goes(demo_run, tmp_path, capsys):
    cut_off(demo_run, 40.0)
    # format 2 writes a record only where something changed: the last instant recorded is the last record's
    last = max(json.loads(line)["t"] for line in read_lines(demo_run / "trace.jsonl.zst")[1:-1])
    assert 30.0 < last <= 40.0
    assert main(["replay", str(demo_run), "--out", str(tmp_path / "rep"), "--verify"]) == 0
    out, err = capsys.readouterr()
    assert "no end record" in err and f"t={last:g}\n" in err and "as far as it goes" in out
    replayed = [json.loads(line) for line in read_lines(tmp_path / "rep" / "trace.jsonl.zst")[1:]]
    assert replayed[-1] == {"t": last, "dir": "end"}  # up to the last recorded instant, not beyond


def test_a_killed_recording_still_shows_a_difference(demo_run, tmp_path, capsys):
    cut_off(demo_run, 40.0, tamper=True)
    assert replay(demo_run, tmp_path / "rep") == 1
    assert "trace.jsonl.zst: first difference" in capsys.readouterr().err


def test_cut_off_compressed_recording_is_refused(demo_run, tmp_path, capsys):
    path = demo_run / "trace.jsonl.zst"
    path.write_bytes(path.read_bytes()[:-40])  # a run killed mid-write leaves an unfinished zstd frame
    assert replay(path, tmp_path / "rep") == 2
    assert "the recording did not finish (was it interrupted?)" in capsys.readouterr().err


def test_malformed_inbound_record_names_the_line(demo_run, tmp_path, capsys):
    rewrite(demo_run / "trace.jsonl.zst", lambda r: r.get("dir") == "in" and bool(r["value"].pop("sequence")))
    assert replay(demo_run / "trace.jsonl.zst", tmp_path / "rep") == 2
    err = capsys.readouterr().err
    assert "trace.jsonl.zst:" in err and "sequence" in err and "missing" in err


def test_recording_without_duration_replays(demo_run, tmp_path):
    """A live run of a scenario with no duration records until_idle false and no duration (live runs
    until a signal); its end record alone says when to stop (review finding)."""
    path = demo_run / "trace.jsonl.zst"
    lines = read_lines(path)
    header = json.loads(lines[0])
    header["fleet"]["simulation"].pop("duration", None)
    header["fleet"]["simulation"]["until_idle"] = False
    write_lines(path, [json.dumps(header), *lines[1:]])
    assert replay(path, tmp_path / "rep") == 0


def test_run_without_any_leg_verifies(run_toml, tmp_path):  # an empty leg log on both sides (fuzz finding)
    out = run_toml(script())
    assert replay(out.dir, tmp_path / "rep") == 0


# --- `vcran replay TRACE --verify` without --out: a temporary folder, removed afterwards ---------------------


@pytest.fixture
def scratch(tmp_path, monkeypatch):
    """The folder tempfile uses, so that a test sees what a replay left there."""
    folder = tmp_path / "scratch"
    folder.mkdir()
    monkeypatch.setattr("tempfile.tempdir", str(folder))
    return folder


def test_verify_without_out_replays_into_a_temporary_folder_and_removes_it(demo_run, scratch, capsys):
    before = sorted(p.name for p in demo_run.iterdir())
    assert main(["replay", str(demo_run / "trace.jsonl.zst"), "--verify"]) == 0
    out, err = capsys.readouterr()
    assert "verify: every outbound record, leg (telemetry) and event matches the recording" in out and err == ""
    assert list(scratch.iterdir()) == []
    assert sorted(p.name for p in demo_run.iterdir()) == before  # and nothing beside the recording


def test_verify_without_out_of_a_run_folder_finds_a_difference_and_still_cleans_up(demo_run, scratch, capsys):
    rewrite(demo_run / "trace.jsonl.zst", lambda r: r.get("attr") == "ran_status" and r["t"] > 20
            and r["value"].update(robot_state=99) is None)  # a difference record now says state 99
    assert main(["replay", str(demo_run), "--verify", "--quiet"]) == 1
    assert "robot_state" in capsys.readouterr().err
    assert list(scratch.iterdir()) == []


def test_replay_without_out_or_verify_is_a_usage_error(demo_run, capsys):
    assert main(["replay", str(demo_run / "trace.jsonl.zst")]) == 2
    assert capsys.readouterr().err == ("vcran replay: --out DIR is required (with --verify it may be left out: the "
                                       "replay then goes to a temporary folder)\n")


def test_a_zero_written_negative_is_recorded_and_replayed_as_written(run_toml, tmp_path):
    # docs/contract.md §5, §6: the trace holds the decoded value a fleet manager wrote, sign of a zero included (-0.0 == 0.0
    # in Python, so a delta by == dropped it, and a memo keyed by floats handed back the other sign).
    # The leg to x = -0.0 ends at -0.0, bit for bit, and the replay drives the same leg.
    out = run_toml(script(motion(1, "A", "A_m1", 1, 1, 0.0, -1.0), motion(10, "B", "B_m1", 1, 1, -0.0, -1.0),
                          motion(20, "C", "C_m1", 1, 1, 0.0, -1.0)))
    written = [r["value"]["point"]["x"] for r in trace_records(out.dir) if r["dir"] == "in"]
    assert [math.copysign(1.0, x) for x in written] == [1.0, -1.0, 1.0]
    legs = np.load(out.dir / "legs.npy")
    assert [math.copysign(1.0, x) for x in legs["x"]] == [1.0, -1.0, 1.0]
    assert replay(out.dir, tmp_path / "rep") == 0
    assert (tmp_path / "rep" / "legs.npy").read_bytes() == (out.dir / "legs.npy").read_bytes()


def test_verify_does_not_claim_events_it_could_not_compare(demo_run, capsys):
    # a new user deleted events.jsonl.zst: verification covers what is there, and says what it left out
    (demo_run / "events.jsonl.zst").unlink()
    assert main(["replay", str(demo_run), "--verify"]) == 0
    out = capsys.readouterr().out
    assert "every outbound record and leg (telemetry) matches the recording; events not compared" in out
    assert "and event matches" not in out


def test_a_recording_made_before_opils_attribute_names_still_verifies(demo_run, tmp_path, capsys):
    # docs/contract.md §2: vcran now publishes assignment_state and battery_state, the names OPIL's planner reads; a run
    # recorded under the old names (assignment_status, battery) replays and verifies, read with the new ones
    lines = read_lines(demo_run / "trace.jsonl.zst")
    old = [line.replace('"attr":"assignment_state"', '"attr":"assignment_status"') for line in lines]
    assert sum(a != b for a, b in zip(lines, old)) > 3
    write_lines(demo_run / "trace.jsonl.zst", old)
    assert replay(demo_run / "trace.jsonl.zst", tmp_path / "rep") == 0
    # and a real difference in such a record is still found, named with today's attribute
    forged = [line.replace('"last_finished_motion":', '"last_finished_motion":"x","was":', 1)
              if '"assignment_status"' in line and '"last_finished_motion"' in line else line for line in old]
    write_lines(demo_run / "trace.jsonl.zst", forged)
    assert replay(demo_run / "trace.jsonl.zst", tmp_path / "rep2") == 1
    assert "attribute=assignment_state" in capsys.readouterr().err
