"""``vcran decode FILE`` / ``vcran decode -`` through :func:`vcran.cli.main` (docs/contract.md §8, issue 3 item 5)."""

from __future__ import annotations

import copy
import importlib.util
import io
import json
from contextlib import redirect_stderr, redirect_stdout
from pathlib import Path
from typing import Any

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from tests.conftest import DATA
from vcran import cli
from vcran.core.opil.codec import decode_entity
from vcran.core.opil.messages import ATTRIBUTES
from vcran.core.opil.plain import from_plain, to_plain

REFERENCE_FILE = DATA / "opil_robot_entity.json"
REFERENCE: dict[str, Any] = json.loads(REFERENCE_FILE.read_text())


@pytest.fixture(autouse=True)
def only_importable_commands(monkeypatch: pytest.MonkeyPatch) -> None:
    """COMMANDS may name modules another branch is still writing; the parser imports every one."""
    present = {k: v for k, v in cli.COMMANDS.items() if importlib.util.find_spec(f"vcran.commands.{v}")}
    monkeypatch.setattr(cli, "COMMANDS", present)


def decode(capsys: pytest.CaptureFixture[str], *argv: str) -> tuple[int, str, str]:
    code = cli.main(["decode", *argv])
    out, err = capsys.readouterr()
    return code, out, err


def feed_stdin(monkeypatch: pytest.MonkeyPatch, data: bytes) -> None:
    monkeypatch.setattr("sys.stdin", io.TextIOWrapper(io.BytesIO(data)))


def test_decode_is_registered() -> None:
    assert cli.COMMANDS["decode"] == "decode"


def test_decode_reference_prints_every_attribute(capsys: pytest.CaptureFixture[str]) -> None:
    code, out, err = decode(capsys, str(REFERENCE_FILE))
    assert (code, err) == (0, "")
    printed = json.loads(out)
    assert list(printed) == ["action_assignment", "cancel_order", "current_motion", "motion_assignment", "robot_description"]
    assert printed["motion_assignment"]["point"] == {"x": -0.916000009, "y": -3.119999886, "theta": 0.0}
    assert printed["action_assignment"]["robot_action"]["category"] == 10
    assert printed["action_assignment"]["task_id"]["description"] == "task pickup at p1: task_1"
    assert printed["cancel_order"]["task_id"] == {
        "uuid": "05030602-0907-0300-0608-010107040503",
        "description": "Cancel task pickup p1",
    }
    assert printed["current_motion"]["current_position"]["header"]["stamp"] == {"secs": 2291, "nsecs": 100000000}
    assert printed["robot_description"]["vendor"] == "default"
    assert out.startswith('{\n  "action_assignment": {\n    "action_id": {')  # indent 2
    expected = decode_entity(REFERENCE)
    assert {name: from_plain(ATTRIBUTES[name], value) for name, value in printed.items()} == expected
    assert printed == {name: to_plain(m) for name, m in expected.items()}


def test_decode_stdin_and_key_values_print_the_same(
    capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    _, from_file, _ = decode(capsys, str(REFERENCE_FILE))
    key_values = {k: v if k in ("id", "type") else v["value"] for k, v in REFERENCE.items()}
    feed_stdin(monkeypatch, json.dumps(key_values).encode())
    code, from_stdin, err = decode(capsys, "-")
    assert (code, err, from_stdin) == (0, "", from_file)


def test_decode_lists_skipped_attributes_on_stderr(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    entity = {"id": "robot_1", "type": "ROBOT", "battery_level": {"type": "Number", "value": 87.5}}
    entity["cancel_order"] = REFERENCE["cancel_order"]
    path = tmp_path / "entity.json"
    path.write_text(json.dumps(entity))
    code, out, err = decode(capsys, str(path))
    assert code == 0
    assert list(json.loads(out)) == ["cancel_order"]
    assert err == "vcran decode: skipped attributes that are not RAN messages: battery_level\n"


def mutated_reference(value: Any, field: str = "byte") -> bytes:
    """The reference with the task id's byte 3 or description replaced. json.dumps writes a NaN as the
    NaN token and a lone surrogate as ``\\ud800``, both of which Python's JSON parser reads back."""
    entity = copy.deepcopy(REFERENCE)
    task_id = entity["cancel_order"]["value"]["task_id"]["value"]
    if field == "byte":
        task_id["uuid"]["value"][3]["value"] = value
    else:
        task_id[field]["value"] = value
    return json.dumps(entity).encode()


@pytest.mark.parametrize(
    ("data", "message"),
    [
        (b'{"id": "robot_1",', "bad JSON: Expecting"),
        (b"\xff\xfe{}", "bad JSON"),
        (b"[" * 100_000 + b"]" * 100_000, "bad JSON"),
        (b"[1, 2]", "entity: expected an entity object, got list"),
        (b'"robot_1"', "entity: expected an entity object, got 'robot_1'"),
        (mutated_reference(256), "cancel_order.value.task_id.value.uuid.value[3]: 256 is outside the uint8 range 0..255"),
        (mutated_reference("x\ud800", "description"), "cancel_order.value.task_id.value.description: not valid Unicode"),
        (mutated_reference(float("nan")), "cancel_order.value.task_id.value.uuid.value[3]: expected an integer, got float nan"),
        (b'{"current_motion": {"type": "x", "value": {}}}', "current_motion.value.current_position: missing field"),
        (b'{"motion_assignment": {"value": []}}', "motion_assignment: expected an object for"),
    ],
    ids=["truncated", "not-utf8", "too-deep", "array", "string", "byte-256", "surrogate", "byte-nan", "missing-field", "value-array"],
)
def test_decode_bad_input_exits_2_with_the_codec_message(
    capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch, data: bytes, message: str
) -> None:
    feed_stdin(monkeypatch, data)
    code, out, err = decode(capsys, "-")
    assert code == 2  # bad input, as in every command (README "Exit status")
    assert out == ""
    assert err.startswith(f"vcran decode: stdin: {message}")
    assert err.count("\n") == 1  # one line, no traceback


def test_decode_missing_file(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    code, out, err = decode(capsys, str(tmp_path / "nope.json"))
    assert (code, out) == (2, "")
    assert err == f"vcran decode: {tmp_path / 'nope.json'}: No such file or directory\n"


json_values = st.recursive(
    st.none() | st.booleans() | st.integers() | st.floats() | st.text(max_size=4),
    lambda inner: st.lists(inner, max_size=3) | st.dictionaries(st.sampled_from(["type", "value", "uuid", "x"]), inner, max_size=3),
    max_leaves=10,
)


@pytest.mark.slow
@settings(suppress_health_check=[HealthCheck.function_scoped_fixture])  # the fixture only narrows COMMANDS
@given(st.dictionaries(st.sampled_from([*ATTRIBUTES, "id", "other"]), json_values, max_size=4))
def test_decode_never_crashes(tmp_path: Path, entity: dict[str, Any]) -> None:
    path = tmp_path / "entity.json"
    path.write_text(json.dumps(entity))
    out, err = io.StringIO(), io.StringIO()
    with redirect_stdout(out), redirect_stderr(err):
        code = cli.main(["decode", str(path)])
    if code == 0:
        assert set(json.loads(out.getvalue())) == set(entity) & set(ATTRIBUTES)
    else:
        assert code == 2 and out.getvalue() == ""
        assert err.getvalue().startswith(f"vcran decode: {path}: ")
