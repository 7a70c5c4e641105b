"""``vcran sweep`` (docs/contract.md §10): a run in a sweep is the run alone, byte for byte; the same rows from this process,
a local process pool and a real Dask LocalCluster on loopback; failures and Ctrl-C keep every row done
(after Ctrl-C in DIR.incomplete: test_sweep_out_folder.py)."""

from __future__ import annotations

import csv
import io
import json
from pathlib import Path

import pytest

from tests.conftest import ROOT
from vcran.cli import main
from vcran.sweep import worker

DEMO = ROOT / "scenarios" / "demo.toml"
RUN_FILES = ("trace.jsonl.zst", "legs.npy", "events.jsonl.zst", "summary.json")

SWEEP = """scenario = "{scenario}"
seeds = [1, 2]
[grid]
"simulation.task_timeout" = [1.5, 30.0]
"robots.*.max_velocity" = [0.5, 1.0]
"""


@pytest.fixture
def sweep_file(tmp_path: Path) -> Path:
    path = tmp_path / "sweep.toml"
    path.write_text(SWEEP.format(scenario=DEMO.as_posix()))
    return path


def rows(out: Path, drop_wall: bool = True) -> list[dict[str, str]]:
    table = list(csv.DictReader(io.StringIO((out / "runs.csv").read_text())))
    for r in table:
        if drop_wall:
            del r["wall_seconds"]
    return table


@pytest.mark.slow
def test_a_run_in_a_sweep_is_byte_identical_to_the_same_variant_and_seed_alone(sweep_file, tmp_path):
    out = tmp_path / "sweep"
    assert main(["sweep", str(sweep_file), "--out", str(out), "--workers", "2", "--keep-runs", "--quiet"]) == 0
    # run 5: the second variant of timeout 1.5 (max_velocity 1.0), second seed -- written by hand from demo.toml
    alone_text = DEMO.read_text()
    for old, new in (("task_timeout = 30.0", "task_timeout = 1.5"), ("seed = 1\n", "seed = 2\n"),
                     ("max_velocity = 1.0 ", "max_velocity = 1.0 ")):
        assert old in alone_text
        alone_text = alone_text.replace(old, new)
    alone = tmp_path / "alone.toml"
    alone.write_text(alone_text)
    assert main(["run", str(alone), "--out", str(tmp_path / "alone"), "--quiet"]) == 0
    kept = out / "runs" / "0003"
    row = rows(out)[3]
    assert (row["simulation.task_timeout"], row["robots.*.max_velocity"], row["seed"]) == ("1.5", "1.0", "2")
    for name in RUN_FILES:
        assert (kept / name).read_bytes() == (tmp_path / "alone" / name).read_bytes(), name
    # the kept scenario.toml reproduces it too
    assert main(["run", str(kept / "scenario.toml"), "--out", str(tmp_path / "again"), "--quiet"]) == 0
    for name in RUN_FILES:
        assert (kept / name).read_bytes() == (tmp_path / "again" / name).read_bytes(), name


@pytest.mark.slow
def test_rows_follow_from_the_demo_by_hand(sweep_file, tmp_path):
    """The demo's three tasks arrive one message a second: a 1.5 s timeout (R7) cancels all three before
    any is assembled, 30 s completes all three (docs/demo.md); the slower AGV needs longer."""
    out = tmp_path / "sweep"
    assert main(["sweep", str(sweep_file), "--out", str(out), "--workers", "1", "--quiet"]) == 0
    table = rows(out)
    assert [(r["run"], r["variant"], r["seed"]) for r in table] == [
        (str(i), str(i // 2), str(1 + i % 2)) for i in range(8)]
    for r in table:
        assert r["error"] == ""
        short = r["simulation.task_timeout"] == "1.5"
        assert (r["tasks_completed"], r["cancelled_timeout"]) == (("0", "3") if short else ("3", "0"))
    slow, fast = (float(table[i]["sim_time"]) for i in (4, 6))
    assert slow > fast
    header = (out / "runs.csv").read_text().splitlines()[0].split(",")
    assert header[:5] == ["run", "variant", "simulation.task_timeout", "robots.*.max_velocity", "seed"]
    assert header[5] == "error" and header[-1] == "wall_seconds"
    assert sorted(p.name for p in out.glob("kpi-by-*.png")) == [
        "kpi-by-robots.each.max_velocity.png", "kpi-by-simulation.task_timeout.png"]


@pytest.mark.slow
def test_embedded_process_pool_and_dask_localcluster_give_the_same_rows(sweep_file, tmp_path):
    distributed = pytest.importorskip("distributed")
    pq = pytest.importorskip("pyarrow.parquet")
    outs = {name: tmp_path / name for name in ("here", "pool", "dask")}
    assert main(["sweep", str(sweep_file), "--out", str(outs["here"]), "--workers", "1", "--quiet"]) == 0
    assert main(["sweep", str(sweep_file), "--out", str(outs["pool"]), "--workers", "2", "--quiet"]) == 0
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=False, protocol="tcp",
                                  host="127.0.0.1", scheduler_port=0, dashboard_address=None) as cluster:
        address = cluster.scheduler_address
        assert address.startswith("tcp://127.0.0.1:")
        assert main(["sweep", str(sweep_file), "--out", str(outs["dask"]), "--cluster", address, "--quiet"]) == 0
    expected = rows(outs["here"])
    assert len(expected) == 8
    assert rows(outs["pool"]) == expected
    assert rows(outs["dask"]) == expected
    parquet = pq.read_table(outs["dask"] / "runs.parquet").to_pylist()
    assert [r["run"] for r in parquet] == list(range(8))
    assert [r["simulation.task_timeout"] for r in parquet] == [1.5] * 4 + [30.0] * 4
    assert [r["tasks_completed"] for r in parquet] == [int(r["tasks_completed"]) for r in expected]
    assert all(r["error"] is None and r["wall_seconds"] > 0 for r in parquet)


@pytest.mark.slow
def test_a_failing_run_is_a_row_with_its_error(sweep_file, tmp_path, monkeypatch, capsys):
    real = worker.simulate

    def simulate(scenario, **options):
        if scenario.settings.seed == 2 and scenario.settings.task_timeout == 30.0:
            raise RuntimeError("the fleet manager crashed")
        return real(scenario, **options)

    monkeypatch.setattr(worker, "simulate", simulate)
    out = tmp_path / "sweep"
    assert main(["sweep", str(sweep_file), "--out", str(out), "--workers", "1"]) == 1
    table = rows(out)
    assert len(table) == 8
    failed = [r["run"] for r in table if r["error"]]
    assert failed == ["5", "7"]
    assert table[5]["error"] == "RuntimeError: the fleet manager crashed" and table[5]["tasks_completed"] == ""
    assert table[4]["tasks_completed"] == "3"
    text = capsys.readouterr().out
    assert "8 runs" in text and "6 ran, 2 failed" in text and "run 5 (seed 2): RuntimeError" in text


def interrupt_run(monkeypatch, n: int, signal: type[KeyboardInterrupt] = KeyboardInterrupt) -> None:
    """Ctrl-C (or ``signal``: the CLI's Terminated, SIGTERM) as the sweep's ``n``-th run starts (in this
    process: ``--workers 1``)."""
    real, calls = worker.simulate, []

    def simulate(scenario, **options):
        calls.append(1)
        if len(calls) == n:
            raise signal
        return real(scenario, **options)

    monkeypatch.setattr(worker, "simulate", simulate)


@pytest.mark.slow
def test_ctrl_c_keeps_the_rows_already_done(sweep_file, tmp_path, monkeypatch, capsys):
    interrupt_run(monkeypatch, 4)
    out = tmp_path / "sweep"
    assert main(["sweep", str(sweep_file), "--out", str(out), "--workers", "1", "--quiet"]) == 130
    partial = tmp_path / "sweep.incomplete"  # never a DIR that looks finished (docs/contract.md §6)
    assert [r["run"] for r in rows(partial)] == ["0", "1", "2"] and not out.exists()
    assert "interrupted: 3 of 8 runs done" in capsys.readouterr().err
    assert not list(partial.glob("*.tmp"))


def test_sigterm_keeps_the_rows_already_done_and_exits_143(sweep_file, tmp_path, monkeypatch, capsys):
    # README: SIGTERM is taken as Ctrl-C and exits 143, as every command reports it; the sweep said 130
    from vcran.commands._signals import Terminated

    interrupt_run(monkeypatch, 4, Terminated)
    out = tmp_path / "sweep"
    assert main(["sweep", str(sweep_file), "--out", str(out), "--workers", "1", "--quiet"]) == 143
    assert [r["run"] for r in rows(tmp_path / "sweep.incomplete")] == ["0", "1", "2"] and not out.exists()


def test_kpis_of_a_summary_written_by_hand():
    summary = {
        "sim_time": 100.0, "errors": 2,
        "robots": {
            "a": {"completed": ["t1", "t2"], "cancelled": [{"task": "t3", "reason": "timeout"}],
                  "distance": 1.5, "parts_moved": 1, "collisions": 1,
                  "battery": {"charge": 9.75, "percentage": 97.5, "used": 0.25, "charged": 0.0}},
            "b": {"completed": [], "cancelled": [{"task": "t4", "reason": "cancelled"},
                                                 {"task": "t5", "reason": "timeout"},
                                                 {"task": "t6", "reason": "collision"}],
                  "distance": 2.0, "parts_moved": 0, "collisions": 1},  # a and b met once (docs/contract.md §4)
            "c": {"completed": [], "cancelled": [], "distance": 0.0, "parts_moved": 0,
                  "battery": {"charge": 9.5, "percentage": 95.0, "used": 0.5, "charged": 0.0}},
        },
        "jobs": {"arrived": 4, "completed": 3, "lead_time": {"mean": 12.5, "p95": None}},
        "utilisation": {"a": 0.5, "b": 0.25, "fleet": 0.375},
    }
    assert worker.kpis(summary) == {
        "sim_time": 100.0, "tasks_completed": 2, "tasks_cancelled": 4, "cancelled_timeout": 2,
        "cancelled_cancelled": 1, "cancelled_action_failed": 0, "cancelled_battery_empty": 0,
        "cancelled_motion_failed": 0, "cancelled_collision": 1, "distance": 3.5, "parts_moved": 1, "errors": 2,
        "collisions": 1, "battery_used": 0.75,
        "jobs_arrived": 4, "jobs_completed": 3, "jobs_lead_time_mean": 12.5,  # p95 None: an empty cell
        "utilisation": 0.375,
    }


@pytest.mark.parametrize(("argv", "message"), [
    (["--workers", "0"], "--workers must be at least 1"),
    (["--workers", "2", "--cluster", "tcp://127.0.0.1:9"], "--workers and --cluster exclude each other"),
])
def test_bad_options_are_one_line_and_exit_2(sweep_file, tmp_path, capsys, argv, message):
    assert main(["sweep", str(sweep_file), "--out", str(tmp_path / "o"), *argv]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"vcran sweep: {message}") and err.count("\n") == 1


def test_a_bad_sweep_file_is_one_line_and_exit_2(tmp_path, capsys):
    bad = tmp_path / "bad.toml"
    bad.write_text(SWEEP.format(scenario=DEMO.as_posix()).replace("max_velocity", "max_velocityy"))
    assert main(["sweep", str(bad), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"vcran sweep: {bad}: variant 0 (") and "'max_velocityy': unknown key" in err
    assert err.count("\n") == 1 and not (tmp_path / "o").exists()


def test_an_out_folder_that_cannot_be_made_is_one_line(sweep_file, tmp_path, capsys):
    (tmp_path / "file").write_text("")
    assert main(["sweep", str(sweep_file), "--out", str(tmp_path / "file" / "o"), "--workers", "1"]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"vcran sweep: {tmp_path / 'file' / 'o'}: cannot create o.incomplete beside it")
    assert err.count("\n") == 1


def test_an_unreachable_scheduler_is_a_pool_error():
    pytest.importorskip("distributed")
    from vcran.sweep.pool import DaskPool, PoolError

    with pytest.raises(PoolError, match=r"cannot reach the Dask scheduler at tcp://127\.0\.0\.1:9"):
        DaskPool("tcp://127.0.0.1:9", timeout=0.5)


def test_a_scheduler_address_dask_cannot_use_is_a_pool_error():
    # a comm Dask knows but cannot use here (ucx without its package) was exit 70, "a bug in vcran"
    pytest.importorskip("distributed")
    from vcran.sweep.pool import DaskPool, PoolError

    with pytest.raises(PoolError, match=r"^cannot reach the Dask scheduler at ucx://127\.0\.0\.1:9: "):
        DaskPool("ucx://127.0.0.1:9", timeout=0.5)


def test_a_tls_scheduler_without_tls_settings_is_one_line_and_exit_2(sweep_file, tmp_path, capsys):
    # docs/sweeps.md: Dask's distributed.comm.tls settings apply to vcran's client; without them a tls://
    # address was a TypeError from deep in Dask (exit 70), and a half-made client held the process for 20 s
    pytest.importorskip("distributed")
    out = tmp_path / "o"
    assert main(["sweep", str(sweep_file), "--out", str(out), "--cluster", "tls://127.0.0.1:9"]) == 2
    err = capsys.readouterr().err
    assert err == ("vcran sweep: tls://127.0.0.1:9: a tls:// scheduler needs Dask's TLS settings "
                   "(distributed.comm.tls: ca-file, client cert and key), and none are set\n")
    assert not out.exists() and not (tmp_path / "o.incomplete").exists()


def test_stopping_the_local_pool_ends_its_workers_without_waiting():
    import time

    from vcran.sweep.pool import LocalPool

    pool = LocalPool(2)
    pool.run(time.sleep, [(60.0,)] * 4)  # submitted at once: two workers start, each on a minute's sleep
    processes = list(pool._executor._processes.values())
    assert len(processes) == 2 and all(p.is_alive() for p in processes)
    pool.stop()
    assert not any(p.is_alive() for p in processes)
    # The queued ones end without running: cancelled, or (those the executor had already moved to its call
    # queue, which may be all of them on a quick machine) failed as a broken pool once the executor's own
    # thread sees its workers gone, which it does on its own time.
    deadline = time.monotonic() + 30
    while not all(f.done() for f in pool._futures) and time.monotonic() < deadline:
        time.sleep(0.05)
    assert all(f.done() and (f.cancelled() or f.exception() is not None) for f in pool._futures)
    pool.close()


@pytest.mark.slow
def test_json_params_in_csv(tmp_path):
    path = tmp_path / "s.toml"
    path.write_text(f'scenario = "{DEMO.as_posix()}"\nseeds = [1]\n[[variants]]\nname = "moved"\n'
                    '"robots.robot_1.pose" = [0.5, 0.0, 0.0]\n')
    out = tmp_path / "o"
    assert main(["sweep", str(path), "--out", str(out), "--workers", "1", "--quiet"]) == 0
    (r,) = rows(out)
    assert (r["label"], json.loads(r["robots.robot_1.pose"])) == ("moved", [0.5, 0.0, 0.0])


def test_a_scheduler_lost_mid_sweep_is_exit_2_and_an_incomplete_folder(sweep_file, tmp_path, monkeypatch, capsys):
    # docs/contract.md §10 and docs/contract.md §6: the runs Dask cancelled when it lost its scheduler are neither dropped from a folder that
    # looks finished (exit 0) nor taken for the runs' own failures; the rows done stay in DIR.incomplete
    distributed = pytest.importorskip("distributed")
    from tests.sweep.lost_scheduler import lost_at_seed

    lost = lost_at_seed(monkeypatch, 2)
    # Dask's client logs its reconnection with a traceback, on the stderr it kept (capsys does not see it)
    import logging

    from vcran.sweep import pool

    client_log, logged, real_open = logging.getLogger("distributed.client"), [], pool.open_pool

    def open_pool(*args, **kwargs):
        client_log.setLevel(logging.WARNING)  # as the first import of distributed, in a `vcran` process, sets it
        return real_open(*args, **kwargs)

    class Keep(logging.Handler):
        def emit(self, record):
            logged.append(record)

    monkeypatch.setattr(pool, "open_pool", open_pool)
    monkeypatch.setattr(client_log, "level", client_log.level)
    monkeypatch.setattr(client_log, "handlers", [*client_log.handlers, Keep()])
    out = tmp_path / "sweep"
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=False, protocol="tcp",
                                  host="127.0.0.1", scheduler_port=0, dashboard_address=None) as cluster:
        address = cluster.scheduler_address
        try:
            code = main(["sweep", str(sweep_file), "--out", str(out), "--cluster", address, "--quiet"])
        finally:
            lost.end()
    assert [r.getMessage() for r in logged if r.levelno >= logging.ERROR] == []
    assert code == 2 and not out.exists()
    assert len(rows(tmp_path / "sweep.incomplete")) < 8
    err = capsys.readouterr().err
    assert err.startswith(f"vcran sweep: lost the Dask scheduler at {address}: ")
    assert err.count("\n") == 1
    assert f"of 8 runs done (0 failed); their rows are in {tmp_path / 'sweep.incomplete' / 'runs.csv'}" in err


FAILING_MANAGERS = f"""scenario = "{(ROOT / 'scenarios' / 'warehouse.toml').as_posix()}"
seeds = [1]
[grid]
"simulation.duration" = [60.0]
manager = ["tests.testing.loop_managers:Raising", "tests.testing.loop_managers:Exiting"]
"""


def test_a_fleet_manager_that_raises_or_exits_is_its_run_s_row_the_same_in_any_pool(tmp_path, capsys):
    # docs/contract.md §10: runs.csv without wall_seconds is the same whichever pool ran it; a manager's sys.exit() ended a
    # sweep in this process (exit 3, no rows) and ended Dask's workers one after the other (KilledWorker),
    # and a raise lost the hook and time that `vcran run` names
    path = tmp_path / "managers.toml"
    path.write_text(FAILING_MANAGERS)
    for workers in ("1", "2"):
        assert main(["sweep", str(path), "--out", str(tmp_path / workers), "--workers", workers, "--quiet"]) == 1
    table = rows(tmp_path / "1")
    assert rows(tmp_path / "2") == table
    assert [r["error"] for r in table] == [
        "RuntimeError: my bug (in fleet manager Raising: on_job at t=0.226908515304104)",  # the first job, seed 1
        "RuntimeError: on_job called sys.exit(3) (in fleet manager Exiting: on_job at t=0.226908515304104)",
    ]


def test_a_local_worker_that_dies_fails_only_the_run_that_kills_it(tmp_path):
    # docs/contract.md §10: a worker process killed part way broke the executor, and every run not finished, most never
    # started, came back failed with BrokenProcessPool; now they run again, and only the run whose own
    # process dies again is a failure
    from tests.sweep.dying import square_or_die
    from vcran.sweep.pool import LocalPool, WorkerDied

    pool = LocalPool(2)
    try:
        results = dict(pool.run(square_or_die, [(i, i == 2) for i in range(9)]))
    finally:
        pool.close()
    assert sorted(results) == list(range(9))
    assert isinstance(results[2], WorkerDied)
    assert str(results[2]) == ("its worker process died under it twice (exit code 9): a crash, os._exit, or the "
                               "system's out-of-memory killer")
    assert {i: r for i, r in results.items() if i != 2} == {i: i * i for i in range(9) if i != 2}


def test_a_local_worker_killed_once_loses_no_run(tmp_path):
    from tests.sweep.dying import square_or_die
    from vcran.sweep.pool import LocalPool

    once = str(tmp_path / "died")
    pool = LocalPool(2)
    try:
        results = dict(pool.run(square_or_die, [(i, i == 1, once) for i in range(12)]))
    finally:
        pool.close()
    assert results == {i: i * i for i in range(12)}


def test_a_scheduler_without_workers_says_so_before_the_runs_wait(sweep_file, tmp_path):
    # a new user's first `dask scheduler` without a `dask worker`: the sweep waited, silently, for ever
    distributed = pytest.importorskip("distributed")
    from vcran.sweep.pool import DaskPool

    with distributed.LocalCluster(n_workers=0, threads_per_worker=1, processes=False, protocol="tcp",
                                  host="127.0.0.1", scheduler_port=0, dashboard_address=None) as cluster:
        pool = DaskPool(cluster.scheduler_address)
        try:
            assert pool.name == f"Dask cluster {cluster.scheduler_address} (no workers yet: the runs wait for one to join)"
        finally:
            pool.close()
        cluster.scale(2)
        cluster.wait_for_workers(2)
        pool = DaskPool(cluster.scheduler_address)
        try:
            assert pool.name == f"Dask cluster {cluster.scheduler_address} (2 workers, 2 threads)"
        finally:
            pool.close()
