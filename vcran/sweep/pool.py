"""Where the runs of a sweep or the chunks of a fuzz campaign execute: this process, a local process
pool, or a Dask cluster (docs/contract.md §10). All three take the same plain-data jobs and yield results as they
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
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, as_completed, wait
from concurrent.futures.process import BrokenProcessPool
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


class WorkerDied(RuntimeError):
    """The result of a job whose process ended under it twice, once among the others' and once on its own:
    a crash, ``os._exit``, or the system's out-of-memory killer. Only that job's: the others run again."""


class LocalPool:
    """Jobs on ``workers`` processes of this machine, each job pickled to a free worker.

    A worker that dies (the out-of-memory killer, a crash, a run that calls ``os._exit``) breaks the
    executor, which then fails every job not finished, most of which never started. Those are run again,
    never reported as failures of their own: the few that may have been on the dead process (the first
    ``2 * workers + 1`` not finished, in the order they were submitted, which is the order the executor
    starts them in) each on a process of its own, then the rest on a new pool. A job whose own process
    dies too is the one that kills it, and its result is :class:`WorkerDied`.
    """

    def __init__(self, workers: int) -> None:
        self.name = f"{workers} local processes"
        self._workers = workers
        self._executor = _executor(workers)
        self._futures: list[Future[Any]] = []
        self._alone: list[ProcessPoolExecutor] = []  # a retry's one-process executors while they run
        self._stopped = False

    def run(self, fn: Callable[..., Any], jobs: Sequence[Job]) -> Iterator[tuple[int, Any]]:
        self._futures = [self._executor.submit(fn, *job) for job in jobs]
        return self._finished(fn, jobs)

    def _finished(self, fn: Callable[..., Any], jobs: Sequence[Job]) -> Iterator[tuple[int, Any]]:
        order = list(range(len(jobs)))  # the job of each of self._futures
        while True:
            lost: list[int] = []
            for i, result in self._results(order):
                if isinstance(result, BrokenProcessPool):
                    lost.append(i)
                else:
                    yield i, result
            if not lost or self._stopped:
                return
            lost.sort()
            suspects, rest = lost[:2 * self._workers + 1], lost[2 * self._workers + 1:]
            self._executor.shutdown(wait=False)
            yield from self._each_alone(fn, jobs, suspects)  # first: never more processes than workers
            if self._stopped:
                return
            self._executor = _executor(self._workers)
            self._futures = [self._executor.submit(fn, *jobs[i]) for i in rest]
            order = rest

    def _results(self, order: list[int]) -> Iterator[tuple[int, Any]]:
        position = {id(f): order[k] for k, f in enumerate(self._futures)}
        pending = set(self._futures)
        while pending:
            done, pending = wait(pending, return_when=FIRST_COMPLETED)
            for f in sorted(done, key=lambda f: position[id(f)]):
                if f.cancelled():
                    continue
                exc = f.exception()
                yield position[id(f)], exc if exc is not None else f.result()

    def _each_alone(self, fn: Callable[..., Any], jobs: Sequence[Job], suspects: list[int]) -> Iterator[tuple[int, Any]]:
        """Each job that may have been on a process that died, on a process of its own (``workers`` at a
        time): one whose process dies again is the job that ends it."""
        for start in range(0, len(suspects), self._workers):
            batch = suspects[start:start + self._workers]
            self._alone = [_executor(1) for _ in batch]
            futures = {executor.submit(fn, *jobs[i]): (i, executor) for i, executor in zip(batch, self._alone)}
            processes = {i: list(getattr(executor, "_processes", {}).values()) for i, executor in futures.values()}
            for f in as_completed(futures):
                i, _ = futures[f]
                exc = f.exception()
                if isinstance(exc, BrokenProcessPool):
                    exc = WorkerDied(f"its worker process died under it twice ({_ended(processes[i])}): a crash, "
                                     "os._exit, or the system's out-of-memory killer")
                yield i, exc if exc is not None else f.result()
            for executor in self._alone:
                executor.shutdown(wait=True)
            self._alone = []

    def stop(self) -> None:
        """Cancel what has not started and end the workers now: a run in progress is lost either way,
        and waiting for it would keep Ctrl-C waiting for minutes."""
        self._stopped = True
        for executor in [self._executor, *self._alone]:
            processes = list(getattr(executor, "_processes", {}).values())  # no public handle before 3.14
            executor.shutdown(wait=False, cancel_futures=True)
            for p in processes:
                p.terminate()
            for p in processes:
                p.join(timeout=2)
                if p.is_alive():  # SIGTERM not acted on in time (a loaded machine): no second chance
                    p.kill()
                    p.join()

    def close(self) -> None:
        for executor in [self._executor, *self._alone]:  # a retry's too, should its caller have left mid-way
            executor.shutdown(wait=True, cancel_futures=True)


def _executor(workers: int) -> ProcessPoolExecutor:
    return ProcessPoolExecutor(workers, mp_context=_context(), initializer=_ignore_sigint)


def _ended(processes: list[Any]) -> str:
    """How a dead worker process ended: ``killed by SIGKILL``, ``exit code 9``."""
    for p in processes:
        p.join(timeout=2)
        code = p.exitcode
        if code is not None and code < 0:
            try:
                return f"killed by {signal.Signals(-code).name}"
            except ValueError:
                return f"killed by signal {-code}"
        if code is not None:
            return f"exit code {code}"
    return "how, unknown"


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
        self.name = f"Dask cluster {address} ({_workers(self._client)})"
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


def _workers(client: Any) -> str:
    """How many workers the scheduler has now, in words: with none the runs wait, and the command, whose
    progress line shows nothing until a run ends, would look hung."""
    try:
        threads = client.nthreads()
    except Exception:  # noqa: BLE001 - only a courtesy; a scheduler lost meanwhile is reported where runs are
        return "workers unknown"
    if not threads:
        return "no workers yet: the runs wait for one to join"
    total = sum(threads.values())
    return f"{len(threads)} worker{'s' if len(threads) != 1 else ''}, {total} thread{'s' if total != 1 else ''}"


def _why(exc: BaseException) -> str:
    """What Dask says of a future it cancelled (its reason, ``scheduler-connection-lost``, and message), or
    of a result it could not fetch, in one line."""
    reason = getattr(exc, "reason", None)
    said = " ".join(str(getattr(exc, "msg", None) or ("" if reason else exc)).split())
    return f"{reason or type(exc).__name__}{f' ({said})' if said else ''}"
