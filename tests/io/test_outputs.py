"""Run folders people can load (issue 14, docs/contract.md §6, §8): the documented calls, the format's promises."""

from __future__ import annotations

import dataclasses
import enum
import json
import re
import tomllib
import typing

import numpy as np
import pytest

from tests.conftest import ROOT, read_lines
from transports.scripted import ScriptedTransport
from vcran.core.opil import effects
from vcran.core.opil.ids import NIL, Id
from vcran.io.gen import generate
from vcran.io.scenario_file import load, parse
from vcran.io.trace import EVENT_KEYS, legs, samples
from vcran.runner import run_to


def test_outputs_doc_blocks_run(tmp_path, monkeypatch):
    """Every ```python block of docs/outputs.md, in order, in one namespace, from the repository root."""
    text = (ROOT / "docs" / "outputs.md").read_text(encoding="utf-8")
    blocks = re.findall(r"```python\n(.*?)```", text, flags=re.S)
    assert len(blocks) >= 3
    monkeypatch.chdir(ROOT)
    namespace: dict[str, object] = {}
    for block in blocks:
        exec(compile(block, "docs/outputs.md", "exec"), namespace)  # noqa: S102 - our own documentation


class Frames(ScriptedTransport):
    """Keeps every telemetry frame the model sent (the values live mode publishes)."""

    def __init__(self, script):
        super().__init__(script)
        self.frames = []

    def send(self, out):
        super().send(out)
        if hasattr(out, "columns"):
            self.frames.append(np.concatenate(([out.t], out.columns.reshape(-1))))


@pytest.mark.parametrize("robots", [3, 40])  # few movers: scalar sampling; 40: numpy's vectorised path
def test_telemetry_evaluated_from_the_legs_is_bit_for_bit_what_was_published(tmp_path, robots):  # docs/contract.md §6
    scenario = parse(tomllib.loads(generate(robots, 0.05, 3)), "<gen>")
    transport = Frames(scenario.messages())
    run_to(scenario, tmp_path / "run", transport)
    published = np.vstack(transport.frames)
    evaluated = samples(tmp_path / "run")
    assert evaluated.shape == published.shape
    assert evaluated.tobytes() == published.tobytes()
    assert np.count_nonzero(published[:, 4::5]) > 0  # robots did move


@pytest.mark.parametrize("name", ["faults", "battery", "crossing"])
def test_telemetry_of_held_and_stopped_legs_is_bit_for_bit_what_was_published(tmp_path, name):  # docs/contract.md §4, §6
    """Pauses, breakdowns, an empty battery and collisions halt robots mid-leg; a halted robot's next leg
    starts where it halted, a resumed leg is timed from its shifted origin: the leg log says all of it."""
    scenario = load(ROOT / "scenarios" / f"{name}.toml")
    transport = Frames(scenario.messages())
    run_to(scenario, tmp_path / "run", transport)
    published = np.vstack(transport.frames)
    assert samples(tmp_path / "run").tobytes() == published.tobytes()
    halts = legs(tmp_path / "run")
    assert np.isnan(halts["t0"]).any()  # the scenario did halt a robot mid-leg


HALT_BEFORE_THE_LEGS_END = """[simulation]
until_idle = true
duration = 100.0

[[robots]]
id = "r0"
pose = [0.0, 0.0, 0.0]
max_velocity = 1.0

[robots.battery]
capacity = 0.5
initial = 0.02734375
per_metre = 0.005
per_idle_second = 0.002
per_action_second = 0.01
charge_rate = 0.05
swap_after = 5.0

[[script]]
t = 0.0
robot = "r0"
kind = "task"
task = "T"
path = [[0.0, 4.0]]
"""


def test_a_halt_before_its_legs_end_within_one_tick_is_where_the_robot_rests(tmp_path):  # docs/contract.md §4, §6
    """The battery runs out at 3.90625, its leg would end at 4.0, the tick is at 4.0: the robot rests where
    it halted (hypothesis found the evaluation finishing the leg first, then ignoring the halt)."""
    scenario = parse(tomllib.loads(HALT_BEFORE_THE_LEGS_END), "<halt>")
    transport = Frames(scenario.messages())
    run_to(scenario, tmp_path / "run", transport)
    published = np.vstack(transport.frames)
    rows = legs(tmp_path / "run")
    assert rows["t"][-1] == 3.90625 and np.isnan(rows["t0"][-1])  # the halt, before the leg's end at 4.0
    assert published[4, 0] == 4.0 and published[4, 2] == 3.90625  # rests where it halted
    assert samples(tmp_path / "run").tobytes() == published.tobytes()


ABANDONED_LEGS = """[simulation]
until_idle = true
duration = 100.0
task_timeout = 10.0

[[robots]]
id = "r0"
pose = [0.0, 3.0, 0.0]
max_velocity = 1.0

[[robots]]
id = "r1"
pose = [0.0, 6.0, 0.0]
max_velocity = 1.0

[[script]]
t = 0.0
robot = "r0"
kind = "motion"
task = "A"
id = "A_m1"
seq = [1, 1]
point = [0.0, 0.0, 0.0]

[[script]]
t = 0.0
robot = "r0"
kind = "cancel"
task = "A"

[[script]]
t = 0.0
robot = "r1"
kind = "motion"
task = "B"
id = "B_m1"
seq = [1, 4]
point = [10.0, 6.0, 0.0]

[[script]]
t = 0.0
robot = "r1"
kind = "motion"
task = "B"
id = "B_m2"
seq = [2, 4]
point = [20.0, 6.0, 0.0]

[[script]]
t = 0.0
robot = "r1"
kind = "action"
task = "B"
id = "B_a3"
seq = [3, 4]
action = "dummy"
"""


def test_legs_abandoned_as_they_begin_are_not_in_the_evaluated_telemetry(tmp_path):  # R14, docs/contract.md §6
    """By hand (R14: a leg that began at the instant of a cancel or of a timeout's deadline is abandoned,
    the robot stays where it began). r0's leg is dispatched at 0 and cancelled at 0: r0 rests at (0, 3)
    at every tick. r1 reaches (10, 6) at 10, B's deadline (its position 4 never comes), and starts the leg
    to (20, 6); the tick at 10 sees it leave at 1 m/s, the timer (10 + 1 µs) abandons that leg: r1 rests
    at (10, 6) from then on. The fuzzer found the leg log keeping abandoned legs (the evaluated telemetry
    drove r0 to (0, 0) after its task was cancelled), or it would put r1 1 µs down its leg."""
    scenario = parse(tomllib.loads(ABANDONED_LEGS), "<abandon>")
    transport = Frames(scenario.messages())
    run_to(scenario, tmp_path / "run", transport)
    published = np.vstack(transport.frames)  # columns: t, then x, y, theta, v, w per robot
    assert (published[:, 1:6] == [0.0, 3.0, 0.0, 0.0, 0.0]).all()
    ten = published[published[:, 0] == 10.0]
    assert ten[0, 6:10].tolist() == [10.0, 6.0, 0.0, 1.0]  # leaving (10, 6) at the tick of its deadline
    assert (published[published[:, 0] > 10.0, 6:11] == [10.0, 6.0, 0.0, 0.0, 0.0]).all()
    assert published[-1, 0] > 10.0
    assert samples(tmp_path / "run").tobytes() == published.tobytes()


def test_events_carry_the_same_keys_in_the_same_order(tmp_path):
    scenario = load(ROOT / "scenarios" / "demo.toml")
    run_to(scenario, tmp_path / "run", ScriptedTransport(scenario.messages()))
    lines = read_lines(tmp_path / "run" / "events.jsonl.zst")
    assert len(lines) > 10
    assert {tuple(json.loads(line)) for line in lines} == {EVENT_KEYS}


def test_an_event_line_is_its_dict_over_the_event_keys_whatever_its_fields(tmp_path):  # docs/contract.md §8
    """docs/outputs.md: a line is ``t``, ``robot``, ``event`` and the event's fields over EVENT_KEYS (null where it
    has none), fields EVENT_KEYS lacks after them in their order. The writer assembles lines from pieces made
    once per name and set of keys (issue 30); the expected line here is that dict, rendered as one value: fields
    out of EVENT_KEYS' order, unlisted ones, one named like a fixed key, text that JSON escapes, -0.0."""
    from vcran.io.trace import EventWriter, json_line

    cases = [("state", {"to": "TASK", "from": "WAITING"}), ("bare", {}), ("extra", {"zzz": 1, "task": "a"}),
             ("renamed", {"event": "other", "x": -0.0}), ("timed", {"t": 5, "task": "b"}), ("moved", {"robot": "r2"}),
             ("escaped", {"y": 1.5, "extra": [1, {"a": None}], "code": 'c\n"', "message": "é\u2028\x01"}),
             ("rejected", {"code": "c", "severity": "error", "task": "T", "message": "m"}),
             ("rejected", {"code": "c", "severity": "error", "action": "A", "message": "m"})]
    writer = EventWriter(tmp_path / "events.jsonl")
    for name, fields in cases:
        writer.write(1.25, "robot_1", name, fields)
    writer.close()
    expected = b"".join(json_line({**dict.fromkeys(EVENT_KEYS), "t": 1.25, "robot": "robot_1", "event": name, **fields})
                        for name, fields in cases)
    assert (tmp_path / "events.jsonl").read_bytes() == expected


def _placeholder(hint):
    if hint is Id:
        return NIL
    if isinstance(hint, type) and issubclass(hint, enum.Enum):
        return next(iter(hint))
    return {str: "x", bool: True, int: 1, float: 1.0}[hint]


def test_every_event_field_has_an_event_key():
    """A new event class with a field EVENT_KEYS lacks would break the one-schema promise: list it."""
    seen = []
    stack = list(effects.Event.__subclasses__())
    while stack:
        cls = stack.pop()
        stack.extend(cls.__subclasses__())
        if not dataclasses.is_dataclass(cls) or not cls.NAME:
            continue
        hints = typing.get_type_hints(cls)
        event = cls(**{f.name: _placeholder(hints[f.name]) for f in dataclasses.fields(cls)})
        assert set(event.fields()) <= set(EVENT_KEYS), cls
        seen.append(cls.NAME)
    assert {"state", "task_queued", "task_completed", "task_cancelled", "rejected", "failed"} <= set(seen)


def test_trace_repeats_nothing_a_reader_can_take_from_an_earlier_record(tmp_path):
    scenario = parse(tomllib.loads(generate(2, 0.1, 1)), "<gen>")
    run_to(scenario, tmp_path / "run", ScriptedTransport(scenario.messages()))
    lines = read_lines(tmp_path / "run" / "trace.jsonl.zst")
    records = [json.loads(line) for line in lines[1:-1]]
    descriptions = [r for r in records if r["attr"] == "robot_description"]
    assert len(descriptions) == 2  # one per robot: the 60 s re-sends are unchanged (0.1 h = 6 of them)
    footprints = [r for r in records if r["attr"] == "assignment_state" and "footprint" in r["value"]]
    assert len(footprints) == 2  # the first status of each robot only
    last = {}
    for r in records:
        if "value" in r:
            key = (r["dir"], r["robot"], r["attr"])
            before = last.get(key, {})
            assert r["value"] and all(before.get(k, object()) != v for k, v in r["value"].items())
            last[key] = {**before, **r["value"]}
    motion = next(r for r in records if r["attr"] == "motion_assignment")
    assert isinstance(motion["value"]["task_id"], str)  # compact: the name, not a 75-byte object


def test_summary_json_is_written_as_json_dumps_would_print_it(tmp_path):
    """docs/contract.md §8 summary.json: encoded piece by piece as it is written (issue 14: a fleet's summary lists every
    task), yet byte for byte ``json.dumps(indent=2, ensure_ascii=False)`` and a newline, across batches."""
    import json

    from vcran.io.sinks import write_summary

    summary = {"scenario": "Förderband", "sim_time": 3600.0, "errors": 0, "robots": {
        f"robot_{i}": {"completed": [f"r{i}_{k}_1" for k in range(300)], "cancelled": [{"task": "T", "reason": "timeout"}],
                       "final_pose": {"x": 0.1, "y": -2.5, "theta": 3.141592653589793}} for i in range(20)}}
    write_summary(tmp_path, summary)
    assert (tmp_path / "summary.json").read_bytes() == (json.dumps(summary, indent=2, ensure_ascii=False) + "\n").encode()


def test_compressed_output_hands_every_line_on_at_flush_and_keeps_lines_longer_than_a_batch(tmp_path):  # docs/contract.md §6
    """A ``.zst`` output is batched (vcran.io.trace.streams._Batched): ``flush`` must make every line written so far
    readable from the file as it stands (live mode flushes each tick, a killed run keeps its recording),
    and a line longer than a batch must come through whole, in its place."""
    import zstandard

    from vcran.io.trace import BATCH, open_input, open_output

    path = tmp_path / "lines.jsonl.zst"
    lines = [b'{"n":%d}\n' % i for i in range(1000)]
    long = b'{"long":"' + b"x" * (BATCH + 123) + b'"}\n'
    f = open_output(path)
    for line in lines:
        f.write(line)
    f.flush()
    partial = zstandard.ZstdDecompressor().decompressobj().decompress(path.read_bytes())  # the frame has no end yet
    assert partial == b"".join(lines)
    f.write(long)
    f.write(lines[0])
    f.close()
    f.flush()  # a closed run's writer may still be flushed: nothing happens
    with open_input(path) as g:
        assert g.read() == b"".join(lines) + long + lines[0]


def test_compressed_output_keeps_what_was_written_when_the_caller_reuses_its_buffer(tmp_path):  # docs/contract.md §6
    """Lines are gathered in a batch before they reach the compressor (vcran.io.trace.streams._Batched): a
    ``bytearray`` or ``memoryview`` written and then changed by the caller, as ``write`` allows, must be
    kept as written."""
    from vcran.io.trace import open_input, open_output

    lines = 100
    path = tmp_path / "reused.jsonl.zst"
    buffer = bytearray(b'{"n":0}\n')
    f = open_output(path)
    for i in range(lines):
        buffer[5:6] = b"%d" % (i % 10)
        f.write(buffer if i % 2 else memoryview(buffer))
    buffer[:] = b"gone\n"
    f.close()
    with open_input(path) as g:
        assert g.read() == b"".join(b'{"n":%d}\n' % (i % 10) for i in range(lines))


def test_compressed_output_drops_the_buffer_a_long_line_grew(tmp_path):  # docs/contract.md §6, issue 14 (flat memory)
    """A line several batches long (a raw payload near Orion's 1 MB limit) goes through whole, and the
    batch buffer it grew is not kept for the rest of the run."""
    from vcran.io.trace import BATCH, open_input, open_output

    path = tmp_path / "long.jsonl.zst"
    long = b'{"long":"' + b"x" * (3 * BATCH) + b'"}\n'
    f = open_output(path)
    f.write(long)
    f.write(b'{"n":1}\n')
    f.flush()
    assert len(f.batch.getvalue()) < BATCH  # what the batch holds now: the short line's buffer only
    f.close()
    with open_input(path) as g:
        assert g.read() == long + b'{"n":1}\n'


def test_an_events_file_cut_off_is_an_error_not_fewer_events(tmp_path):  # docs/contract.md §6, §8
    """A zstd stream cut short reads as a shorter one, without an error, and cut where a block ends it even
    ends with a whole line: ``vcran report`` drew a finished run from half its events (0 tasks done where
    the demo does 3). A reader of a finished run's events says the file is cut off; one reading a killed
    run's recording (``cut_off=True``) takes its whole lines, as before."""
    from vcran.io.trace import event_records, open_output

    path = tmp_path / "events.jsonl.zst"
    f = open_output(path)
    f.write(b'{"t": 1.0, "robot": "r", "event": "task_queued", "task": "A"}\n')
    f.flush()
    boundary = path.stat().st_size  # the first lines' block ends here
    f.write(b'{"t": 2.0, "robot": "r", "event": "task_completed", "task": "A"}\n')
    f.close()
    whole = path.read_bytes()
    assert [e["event"] for e in event_records(path)] == ["task_queued", "task_completed"]
    for cut in (boundary, len(whole) // 2, len(whole) - 1, 0):
        path.write_bytes(whole[:cut])
        with pytest.raises(ValueError, match="events.jsonl.zst: cut off: the zstd stream ends before its end"):
            list(event_records(path))
    path.write_bytes(whole[:boundary])
    assert [e["event"] for e in event_records(path, cut_off=True)] == ["task_queued"]
    path.write_bytes(b"hello")
    with pytest.raises(ValueError, match="events.jsonl.zst: not a zstd stream"):
        list(event_records(path))


def test_a_zstd_file_with_skippable_frames_is_whole_not_a_foreign_file(tmp_path):  # docs/contract.md §6, §8
    """zstd's skippable frames (pzstd writes one before each frame) are part of a valid stream, which the
    reader always read; the cut-off check called such a file 'not a zstd stream'. One cut inside a
    skippable frame is cut off, and a raw block or an RLE one (one byte for many) are walked over too."""
    import zstandard

    from vcran.io.trace import event_records, zst_cut_off

    line = b'{"t": 1.0, "robot": "r", "event": "task_queued", "task": "A"}\n'
    frame = zstandard.ZstdCompressor(write_checksum=True).compress(line)
    skip = b"\x5a\x2a\x4d\x18" + (5).to_bytes(4, "little") + b"vcran"
    rle = b"\x28\xb5\x2f\xfd\x20\x03" + (1 | 1 << 1 | 3 << 3).to_bytes(3, "little") + b" "  # 3 spaces
    raw = b"\x28\xb5\x2f\xfd\x20" + bytes([len(line)]) + (1 | len(line) << 3).to_bytes(3, "little") + line
    path = tmp_path / "events.jsonl.zst"
    whole = skip + frame + skip + raw + rle + frame
    path.write_bytes(whole)
    assert not zst_cut_off(path)
    assert [e["event"] for e in event_records(path)] == ["task_queued"] * 3
    for cut in (len(skip) - 1, len(skip) + len(frame) + 4, len(whole) - len(frame) - 1):
        path.write_bytes(whole[:cut])
        assert zst_cut_off(path), cut
