"""A Dask scheduler lost part way, for tests (docs/contract.md §10): a run cuts the connection of vcran's client to its
scheduler, which is what the client sees when the scheduler's machine goes down, while the LocalCluster
itself stays up and closes at once at the end of the test."""

from __future__ import annotations

import threading
from typing import Any

from vcran.sweep import worker
from vcran.sweep.pool import DaskPool


class LostScheduler:
    """Call :meth:`now` from inside a job (a Dask worker thread of a ``LocalCluster(processes=False)``)."""

    def __init__(self, monkeypatch: Any) -> None:
        self.clients: list[Any] = []
        self.release = threading.Event()
        real = DaskPool.run

        def run(pool: DaskPool, fn: Any, jobs: Any) -> Any:
            self.clients.append(pool._client)
            return real(pool, fn, jobs)

        monkeypatch.setattr(DaskPool, "run", run)

    def now(self) -> None:
        """Cut the client's connection, then hold this job until :meth:`end`: it never finishes by itself."""
        client = self.clients[0]
        client.loop.add_callback(client.scheduler_comm.comm.abort)
        self.release.wait(60)

    def end(self) -> None:
        self.release.set()


def lost_at_seed(monkeypatch: Any, seed: int) -> LostScheduler:
    """A scheduler lost when the run of ``seed`` starts (that run then never finishes by itself)."""
    lost, real = LostScheduler(monkeypatch), worker.simulate

    def simulate(scenario: Any, **options: Any) -> Any:
        if scenario.settings.seed == seed:
            lost.now()
        return real(scenario, **options)

    monkeypatch.setattr(worker, "simulate", simulate)
    return lost
