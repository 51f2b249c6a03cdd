"""Where the simulator's tasks run: this process, a local process pool, or a Dask cluster.

Every sequence has its own derived seed, so the work is independent tasks whose outputs
do not depend on where or in which order they run. :class:`TaskRunner` maps a module-level
function over picklable tasks and yields the results as they complete (or in the tasks'
order):

``serial``       in this process (``--workers 1``)
``processes``    a ``multiprocessing`` pool of N processes (``--workers N``; forked where
                 the platform can, so no start-up beyond the fork)
``dask-local``   a ``dask.distributed`` ``LocalCluster`` of N single-threaded worker
                 processes on the loopback (``--cluster local:N``)
``dask``         an existing Dask cluster, by its scheduler's address
                 (``--scheduler tcp://HOST:PORT``); its workers need wavealt installed and
                 the output location within reach
"""

from __future__ import annotations

import logging
import multiprocessing as mp
import re
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass
from typing import Any

from wavealt._checks import check_integer

#: Seconds to wait for a scheduler to answer, and then for it to have a worker.
CONNECT_TIMEOUT_S = 10.0
_SCHEDULER = re.compile(r"(tcp|tls)://(\[[0-9a-fA-F:]+\]|[A-Za-z0-9_.-]+):(\d{1,5})")


@dataclass(frozen=True)
class RunnerSpec:
    """Where tasks run: ``kind`` is ``serial``, ``processes``, ``dask-local`` or ``dask``;
    ``workers`` the process count (local kinds); ``address`` the scheduler's (``dask``)."""

    kind: str
    workers: int = 1
    address: str | None = None

    def describe(self) -> str:
        return {"serial": "this process", "processes": f"{self.workers} local processes",
                "dask-local": f"a Dask LocalCluster of {self.workers} workers",
                "dask": f"the Dask scheduler at {self.address}"}[self.kind]


def runner_spec(*, workers: int = 1, cluster: str | None = None,
                scheduler: str | None = None) -> RunnerSpec:
    """The runner of the command line's ``--workers N``, ``--cluster local:N`` or
    ``--scheduler tcp://HOST:PORT`` (at most one of them); a one-line ``ValueError`` naming
    the option when one is malformed."""
    workers = check_integer("workers", workers, low=1)
    if cluster is not None and scheduler is not None:
        msg = "give one of --cluster and --scheduler, not both"
        raise ValueError(msg)
    if (cluster is not None or scheduler is not None) and workers != 1:
        msg = ("--workers is the local process pool; with --cluster or --scheduler the "
               "cluster's workers run the sequences (drop --workers)")
        raise ValueError(msg)
    if cluster is not None:
        m = re.fullmatch(r"local:(\d+)", cluster.strip())
        if m is None or int(m.group(1)) < 1:
            msg = f"--cluster must be local:N with N >= 1 worker processes; got {cluster!r}"
            raise ValueError(msg)
        return RunnerSpec("dask-local", workers=int(m.group(1)))
    if scheduler is not None:
        m = _SCHEDULER.fullmatch(scheduler.strip())
        if m is None or not 0 < int(m.group(3)) < 65536:
            msg = f"--scheduler must be a Dask scheduler address tcp://HOST:PORT; got {scheduler!r}"
            raise ValueError(msg)
        return RunnerSpec("dask", address=scheduler.strip())
    return RunnerSpec("serial" if workers == 1 else "processes", workers=int(workers))


class TaskRunner:
    """A started runner (a context manager): the pool is started, the cluster started or
    connected to, on entry, before the caller writes anything, and closed on exit.

    A scheduler that does not answer, or has no worker, within :data:`CONNECT_TIMEOUT_S`
    is a one-line ``ValueError``.
    """

    def __init__(self, spec: RunnerSpec) -> None:
        self.spec = spec
        self._pool: Any = None
        self._client: Any = None
        self._cluster: Any = None

    def __enter__(self) -> TaskRunner:
        kind = self.spec.kind
        if kind == "processes":
            ctx = mp.get_context("fork" if "fork" in mp.get_all_start_methods() else "spawn")
            self._pool = ctx.Pool(self.spec.workers)
        elif kind in ("dask-local", "dask"):
            try:
                self._connect()
            except BaseException:
                self.__exit__(None, None, None)
                raise
        return self

    def _connect(self) -> None:
        # deferred: 0.5 s, only for a Dask run
        import dask
        from distributed import Client, LocalCluster

        if self.spec.kind == "dask-local":
            # Dask's nannies start workers with MALLOC_TRIM_THRESHOLD_=65536, which fixes
            # glibc's mmap threshold at 128 KiB: every frame-sized array is then mapped and
            # unmapped afresh, and the simulator runs 1.5 x slower (measured at 256 px);
            # the workers get glibc's adaptive default instead (docs/scale.md).
            with dask.config.set({"distributed.nanny.pre-spawn-environ.MALLOC_TRIM_THRESHOLD_": None}):
                self._cluster = LocalCluster(
                    n_workers=self.spec.workers, threads_per_worker=1, processes=True,
                    host="127.0.0.1", dashboard_address=None, silence_logs=logging.ERROR)
            self._client = Client(self._cluster)
            return
        addr = self.spec.address
        try:
            self._client = Client(addr, timeout=CONNECT_TIMEOUT_S)
        except (OSError, TimeoutError) as exc:
            first = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
            msg = f"--scheduler {addr}: no Dask scheduler answered within {CONNECT_TIMEOUT_S:g} s ({first})"
            raise ValueError(msg) from None
        try:
            self._client.wait_for_workers(1, timeout=CONNECT_TIMEOUT_S)
        except (OSError, TimeoutError):
            msg = (f"--scheduler {addr}: the scheduler has no workers (waited "
                   f"{CONNECT_TIMEOUT_S:g} s); start some with `dask worker {addr}`")
            raise ValueError(msg) from None

    def __exit__(self, *exc: object) -> None:
        if self._pool is not None:
            self._pool.terminate()
            self._pool.join()
            self._pool = None
        if self._client is not None:
            self._client.close()
            self._client = None
        if self._cluster is not None:
            self._cluster.close()
            self._cluster = None

    @property
    def workers(self) -> int:
        """Workers running the tasks now (a remote cluster's may change while it runs)."""
        if self._client is not None:
            return len(self._client.nthreads())
        return self.spec.workers

    def map(self, fn: Callable[[Any], Any], tasks: Iterable[Any]) -> Iterator[Any]:
        """``fn(task)`` for every task, yielded in the tasks' order (each as soon as it and
        those before it are done); otherwise as :meth:`map_unordered`."""
        return self._map(fn, tasks, ordered=True)

    def map_unordered(self, fn: Callable[[Any], Any], tasks: Iterable[Any]) -> Iterator[Any]:
        """``fn(task)`` for every task, yielded as each completes. ``fn`` must be a
        module-level function (it is pickled by name). The first task to fail raises its
        error here; the tasks not yet run are cancelled when the runner closes."""
        return self._map(fn, tasks, ordered=False)

    def _map(self, fn: Callable[[Any], Any], tasks: Iterable[Any],
             ordered: bool) -> Iterator[Any]:
        tasks = list(tasks)
        if not tasks:
            return
        if self._pool is not None:
            yield from (self._pool.imap if ordered else self._pool.imap_unordered)(fn, tasks)
        elif self._client is not None:
            from distributed import as_completed

            futures = self._client.map(fn, tasks, pure=False)
            try:
                for fut in futures if ordered else as_completed(futures):
                    yield fut.result()
            finally:
                self._client.cancel(futures)
        else:
            for t in tasks:
                yield fn(t)


__all__ = ["CONNECT_TIMEOUT_S", "RunnerSpec", "TaskRunner", "runner_spec"]
