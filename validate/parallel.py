"""Where sweeps run: any `concurrent.futures.Executor`, by default a process pool on every core.

The harness only submits work through the standard executor interface, so a distributed executor
can be handed in instead. A pool the harness makes itself is stopped cleanly on Ctrl-C and SIGTERM:
its workers ignore SIGINT and take SIGTERM's default action (the parent reports one line and
terminates them), and on Linux they are killed when the parent dies (PR_SET_PDEATHSIG), so a parent
killed outright leaves no worker waiting for work that never comes.
"""

from __future__ import annotations

import contextlib
import os
from collections.abc import Iterator
from concurrent.futures import Executor, ProcessPoolExecutor, ThreadPoolExecutor


def _worker_init(parent: int) -> None:
    """Runs in each pool worker: the parent handles Ctrl-C; SIGTERM ends the worker (a forked worker
    would otherwise inherit the CLI's handler); the worker dies with the parent."""
    import signal
    import sys

    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    if sys.platform.startswith("linux"):
        import ctypes

        pr_set_pdeathsig = 1
        ctypes.CDLL(None, use_errno=True).prctl(pr_set_pdeathsig, signal.SIGKILL)
    if os.getppid() != parent:  # the parent died before the line above took effect
        os._exit(1)


@contextlib.contextmanager
def executor_for(executor: Executor | None, *, tasks: int | None = None) -> Iterator[Executor]:
    """`executor` as given, or (if None) a process pool with a worker per core (at most `tasks`),
    shut down on exit and terminated on Ctrl-C."""
    if executor is not None:
        yield executor
        return
    workers = min(tasks or os.cpu_count() or 1, os.cpu_count() or 1)
    pool: Executor = (
        ProcessPoolExecutor(max_workers=workers, initializer=_worker_init, initargs=(os.getpid(),))
        if workers > 1
        else ThreadPoolExecutor(max_workers=1)
    )
    try:
        yield pool
    except KeyboardInterrupt:
        import multiprocessing

        for child in multiprocessing.active_children():
            child.terminate()
        raise
    finally:
        pool.shutdown(wait=True, cancel_futures=True)
