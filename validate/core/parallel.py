"""Where sweeps run: any `concurrent.futures.Executor`, by default a process pool on every core.

The harness only submits work through the standard executor interface, so a distributed executor
can be handed in instead: `named_executor("dask")` is a dask.distributed `LocalCluster` on this
machine (one single-threaded worker process per core, so each run is timed alone on its core as in
the local pool), `named_executor("dask:tcp://HOST:8786")` a running scheduler's cluster; both give
`Client.get_executor(pure=False)` (pure=False: a repeat of the same run is run again, not served
from dask's cache of results). The command line's `--executor local|dask[:ADDRESS]` names them.

`run`'s pool (`executor_for(..., isolated=True)`) runs each task in a process of its own
(`OnePerTask`): a task that ends its process (an equations module calling os._exit) fails its own
future alone, where in one shared pool every task still running would fail with it. A pool the
harness makes itself is stopped cleanly on Ctrl-C and SIGTERM:
its workers ignore SIGINT and take SIGTERM's default action (the parent reports one line and
terminates them), and on Linux they are killed when the parent dies (PR_SET_PDEATHSIG), so a parent
killed outright leaves no worker waiting for work that never comes.
"""

from __future__ import annotations

import contextlib
import functools
import os
import queue
import re
import threading
from collections import deque
from collections.abc import Callable, Iterable, Iterator
from concurrent.futures import CancelledError, Executor, Future, ProcessPoolExecutor, ThreadPoolExecutor
from typing import Any, ParamSpec, TypeVar

from .errors import HarnessError

EXECUTOR_KINDS = ("local", "dask")
T = TypeVar("T")
P = ParamSpec("P")


def completed(futures: Iterable[Future[T]]) -> Iterator[Future[T]]:
    """The futures as each finishes (as `concurrent.futures.as_completed`), waited for through their
    done callbacks and a C queue. CPython 3.11's `as_completed` takes every future's lock in a loop
    that Ctrl-C can interrupt midway: a lock left held then blocks the pool's manager thread, which
    the interpreter joins at exit, for ever (a run interrupted just as it started hung)."""
    finished: queue.SimpleQueue[Future[T]] = queue.SimpleQueue()
    pending = list(futures)
    for future in pending:
        future.add_done_callback(finished.put)
    for _ in pending:
        yield finished.get()


def parent_death_signal() -> Callable[[], None] | None:
    """The call that has a process killed when the thread that started it ends (Linux's
    PR_SET_PDEATHSIG), looked up here so that a child between fork and exec only calls it; None off
    Linux."""
    import signal
    import sys

    if not sys.platform.startswith("linux"):
        return None
    import ctypes

    prctl = ctypes.CDLL(None, use_errno=True).prctl
    pr_set_pdeathsig = 1
    return lambda: prctl(pr_set_pdeathsig, signal.SIGKILL)


def _worker_init(parent: int) -> None:
    """Runs in each pool worker: the parent handles Ctrl-C; SIGTERM ends the worker (a forked worker
    would otherwise inherit the CLI's handler); the worker dies with the parent."""
    import signal

    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    die = parent_death_signal()
    if die is not None:
        die()
    if os.getppid() != parent:  # the parent died before the line above took effect
        os._exit(1)


MANAGER_JOIN_S = 30.0  # at most this long for a pool's manager thread at shutdown (they end in milliseconds)


class OnePerTask(Executor):
    """Each task in a one-worker process pool of its own, at most `workers` at once: a task whose
    process dies (os._exit, a crash) breaks only its own pool, so its future alone fails
    (BrokenProcessPool) and the others' results are kept. The next task starts as one finishes.

    Every pool is made, and so every worker forked, by one launcher thread that lives as long as the
    executor: PR_SET_PDEATHSIG kills a worker when the *thread* that forked it ends, so a worker
    forked by the finished pool's thread (where its result arrives) would die with it."""

    def __init__(self, workers: int) -> None:
        self._workers = workers
        self._ready = threading.Condition()
        self._pending: deque[tuple[Future[Any], Callable[..., Any], tuple[Any, ...], dict[str, Any]]] = deque()
        self._pools: set[ProcessPoolExecutor] = set()
        self._managers: list[threading.Thread | None] = []  # every pool's manager thread, joined at shutdown
        self._closed = False
        self._launcher = threading.Thread(target=self._launch, name="OnePerTask launcher", daemon=True)
        self._launcher.start()

    def submit(self, fn: Callable[P, T], /, *args: P.args, **kwargs: P.kwargs) -> Future[T]:
        outer: Future[T] = Future()
        with self._ready:
            if self._closed:
                raise RuntimeError("cannot schedule new futures after shutdown")
            self._pending.append((outer, fn, args, kwargs))
            self._ready.notify_all()
            # Where a worker is free, return once its process exists (as a pool's submit does).
            self._ready.wait_for(
                lambda: self._closed or outer.running() or outer.done() or len(self._pools) >= self._workers
            )
        return outer

    def _launch(self) -> None:
        """The launcher: a pool for the next pending task whenever one is free, until shutdown."""
        while True:
            with self._ready:
                self._ready.wait_for(lambda: self._closed or (self._pending and len(self._pools) < self._workers))
                if self._closed:
                    return
                outer, fn, args, kwargs = self._pending.popleft()
                if not outer.set_running_or_notify_cancel():
                    continue
                pool = ProcessPoolExecutor(max_workers=1, initializer=_worker_init, initargs=(os.getpid(),))
                self._pools.add(pool)
                inner = pool.submit(fn, *args, **kwargs)  # forks here, in this thread
                self._managers.append(getattr(pool, "_executor_manager_thread", None))
                self._ready.notify_all()
            inner.add_done_callback(functools.partial(self._finished, outer, pool))

    def _finished(self, outer: Future[object], pool: ProcessPoolExecutor, inner: Future[object]) -> None:
        if inner.cancelled():  # at shutdown; the outer future is running, so it cannot be cancelled itself
            outer.set_exception(CancelledError())
        elif inner.exception() is not None:
            outer.set_exception(inner.exception())
        else:
            outer.set_result(inner.result())
        pool.shutdown(wait=False)
        with self._ready:
            self._pools.discard(pool)
            self._ready.notify_all()

    def shutdown(self, wait: bool = True, *, cancel_futures: bool = False) -> None:
        """Pending tasks cancelled (`cancel_futures`) or left to run; the pools shut down, then the
        launcher stopped (its workers die with it)."""
        if wait and not cancel_futures:
            with self._ready:
                self._ready.wait_for(lambda: not self._pending and not self._pools)
        with self._ready:
            pending = list(self._pending)
            self._pending.clear()
            self._closed = True
            pools = list(self._pools)
            self._ready.notify_all()
        for outer, *_ in pending:
            outer.cancel()
        for pool in pools:
            pool.shutdown(wait=wait, cancel_futures=cancel_futures)
        if wait:
            self._launcher.join()
            self._join_managers()

    def _join_managers(self) -> None:
        """Waits for every pool's manager thread, finished pools' too: one still closing its wake-up
        pipe when the interpreter exits races CPython 3.11's exit hook, which writes to that pipe
        ("Exception ignored in threading ... Bad file descriptor" after the command's last line).
        `shutdown(wait=False)` forgets the thread, so it is kept here from the pool's first submit."""
        with self._ready:
            managers, self._managers = self._managers, []
        for manager in managers:
            if manager is not None and manager is not threading.current_thread():
                manager.join(timeout=MANAGER_JOIN_S)


@contextlib.contextmanager
def executor_for(executor: Executor | None, *, tasks: int | None = None, isolated: bool = False) -> Iterator[Executor]:
    """`executor` as given, or (if None) a process pool with a worker per core (at most `tasks`; one
    task: a thread), shut down on exit and terminated on Ctrl-C. `isolated`: a process per task
    (`OnePerTask`), one task included, so that a task ending its process fails alone and the main
    thread only waits (Ctrl-C and SIGTERM stop it whatever the task is doing)."""
    if executor is not None:
        yield executor
        return
    workers = min(tasks or os.cpu_count() or 1, os.cpu_count() or 1)
    pool: Executor
    if isolated:
        pool = OnePerTask(workers)
    elif workers > 1:
        pool = ProcessPoolExecutor(max_workers=workers, initializer=_worker_init, initargs=(os.getpid(),))
    else:
        pool = ThreadPoolExecutor(max_workers=1)
    try:
        yield pool
    except KeyboardInterrupt:
        import multiprocessing

        pool.shutdown(wait=False, cancel_futures=True)  # no task starts from here on
        for child in multiprocessing.active_children():
            child.terminate()
        raise
    finally:
        pool.shutdown(wait=True, cancel_futures=True)


def parse_executor(text: str) -> tuple[str, str | None]:
    """`local`, `dask` or `dask:ADDRESS` as (kind, address or None); anything else is a HarnessError."""
    kind, sep, address = text.strip().partition(":")
    if kind not in EXECUTOR_KINDS or (kind == "local" and sep) or (sep and not address.strip()):
        raise HarnessError(
            f"unknown executor '{text}'; valid: local, dask (a LocalCluster on this machine) or "
            "dask:ADDRESS (a running scheduler, e.g. dask:tcp://10.0.0.5:8786)."
        )
    address = address.strip()
    if address and not _valid_address(address):
        raise HarnessError(
            f"'{address}' is not a dask scheduler address; valid: [PROTOCOL://]HOST:PORT with "
            f"PROTOCOL one of {', '.join(PROTOCOLS)} and PORT from 1 to 65535 (e.g. dask:tcp://10.0.0.5:8786)."
        )
    return kind, address or None


PROTOCOLS = ("tcp", "tls", "ws", "wss", "ucx")
_ADDRESS = re.compile(r"(?:([a-z]+)://)?(\[[0-9A-Fa-f:.]+\]|[A-Za-z0-9._-]+):([0-9]{1,5})")


def _valid_address(address: str) -> bool:
    """Whether `address` is a dask scheduler address, checked before any connection is tried."""
    if address.startswith("inproc://") and len(address) > len("inproc://"):  # a cluster in this process
        return True
    match = _ADDRESS.fullmatch(address)
    return match is not None and match[1] in (None, *PROTOCOLS) and 1 <= int(match[3]) <= 65535


@contextlib.contextmanager
def named_executor(
    text: str | None, *, workers: int | None = None, processes: bool = True
) -> Iterator[Executor | None]:
    """The executor `text` names (see `parse_executor`), closed on exit: None for "local" (the callers
    then make their own process pool), else a dask.distributed client's executor, on a new LocalCluster
    of `workers` single-threaded workers (default: one per core; `processes=False` keeps them as
    threads of this process) or on the scheduler at ADDRESS."""
    kind, address = parse_executor(text or "local")
    if kind == "local":
        yield None
        return
    try:
        from distributed import Client, LocalCluster
    except ImportError:
        raise HarnessError(
            "--executor dask needs dask.distributed, which is not installed: "
            "pip install 'lagrange-xval[dask]' (or the pinned dask and distributed of requirements.lock)."
        ) from None
    cluster = None
    if address is None:
        loopback = {"host": "127.0.0.1"} if processes else {}  # threads talk in-process, not over TCP
        cluster = LocalCluster(
            n_workers=workers or os.cpu_count() or 1,
            threads_per_worker=1,
            processes=processes,
            dashboard_address="127.0.0.1:0",  # its HTTP server on loopback, any free port
            **loopback,
        )
        client = Client(cluster)
    else:
        try:
            client = Client(address, timeout=30)
        except (OSError, TimeoutError) as exc:
            raise HarnessError(f"cannot reach the dask scheduler at {address}: {exc}") from None
    try:
        yield client.get_executor(pure=False)
    finally:
        client.close()
        if cluster is not None:
            cluster.close()
