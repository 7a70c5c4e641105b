"""Where the runs of a sweep or the chunks of a fuzz campaign execute: this process, a local process
pool, or a Dask cluster (SPEC §10). All three take the same plain-data jobs and yield results as they
finish; a job's result is whatever the function returned, or the exception that stopped it.

The local pool is :class:`concurrent.futures.ProcessPoolExecutor` with the ``forkserver`` start method
(``spawn`` where there is none: no forked copies of a parent's threads and locks). Its workers ignore
SIGINT, so Ctrl-C reaches only this process, which stops the pool and keeps what is done. Past one
machine, a Dask ``distributed`` client does the same job over a scheduler's workers: vcran brings no
scheduler of its own.
"""

from __future__ import annotations

import os
import signal
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from multiprocessing import get_all_start_methods, get_context
from typing import Any, Protocol

Job = tuple[Any, ...]


class PoolError(RuntimeError):
    """A pool that cannot start (a missing extra, a scheduler that cannot be reached, a ``tls://`` address
    without TLS settings), or a cluster lost part way (its scheduler went away): the surroundings, not a run."""

    #: What ``run_sweep`` had done when its cluster was lost (a SweepResult, ``interrupted``); else None.
    result: Any = None


class Pool(Protocol):
    #: What the progress line and the report call it: "this process", "4 local processes", "tcp://...".
    name: str

    def run(self, fn: Callable[..., Any], jobs: Sequence[Job]) -> Iterator[tuple[int, Any]]:
        """Start the jobs (a pool submits them all at once, this process one by one as the iterator is
        read); the iterator yields (position in ``jobs``, result or exception) in the order they finish."""
        ...

    def stop(self) -> None:
        """Drop every job not yet finished, without waiting for the running ones."""
        ...

    def close(self) -> None: ...


def machine_workers() -> int:
    """The CPUs this process may use (its affinity, where the OS says), at least 1."""
    try:
        return max(len(os.sched_getaffinity(0)), 1)
    except AttributeError:  # not on Linux
        return os.cpu_count() or 1


def open_pool(workers: int | None = None, cluster: str | None = None, jobs: int | None = None) -> Pool:
    """A Dask client of ``cluster`` if given; else ``workers`` local processes (default: one per CPU,
    never more than ``jobs``), or this process when that is one. A ValueError for ``workers`` that is not
    a whole number of at least 1, or that comes with ``cluster`` (whose workers are its own), as the
    commands' ``--workers`` refuses them."""
    if workers is not None and (isinstance(workers, bool) or not isinstance(workers, int) or workers < 1):
        raise ValueError(f"workers must be a whole number of at least 1, got {workers!r}")
    if workers is not None and cluster is not None:
        raise ValueError("workers and cluster exclude each other: a cluster's workers are its own")
    if cluster is not None:
        return DaskPool(cluster)
    n = workers if workers is not None else machine_workers()
    if jobs is not None:
        n = min(n, max(jobs, 1))
    return InProcess() if n <= 1 else LocalPool(n)


class InProcess:
    """Runs jobs one after the other here: no start-up cost, and Ctrl-C stops the job that runs."""

    name = "this process"

    def __init__(self) -> None:
        self._stopped = False

    def run(self, fn: Callable[..., Any], jobs: Sequence[Job]) -> Iterator[tuple[int, Any]]:
        for i, job in enumerate(jobs):
            if self._stopped:
                return
            try:
                yield i, fn(*job)
            except Exception as exc:  # noqa: BLE001 - a job's failure is its result
                yield i, exc

    def stop(self) -> None:
        self._stopped = True

    def close(self) -> None:
        pass


#: Modules a fork server imports once, before it forks the workers: what every job needs.
PRELOAD = ["vcran.sweep.worker"]


def _context() -> Any:
    """``forkserver`` where the OS has it: a clean server process (no parent threads or locks, unlike
    ``fork``) that imported vcran once and forks each worker ready to run, where ``spawn`` makes every
    worker import it again (a second or more per worker on a loaded machine). ``spawn`` elsewhere."""
    if "forkserver" in get_all_start_methods():
        context = get_context("forkserver")
        context.set_forkserver_preload(PRELOAD)
        return context
    return get_context("spawn")


def _ignore_sigint() -> None:
    signal.signal(signal.SIGINT, signal.SIG_IGN)


class LocalPool:
    """Jobs on ``workers`` processes of this machine, each job pickled to a free worker."""

    def __init__(self, workers: int) -> None:
        self.name = f"{workers} local processes"
        self._executor = ProcessPoolExecutor(workers, mp_context=_context(), initializer=_ignore_sigint)
        self._futures: list[Future[Any]] = []

    def run(self, fn: Callable[..., Any], jobs: Sequence[Job]) -> Iterator[tuple[int, Any]]:
        self._futures = [self._executor.submit(fn, *job) for job in jobs]
        return self._finished()

    def _finished(self) -> Iterator[tuple[int, Any]]:
        position = {id(f): i for i, f in enumerate(self._futures)}
        pending = set(self._futures)
        while pending:
            done, pending = wait(pending, return_when=FIRST_COMPLETED)
            for f in sorted(done, key=lambda f: position[id(f)]):
                if f.cancelled():
                    continue
                exc = f.exception()
                yield position[id(f)], exc if exc is not None else f.result()

    def stop(self) -> None:
        """Cancel what has not started and end the workers now: a run in progress is lost either way,
        and waiting for it would keep Ctrl-C waiting for minutes."""
        processes = list(getattr(self._executor, "_processes", {}).values())  # no public handle before 3.14
        self._executor.shutdown(wait=False, cancel_futures=True)
        for p in processes:
            p.terminate()
        for p in processes:
            p.join(timeout=2)
            if p.is_alive():  # SIGTERM not acted on in time (a loaded machine): no second chance
                p.kill()
                p.join()

    def close(self) -> None:
        self._executor.shutdown(wait=True, cancel_futures=True)


class DaskPool:
    """Jobs as tasks of a Dask ``distributed`` scheduler. Its workers need vcran installed (and any fleet
    manager a sweep names); they never need the sweep's files: jobs carry the scenario's text."""

    def __init__(self, address: str, timeout: float = 10.0) -> None:
        try:
            from distributed import Client
        except ImportError:
            raise PoolError("--cluster needs Dask's distributed package: pip install 'vcran[sweep]'") from None
        _check_security(address)
        try:
            self._client = Client(address, timeout=timeout, set_as_default=False)
        except Exception as exc:  # noqa: BLE001 - refused, timed out, a bad address, a comm not installed (ucx)
            raise PoolError(f"cannot reach the Dask scheduler at {address}: {exc}") from None
        self.address = address
        self.name = f"Dask cluster {address}"
        self._futures: list[Any] = []
        self._stopped = False

    def run(self, fn: Callable[..., Any], jobs: Sequence[Job]) -> Iterator[tuple[int, Any]]:
        self._futures = [self._client.submit(fn, *job, pure=False) for job in jobs]
        return self._finished()

    def _finished(self) -> Iterator[tuple[int, Any]]:
        from distributed import as_completed

        position = {f.key: i for i, f in enumerate(self._futures)}
        for f in as_completed(self._futures, loop=self._client.loop):
            try:
                if f.cancelled():
                    f.result()  # raises why: Dask cancels every future when it loses the scheduler
                exc = f.exception()
                result = exc if exc is not None else f.result()
            except Exception as lost:  # noqa: BLE001 - cancelled (now or meanwhile), or its result not fetched
                if self._stopped:
                    continue
                # not by stop(): a job is never dropped silently, nor its loss taken for the run's own error
                raise PoolError(f"lost the Dask scheduler at {self.address}: {_why(lost)}") from None
            yield position[f.key], result

    def stop(self) -> None:
        """Cancel every task not finished. A task already running on a worker runs to its end there
        (a worker thread cannot be interrupted); its result is dropped."""
        self._stopped = True
        if self._futures:
            self._client.cancel(self._futures)

    def close(self) -> None:
        self._client.close()


def _check_security(address: str) -> None:
    """A ``tls://`` (or ``wss://``) address needs Dask's TLS settings (``distributed.comm.tls``): without
    them Dask's client fails with a TypeError, and its half-made client then holds the process for 20 s."""
    from distributed.comm.addressing import parse_address
    from distributed.security import Security

    try:
        scheme, _ = parse_address(address)
    except ValueError:
        return  # the client says what is wrong with it
    if scheme in ("tls", "wss") and Security().get_connection_args("client").get("ssl_context") is None:
        raise PoolError(f"{address}: a {scheme}:// scheduler needs Dask's TLS settings (distributed.comm.tls: "
                        "ca-file, client cert and key), and none are set")


def _why(exc: BaseException) -> str:
    """What Dask says of a future it cancelled (its reason, ``scheduler-connection-lost``, and message), or
    of a result it could not fetch, in one line."""
    reason = getattr(exc, "reason", None)
    said = " ".join(str(getattr(exc, "msg", None) or ("" if reason else exc)).split())
    return f"{reason or type(exc).__name__}{f' ({said})' if said else ''}"
