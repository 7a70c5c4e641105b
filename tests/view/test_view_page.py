"""The page in a real browser (docs/contract.md §13, issue 33 items 2 and 4): it loads from disk with no console error
and no request but its own file; what it draws at t is what the run's telemetry says (the positions the
page reports drawing, and the canvas's pixels); clicking a job highlights its robot; clicking an incident
jumps to it. Expectations come from vcran.telemetry_table, the run's events and docs/demo.md."""

from __future__ import annotations

import io
import json
import math

import numpy as np
import pytest

import vcran
from tests.conftest import read_lines
from tests.view.browser import file_url, open_page
from tests.view.runs import bundled, generated, managed, still_running
from vcran.io.trace import EVENTS_FILE
from vcran.view import write_page

WHITE = (255, 255, 255)


@pytest.fixture(scope="module")
def pages(tmp_path_factory):
    """Run folders and their pages, written once for the module."""
    base = tmp_path_factory.mktemp("pages")
    runs = {name: bundled(name, base / name) for name in ("demo", "warehouse", "faults", "battery", "vda5050", "corridor")}
    runs["manage"] = managed(runs["warehouse"], base / "manage")
    runs["live"] = still_running(runs["warehouse"], base / "live.incomplete", cut=500)
    return {name: (run, write_page(run, base / f"{name}.html")) for name, run in runs.items()}


@pytest.mark.parametrize("name", ["demo", "warehouse", "faults", "battery", "vda5050", "corridor", "manage", "live"])
def test_the_page_loads_from_disk_without_errors_or_any_request(browser, pages, name):
    """Issue 33 items 1 and 4: self-contained (the one request is the file itself) and clean."""
    run, page_file = pages[name]
    page = open_page(browser, file_url(page_file))
    page.js("vcranView.seek(vcranView.end() / 2)")
    page.js("vcranView.play()")
    page.page.wait_for_timeout(200)
    page.js("vcranView.pause()")
    assert page.problems == []
    assert page.requests == [file_url(page_file)]
    assert page.page.locator("#failure").is_hidden()
    page.page.close()


def telemetry_at(run, t: float) -> dict[str, tuple[float, float, float]]:
    table = vcran.telemetry_table(run)
    rows = table[table["t"] == t]
    assert len(rows), f"no tick at {t}"
    return {str(r["robot"]): (float(r["x"]), float(r["y"]), float(r["theta"])) for r in rows}


@pytest.mark.parametrize(("name", "times"), [("demo", (10.0, 25.0, 50.0)), ("warehouse", (200.0, 1500.0, 3000.0)),
                                             ("vda5050", (10.0, 25.0, 50.0))])  # docs/contract.md §11: a VDA 5050 run
def test_drawn_robots_are_where_the_telemetry_puts_them(browser, pages, name, times):
    """docs/contract.md §13: at three instants each robot is drawn within a pixel of its telemetry position, its pose
    the telemetry's to a nanometre (fleet.js evaluates the leg log as vcran/core/motion.py does)."""
    run, page_file = pages[name]
    page = open_page(browser, file_url(page_file))
    for t in times:
        page.js("t => vcranView.seek(t)", t)
        drawn = {d["robot"]: d for d in page.js("vcranView.drawn()")}
        telemetry = telemetry_at(run, t)
        assert set(drawn) == set(telemetry)
        for robot, (x, y, theta) in telemetry.items():
            d = drawn[robot]
            assert (d["x"], d["y"]) == pytest.approx((x, y), abs=1e-9)
            assert math.remainder(d["theta"] - theta, 2 * math.pi) == pytest.approx(0.0, abs=1e-9)
            px, py = page.js("([x, y]) => vcranView.toPixel(x, y)", [x, y])
            assert math.hypot(d["px"] - px, d["py"] - py) <= 1.0
    assert page.problems == []
    page.page.close()


def footprint_centre(run, robot: str, pose: tuple[float, float, float]) -> tuple[float, float]:
    """The middle of the robot's footprint on the floor at ``pose`` (inside it: footprints are convex here)."""
    header = json.loads(read_lines(run / "trace.jsonl.zst")[0])
    corners = next(r["footprint"] for r in header["fleet"]["robots"] if r["id"] == robot)
    cx, cy = np.mean(corners, axis=0)
    x, y, theta = pose
    return x + math.cos(theta) * cx - math.sin(theta) * cy, y + math.sin(theta) * cx + math.cos(theta) * cy


def pixel(image, px: float, py: float) -> tuple[int, int, int]:
    return image.getpixel((int(px), int(py)))[:3]


def rgb(colour: str) -> tuple[int, int, int]:
    return tuple(int(colour[k:k + 2], 16) for k in (1, 3, 5))


def canvas_image(page):
    from PIL import Image

    return Image.open(io.BytesIO(page.canvas_png())).convert("RGB")


def apart(positions: dict[str, tuple[float, float, float]], robot: str, gap: float = 2.0) -> bool:
    x, y, _ = positions[robot]
    return all(math.hypot(x - u, y - v) > gap for other, (u, v, _) in positions.items() if other != robot)


@pytest.mark.parametrize(("name", "t"), [("demo", 25.0), ("warehouse", 1500.0)])
def test_the_canvas_shows_each_robot_where_the_telemetry_puts_it(browser, pages, name, t):
    """The pixels themselves (a screenshot of the floor): at the middle of each robot's footprint, placed by
    its telemetry pose, the canvas has that robot's task colour; an empty corner is the floor's white."""
    run, page_file = pages[name]
    page = open_page(browser, file_url(page_file))
    page.js("t => vcranView.seek(t)", t)
    drawn = {d["robot"]: d for d in page.js("vcranView.drawn()")}
    image = canvas_image(page)
    telemetry = telemetry_at(run, t)
    checked = 0
    for robot, pose in telemetry.items():
        if not apart(telemetry, robot):  # another robot drawn on top would hide it
            continue
        px, py = page.js("([x, y]) => vcranView.toPixel(x, y)", list(footprint_centre(run, robot, pose)))
        assert pixel(image, px, py) == rgb(drawn[robot]["fill"]), robot
        checked += 1
    assert checked >= 1
    assert pixel(image, 2, 2) == WHITE
    page.page.close()


def test_the_robot_panel_and_stations_follow_the_cursor(browser, pages):
    """docs/demo.md by hand (tests/view/test_view_model.py derives the instants): the part is on the robot from
    14 + pi/2 + 2√2 s, while task 200 runs; conveyor 1's one part appears at t = 10 and leaves with it."""
    run, page_file = pages["demo"]
    page = open_page(browser, file_url(page_file))
    loaded = 14 + math.pi / 2 + 2 * math.sqrt(2)
    page.js("t => vcranView.seek(t)", 5.0)
    assert page.js("vcranView.status('robot_1')") == {"state": "MOTION", "task": 0, "taskLabel": "100", "load": 0,
                                                        "battery": None, "error": ""}
    page.js("t => vcranView.seek(t)", loaded + 1)
    status = page.js("vcranView.status('robot_1')")
    assert (status["state"], status["taskLabel"], status["load"]) == ("MOTION", "200", 1)
    row = page.page.locator('#robots tr[data-robot="robot_1"] td')
    page.page.locator('#tabs button[data-tab="robots"]').click()
    assert row.all_inner_texts()[:4] == ["robot_1", "MOTION", "200", "1/1"]
    parts = []
    for t in (9.99, 10.0, loaded - 0.01, loaded + 0.01):
        page.js("t => vcranView.seek(t)", t)
        parts.append(page.js("vcranView.parts('conveyor_1')"))
    assert parts == [0, 1, 1, 0]
    assert page.problems == []
    page.page.close()


def test_clicking_a_job_highlights_its_robot_its_tasks_and_its_path(browser, pages):
    """Issue 33 item 2: a click on a job's row selects the robot the manager assigned it to (job_assigned),
    lists the job's tasks, and draws the others dimmed: on the canvas the job's robot keeps its colour."""
    run, page_file = pages["warehouse"]
    events = [json.loads(line) for line in read_lines(run / EVENTS_FILE)]
    job = "job_41"
    robot = next(e["robot"] for e in events if e["event"] == "job_assigned" and e["job"] == job)
    page = open_page(browser, file_url(page_file))
    page.page.locator('#tabs button[data-tab="jobs"]').click()
    page.page.locator(f'#jobs tr[data-job="{job}"]').click()
    assert page.js("vcranView.selected()") == {"job": job, "robots": [robot]}
    tasks = page.page.locator("#job-detail li").all_inner_texts()
    assert tasks and all(text.startswith(f"{job}_") and f"on {robot}" in text for text in tasks)
    t = page.js("vcranView.time()")
    started = min(e["t"] for e in events if e["event"] == "job_assigned" and e["job"] == job)
    assert t >= started  # the cursor moved into the job's life
    drawn = {d["robot"]: d for d in page.js("vcranView.drawn()")}
    assert [r for r, d in drawn.items() if d["selected"]] == [robot]
    image = canvas_image(page)
    positions = {r: (d["x"], d["y"], d["theta"]) for r, d in drawn.items()}
    for other, d in drawn.items():
        if not apart(positions, other):
            continue
        px, py = page.js("([x, y]) => vcranView.toPixel(x, y)", list(footprint_centre(run, other, positions[other])))
        full = pixel(image, px, py) == rgb(d["fill"])
        assert full == (other == robot), other
    page.page.locator('#tabs button[data-tab="robots"]').click()
    assert page.page.locator("#robots tr.selected").all_inner_texts()[0].startswith(robot)
    assert page.problems == []
    page.page.close()


def test_clicking_an_incident_jumps_to_it(browser, pages):
    """The incidents strip: a click on a mark moves the cursor to that incident and selects its robot; the
    list has one row per incident of the run (scenarios/faults.toml's faults, failures, cancels)."""
    run, page_file = pages["faults"]
    page = open_page(browser, file_url(page_file))
    incidents = page.js("vcranView.incidents()")
    target = next(i for i in incidents if i["kind"] == "failure")
    kinds = list(dict.fromkeys(k["kind"] for k in page.js("vcranView.app.data.incidentKinds")
                               if any(i["kind"] == k["kind"] for i in incidents)))
    strip = page.page.locator("#strip")
    box = strip.bounding_box()
    row_height = page.js("vcranView.app.timeline.rowHeight()")
    x = target["t"] / page.js("vcranView.end()") * (box["width"] - 1)
    y = 2 + (kinds.index("failure") + 0.5) * row_height
    strip.click(position={"x": x, "y": y})
    assert page.js("vcranView.time()") == target["t"]
    assert page.js("vcranView.selected()")["robots"] == [target["robot"]]
    page.page.locator('#tabs button[data-tab="incidents"]').click()
    assert page.page.locator("#incidents li[data-incident]").count() == len(incidents)
    assert page.problems == []
    page.page.close()


def test_the_slider_and_play_move_the_cursor(browser, pages):
    _, page_file = pages["demo"]
    page = open_page(browser, file_url(page_file))
    page.page.locator("#slider").fill("30")
    assert page.js("vcranView.time()") == 30.0
    assert page.page.locator("#time").inner_text() == "0:30.0"
    page.page.locator("#play").click()
    page.page.wait_for_function("() => vcranView.time() > 30")
    page.page.locator("#play").click()
    assert page.page.locator("#play").get_attribute("aria-pressed") == "false"
    assert page.problems == []
    page.page.close()


def test_a_large_fleet_opens_and_draws_every_robot(browser, tmp_path):
    """Issue 33 item 5 in small (benchmarks/bench_view.py opens 1000 robots × 1 h): 400 generated robots,
    every one drawn where the telemetry puts it."""
    run = generated(400, 0.05, tmp_path / "fleet")
    page = open_page(browser, file_url(write_page(run, tmp_path / "fleet.html")))
    t = 120.0
    page.js("t => vcranView.seek(t)", t)
    drawn = {d["robot"]: (d["x"], d["y"]) for d in page.js("vcranView.drawn()")}
    telemetry = telemetry_at(run, t)
    assert len(drawn) == 400
    assert all(drawn[r] == pytest.approx(p[:2], abs=1e-9) for r, p in telemetry.items())
    assert page.problems == []
    page.page.close()
