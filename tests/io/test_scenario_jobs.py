"""Closed-loop sections of a scenario file (docs/contract.md §9): ``[[jobs]]``, ``[job_stream]``, ``[link]``, ``[manager]``.

Loading is strict like every other section: each bad entry fails with a ScenarioError that names the file,
the section and the field.
"""

from __future__ import annotations

import re
import tomllib
from collections import Counter

import pytest

from vcran.core.scenario import Job
from vcran.io.scenario_file import ScenarioError, parse

FLEET = """
[simulation]
duration = 3600.0
seed = 5
[[robots]]
id = "robot_1"
[[stations]]
id = "a"
position = [0.0, 0.0]
[[stations]]
id = "b"
position = [10.0, 0.0]
[[stations]]
id = "c"
position = [10.0, 10.0]
"""


def load(extra: str):
    return parse(tomllib.loads(FLEET + extra), "<test>")


def job(t, id, pickup="a", dropoff="b", more=""):
    return f'\n[[jobs]]\nt = {t}\nid = "{id}"\npickup = "{pickup}"\ndropoff = "{dropoff}"\n{more}\n'


def test_listed_jobs_load_in_time_order_equal_times_in_file_order():
    sc = load(job(20, "late") + job(5, "first", more="priority = 2\ndeadline = 60.0") + job(20, "later", "c", "a"))
    assert [j.id for j in sc.jobs] == ["first", "late", "later"]
    assert sc.jobs[0] == Job(5.0, "first", "a", "b", priority=2, deadline=60.0)
    assert sc.jobs[1].priority == 0 and sc.jobs[1].deadline is None
    assert sc.has_workload and list(sc.workload()) == list(sc.jobs)


def test_a_scenario_without_jobs_has_no_workload():
    sc = load("")
    assert not sc.has_workload and list(sc.workload()) == [] and sc.manager is None


@pytest.mark.parametrize("entry, message", [
    (job(1, "j", pickup="nowhere"), "jobs[0]: field 'pickup': no station 'nowhere' in this scenario; stations: a, b, c"),
    (job(1, "j", dropoff="a"), "field 'dropoff': equals the pickup 'a'"),
    (job(10, "j", more="deadline = 10.0"), "field 'deadline': 10.0 is not after the job's time 10"),
    (job(-1, "j"), "field 't'"),
    (job(3600.5, "j"), "jobs[0]: field 't': the job arrives at t = 3600.5, after the run ends (duration = 3600)"),
    (job(1, "j", more="colour = 'red'"), "colour"),
    (job(1, "j") + job(2, "j"), "'j'"),
    ('\n[[jobs]]\nt = 1.0\nid = "j"\npickup = "a"\n', "field 'dropoff'"),
])
def test_bad_jobs_fail_to_load_naming_the_field(entry, message):
    with pytest.raises(ScenarioError) as err:
        load(entry)
    assert str(err.value).startswith("<test>: ")
    assert message in str(err.value)


def test_a_job_at_the_last_instant_still_loads():
    """The bound is inclusive, as for a script entry: a job at exactly ``duration`` reaches the manager
    (jobs come before the end within an instant, docs/determinism.md)."""
    assert [j.t for j in load(job(3600.0, "j")).jobs] == [3600.0]


def test_jobs_and_a_script_exclude_each_other():
    script = '\n[[script]]\nt = 1.0\nrobot = "robot_1"\nkind = "cancel"\ntask = "x"\n'
    with pytest.raises(ScenarioError, match=r"\[\[script\]\] and a closed loop"):
        load(job(1, "j") + script)


STREAM = """
[job_stream]
mean_interval = 10.0
pickup = ["a", "b"]
dropoff = {{ b = 3.0, c = 1.0 }}
{more}
"""


def stream(more: str = "") -> str:
    return STREAM.format(more=more)


def test_stream_is_a_seeded_poisson_process_honouring_stations_and_weights():
    jobs = list(load(stream("until = 100000.0")).workload())
    # ~10,000 exponential gaps of mean 10 s: the sample mean is within 3% (about 3 standard errors)
    gaps = [b.t - a.t for a, b in zip(jobs, jobs[1:])]
    assert abs(sum(gaps) / len(gaps) - 10.0) < 0.3
    assert all(g > 0 for g in gaps)
    assert jobs[-1].t < 100000.0
    assert [j.id for j in jobs[:3]] == ["job_1", "job_2", "job_3"]
    assert all(j.pickup != j.dropoff for j in jobs)
    pickups = Counter(j.pickup for j in jobs)
    assert set(pickups) == {"a", "b"} and abs(pickups["a"] / len(jobs) - 0.5) < 0.03
    # from a: b and c by weight 3:1; from b: only c is left
    from_a = Counter(j.dropoff for j in jobs if j.pickup == "a")
    assert abs(from_a["b"] / (from_a["b"] + from_a["c"]) - 0.75) < 0.03
    assert {j.dropoff for j in jobs if j.pickup == "b"} == {"c"}


def test_stream_is_the_same_for_the_same_seed_and_differs_for_another():
    once, again = list(load(stream()).workload()), list(load(stream()).workload())
    other = list(load(stream("seed = 6")).workload())
    assert once == again and len(once) > 100
    assert once != other


def test_stream_defaults_to_the_duration_and_rate_is_jobs_per_hour():
    sc = load(stream().replace("mean_interval = 10.0", "rate = 360.0"))
    assert sc.job_stream is not None
    assert sc.job_stream.mean_interval == 10.0 and sc.job_stream.until == 3600.0 and sc.job_stream.seed == 5


def test_listed_and_streamed_jobs_merge_by_time():
    sc = load(stream("until = 60.0\nprefix = 'auto'") + job(0, "manual") + job(30, "mid"))
    jobs = list(sc.workload())
    assert [j.t for j in jobs] == sorted(j.t for j in jobs)
    assert jobs[0].id == "manual" and "mid" in [j.id for j in jobs]
    assert any(j.id.startswith("auto_") for j in jobs)


@pytest.mark.parametrize("more, message", [
    ("rate = 5.0", "give exactly one of rate"),
    ("until = 0.0", "is not after start"),
    ("prefix = 'j'\n[[jobs]]\nt = 1.0\nid = 'j_1'\npickup = 'a'\ndropoff = 'b'", "would clash"),
])
def test_bad_streams_fail_to_load(more, message):
    with pytest.raises(ScenarioError, match=message):
        load(stream(more))


@pytest.mark.parametrize("table, message", [
    ('\n[job_stream]\nmean_interval = 1.0\npickup = ["a"]\ndropoff = ["a"]\n', "offers no station other than"),
    ('\n[job_stream]\nmean_interval = 1.0\npickup = ["zz"]\ndropoff = ["a"]\n', "no station 'zz'"),
    ('\n[job_stream]\nmean_interval = 1.0\npickup = []\ndropoff = ["a"]\n', "names no station"),
    ('\n[job_stream]\nmean_interval = 1.0\npickup = ["a", "a"]\ndropoff = ["b"]\n', "names 'a' twice"),
    ('\n[job_stream]\nmean_interval = 1.0\npickup = {a = 0}\ndropoff = ["b"]\n', "positive number"),
    ('\n[job_stream]\nmean_interval = -1.0\npickup = ["a"]\ndropoff = ["b"]\n', "mean_interval"),
    ('\n[job_stream]\npickup = ["a"]\ndropoff = ["b"]\n', "give exactly one of rate"),  # neither
    ('\n[job_stream]\nrate = 1.0\nstart = 3600.0\nuntil = 7200.0\npickup = ["a"]\ndropoff = ["b"]\n',
     "field 'start': the job stream starts at t = 3600, when the run has ended \\(duration = 3600\\)"),
    ('\n[[job_stream]]\nrate = 1.0\npickup = ["a"]\ndropoff = ["b"]\n', "job_stream: expected a table, got list"),
    ('\n[manager]\nclass = "vcran.managers:Dispatcher"\noptions = 3\n', "manager.options: expected a table"),
])
def test_bad_station_choices_fail_to_load(table, message):
    with pytest.raises(ScenarioError, match=message):
        load(table)


def test_link_defaults_are_subscription_and_50_ms():
    link = load("").link
    assert (link.latency, link.jitter, link.inbound) == (0.05, 0.0, "subscription")


@pytest.mark.parametrize("table, message", [
    ("\n[link]\nlatency = 0.0\n", "latency"),
    ("\n[link]\ninbound = 'carrier pigeon'\n", "unknown inbound 'carrier pigeon'; known: subscription, polling"),
    ("\n[link]\njitter = -0.1\n", "jitter"),
    ("\n[link]\nloss = 0.1\n", "loss"),
    ("\n[manager]\nclass = 'no colon'\n", "expected 'module:Class'"),
    ("\n[manager]\nklass = 'a:B'\n", "class"),
])
def test_bad_link_and_manager_tables_fail_to_load(table, message):
    with pytest.raises(ScenarioError, match=message):
        load(table)


def test_manager_table_keeps_its_options_for_the_class():
    sc = load("\n[manager]\nclass = 'vcran.managers:Dispatcher'\noptions = { max_tries = 5 }\n")
    assert sc.manager is not None
    assert sc.manager.path == "vcran.managers:Dispatcher" and dict(sc.manager.options) == {"max_tries": 5}


def test_a_dock_of_the_wrong_shape_fails_to_load():
    with pytest.raises(ScenarioError, match=r"stations\[0\]: field 'dock': expected \[x, y\] or \[x, y, theta\]"):
        parse(tomllib.loads(FLEET.replace('position = [0.0, 0.0]', 'position = [0.0, 0.0]\ndock = [1.0]')))


def test_station_dock_loads_with_or_without_heading():
    sc = parse(tomllib.loads(FLEET.replace('position = [0.0, 0.0]', 'position = [0.0, 0.0]\ndock = [1.0, 0.0, 3.0]')
                             .replace('position = [10.0, 0.0]', 'position = [10.0, 0.0]\ndock = [9.0, 0.0]')))
    assert [s.dock for s in sc.stations] == [(1.0, 0.0, 3.0), (9.0, 0.0, None), None]


@pytest.mark.parametrize(("station", "problem"), [
    # a charger's dock 5 m off: the Dispatcher sent robots there to charge, and every charge failed
    # no_charger_in_reach (a pickup's: every load failed), the run going on as if that were the robots' fault
    ("position = [0.0, 0.0]\ndock = [0.0, 5.0]", "[0, 5] is 5 m from the station's position [0, 0], beyond its reach 1"),
    ("position = [0.0, 0.0]\nreach = 2.0\ndock = [2.0, 0.1]", "beyond its reach 2"),
    ("position = [0.0, 0.0]\narea = [[-1, -1], [1, -1], [1, 1], [-1, 1]]\ndock = [1.5, 0.0]", "outside the station's area"),
])
def test_a_dock_where_a_robot_cannot_reach_the_station_fails_to_load(station, problem):
    """The dock is where a robot stands to load or unload at a station (docs/scenarios.md)."""
    with pytest.raises(ScenarioError, match=r"stations\[0\]: field 'dock': .*" + re.escape(problem)):
        parse(tomllib.loads(FLEET.replace("position = [0.0, 0.0]", station, 1)), "<test>")


def test_a_dock_at_the_edge_of_reach_or_area_loads():
    for station in ("position = [0.0, 0.0]\ndock = [1.0, 0.0, 3.0]",  # exactly the reach: as within_reach says
                    "position = [0.0, 0.0]\narea = [[-1, -1], [1, -1], [1, 1], [-1, 1]]\ndock = [1.0, 1.0]"):
        parse(tomllib.loads(FLEET.replace("position = [0.0, 0.0]", station, 1)), "<test>")


def test_the_toml_key_rate_is_the_python_field_rate():
    """issue 29 item 13: ``[job_stream] rate`` (jobs per hour) is ``JobStream.rate``, so
    ``replace(stream, rate=...)`` says what a sweep's ``job_stream.rate`` says; ``mean_interval``
    (seconds), the other spelling files may use, loads as ``rate = 3600 / mean_interval`` and stays
    readable as a property. The first arrival, by hand: the stream's own generator, an exponential gap of
    mean 3600 / 360 = 10 s (``random.expovariate(1 / 10)``), from start 0."""
    import random
    from dataclasses import replace

    from vcran.io.scenario_toml import loop_dict

    sc = load(stream().replace("mean_interval = 10.0", "rate = 360.0"))
    assert sc.job_stream is not None and sc.job_stream.rate == 360.0 and sc.job_stream.mean_interval == 10.0
    first = random.Random("job_stream:5").expovariate(1 / 10.0)
    assert next(sc.workload()).t == first
    assert loop_dict(sc)["job_stream"]["rate"] == 360.0 and "mean_interval" not in loop_dict(sc)["job_stream"]
    faster = replace(sc.job_stream, rate=720.0)
    assert faster.mean_interval == 5.0
    old = load(stream())  # mean_interval = 10.0
    assert old.job_stream is not None and old.job_stream.rate == 360.0
    assert list(old.workload()) == list(sc.workload())
