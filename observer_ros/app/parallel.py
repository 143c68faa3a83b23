# Copyright 2026 observer_ros contributors
#
# Licensed under the Apache License, Version 2.0 (the "License");
# you may not use this file except in compliance with the License.
# You may obtain a copy of the License at
#
#     http://www.apache.org/licenses/LICENSE-2.0
#
# Unless required by applicable law or agreed to in writing, software
# distributed under the License is distributed on an "AS IS" BASIS,
# WITHOUT WARRANTIES OR CONDITIONS OF ANY KIND, either express or implied.
# See the License for the specific language governing permissions and
# limitations under the License.

"""
Run one task per bag: in this process, in local worker processes, or on a Dask cluster.

:func:`task_mapper` returns a ``mapper(function, tasks, label)`` that gives
``function(task)`` of every task, in the order of ``tasks`` whatever order they finish in,
with a progress bar on a terminal (:class:`Progress`). The bag tools hand it their per-bag
task; ``function`` must be importable at module level (worker processes and Dask workers
import it by name).

* one task, or ``workers=1``: in this process;
* otherwise local worker processes (``concurrent.futures``, ``forkserver`` start: nothing
  of this process's threads is copied);
* ``scheduler='tcp://host:port'``: the tasks go to an existing Dask cluster
  (``distributed.Client``); its workers need observer_ros installed.
"""

from concurrent.futures import as_completed, BrokenExecutor, ProcessPoolExecutor
import contextlib
import multiprocessing
import os
import sys
import time
from typing import Callable, Optional, Sequence, TextIO

#: Seconds a Dask client waits for the scheduler before giving up.
CONNECT_TIMEOUT = 10.0


def single_threaded_blas():
    """
    Return a context in which numpy's BLAS and LAPACK use one thread (threadpoolctl).

    The bag tools run one worker per core; BLAS threads on top of that only compete for the
    same cores (a QR of a tall matrix ran 20 times slower on a loaded two-core machine).
    Without threadpoolctl the context changes nothing.
    """
    try:
        from threadpoolctl import threadpool_limits
    except ImportError:
        return contextlib.nullcontext()
    return threadpool_limits(limits=1)


def _limited(function: Callable, task):
    """Run one task with single-threaded BLAS (in a worker process)."""
    with single_threaded_blas():
        return function(task)


class Progress:
    """
    A one-line progress bar on a terminal, nothing elsewhere.

    Parameters
    ----------
    total : int
    label : str
    stream : file, optional
        Where to draw (default ``sys.stderr``); drawn only when it is a TTY, or ``force``.

    """

    WIDTH = 30

    def __init__(self, total: int, label: str, stream: Optional[TextIO] = None,
                 force: bool = False) -> None:
        self.total = max(int(total), 1)
        self.label = label
        self.stream = sys.stderr if stream is None else stream
        self.shown = force or bool(getattr(self.stream, 'isatty', lambda: False)())
        self.done = 0
        self.started = time.monotonic()
        self._draw()

    def advance(self, count: int = 1) -> None:
        """Count ``count`` more tasks done."""
        self.done += count
        self._draw()

    def _draw(self) -> None:
        if not self.shown:
            return
        filled = round(self.WIDTH * self.done / self.total)
        elapsed = time.monotonic() - self.started
        self.stream.write(f'\r{self.label} [{"#" * filled}{"." * (self.WIDTH - filled)}] '
                          f'{self.done}/{self.total} {elapsed:.1f} s')
        self.stream.flush()

    def close(self) -> None:
        """End the line."""
        if self.shown:
            self.stream.write('\n')
            self.stream.flush()


def add_worker_arguments(parser, verb: str = 'run') -> None:
    """Add ``--workers`` and ``--dask`` to a bag tool's argument parser."""
    parser.add_argument('--workers', type=int, default=None,
                        help='local worker processes (default: one per bag, at most one per '
                        'core; 1: in this process)')
    parser.add_argument('--dask', metavar='SCHEDULER_ADDRESS',
                        help=f'{verb} the bags on an existing Dask cluster')


def default_workers(tasks: int) -> int:
    """One worker per task, at most one per core."""
    return max(1, min(int(tasks), os.cpu_count() or 1))


class TaskMapper:
    """
    ``mapper(function, tasks, label) -> list``: the tasks run as configured, in task order.

    Use it as a context manager (or call :meth:`close`): local worker processes are started
    once, on the first call that needs them, and kept for the calls after it (a tuning
    replays the bags several times).
    """

    def __init__(self, workers: Optional[int] = None, scheduler: Optional[str] = None,
                 stream: Optional[TextIO] = None) -> None:
        if workers is not None and workers < 1:
            raise ValueError(f'--workers: expected at least 1, got {workers}')
        self.workers = workers
        self.scheduler = scheduler
        self.stream = stream
        self._pool: Optional[ProcessPoolExecutor] = None
        self._client = None

    def _dask_client(self):
        if self._client is None:
            self._client = _connect(self.scheduler)
        return self._client

    def __call__(self, function: Callable, tasks: Sequence, label: str = 'bags') -> list:
        """Return ``function(task)`` of every task, in the order of ``tasks``."""
        tasks = list(tasks)
        progress = Progress(len(tasks), label, self.stream)
        try:
            if self.scheduler is not None:
                return _on_dask(self._dask_client(), function, tasks, progress)
            count = (default_workers(len(tasks)) if self.workers is None
                     else min(self.workers, len(tasks)))
            if count <= 1:
                results = []
                for task in tasks:
                    results.append(function(task))
                    progress.advance()
                return results
            return self._in_processes(function, tasks, progress)
        finally:
            progress.close()

    def _executor(self, function: Callable) -> ProcessPoolExecutor:
        if self._pool is None:
            context = multiprocessing.get_context('forkserver')
            # Workers fork from a server that has imported the task's module already.
            context.set_forkserver_preload([function.__module__])
            count = self.workers or os.cpu_count() or 1
            self._pool = ProcessPoolExecutor(max_workers=count, mp_context=context)
        return self._pool

    def _in_processes(self, function: Callable, tasks: list, progress: Progress) -> list:
        pool = self._executor(function)
        results: list = [None] * len(tasks)
        futures = {pool.submit(_limited, function, task): index
                   for index, task in enumerate(tasks)}
        try:
            for future in as_completed(futures):
                results[futures[future]] = future.result()
                progress.advance()
        except BrokenExecutor as e:
            self.close()
            raise ValueError(f'--workers: a worker process died ({e}); run with --workers 1 '
                             f'to see why') from e
        except BaseException:
            for future in futures:
                future.cancel()
            raise
        return results

    def close(self) -> None:
        """Stop the worker processes, if any were started."""
        if self._pool is not None:
            self._pool.shutdown(cancel_futures=True)
            self._pool = None
        if self._client is not None:
            self._client.close()
            self._client = None

    def __enter__(self) -> 'TaskMapper':
        """Return the mapper; :meth:`close` it on leaving."""
        return self

    def __exit__(self, *exc) -> None:
        """Stop the workers."""
        self.close()


def task_mapper(workers: Optional[int] = None, scheduler: Optional[str] = None,
                stream: Optional[TextIO] = None) -> TaskMapper:
    """
    Return a :class:`TaskMapper` running tasks as configured.

    Parameters
    ----------
    workers : int, optional
        Local worker processes (default: one per task, at most one per core); 1 runs in
        this process. Ignored with ``scheduler``.
    scheduler : str, optional
        Address of a Dask scheduler (``tcp://127.0.0.1:8786``).
    stream : file, optional
        Where the progress bar goes (default ``sys.stderr``, only on a terminal).

    Raises
    ------
    ValueError
        ``workers`` below 1.

    """
    return TaskMapper(workers, scheduler, stream)


def _connect(address: str):
    """Return a Dask client of the scheduler at ``address``."""
    try:
        from distributed import Client
    except ImportError as e:
        raise ValueError('--dask: the distributed package is not installed') from e
    try:
        return Client(address, timeout=CONNECT_TIMEOUT, set_as_default=False)
    except (OSError, TimeoutError) as e:
        raise ValueError(f'--dask: cannot reach the scheduler at {address} ({e})') from e


def _on_dask(client, function: Callable, tasks: list, progress: Progress) -> list:
    from distributed import as_completed as dask_completed
    futures = client.map(function, tasks, pure=False)
    index = {future.key: position for position, future in enumerate(futures)}
    results: list = [None] * len(tasks)
    for future in dask_completed(futures, loop=client.loop):
        results[index[future.key]] = future.result()
        progress.advance()
    return results


__all__ = ['Progress', 'TaskMapper', 'add_worker_arguments', 'default_workers',
           'single_threaded_blas', 'task_mapper']
