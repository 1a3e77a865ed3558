"""Where sweeps run: any `concurrent.futures.Executor`, by default a process pool on every core.

The harness only submits work through the standard executor interface, so a distributed executor
can be handed in instead. A pool the harness makes itself is stopped cleanly on Ctrl-C: its workers
ignore SIGINT (the parent reports one line), and the parent terminates them.
"""

from __future__ import annotations

import contextlib
import os
from collections.abc import Iterator
from concurrent.futures import Executor, ProcessPoolExecutor, ThreadPoolExecutor


def _ignore_sigint() -> None:
    import signal

    signal.signal(signal.SIGINT, signal.SIG_IGN)


@contextlib.contextmanager
def executor_for(executor: Executor | None, *, tasks: int | None = None) -> Iterator[Executor]:
    """`executor` as given, or (if None) a process pool with a worker per core (at most `tasks`),
    shut down on exit and terminated on Ctrl-C."""
    if executor is not None:
        yield executor
        return
    workers = min(tasks or os.cpu_count() or 1, os.cpu_count() or 1)
    pool: Executor = (
        ProcessPoolExecutor(max_workers=workers, initializer=_ignore_sigint)
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
