"""Where the work of a sweep or a batch runs: in this process, in a local process pool, or on
dask.distributed.

- below a cut-off (:func:`choose_backend`) the work runs in this process (``serial``): a
  pool's start-up would cost more than it saves;
- above it, a local pool of forked worker processes (``pool``, ``concurrent.futures``): a
  forked worker inherits the imported modules and the allocator settings of this process, so
  it starts in ~20 ms against ~1.2 s wall and ~1.8 s CPU for a 2-worker dask LocalCluster
  (nannies, workers, scheduler; issue 21);
- ``--scheduler ADDRESS`` sends the tasks to a running dask.distributed scheduler (``dask``),
  for real clusters.

All three run the same function on the same items and hand the results back in the order of
the items (:func:`stream_tasks`), so their tables are identical, and they keep only a bounded
number of tasks in flight: what the caller does not keep (it streams the results to disk) is
not held in memory, whatever the number of items.
"""
from __future__ import annotations

import collections
import contextlib
import math
import multiprocessing
import os
import signal
import sys

from model_core import CycloidInputError

BACKENDS = ("serial", "pool", "dask")

#: Wall time [s] to start a local pool of forked workers and get a first trivial result back,
#: measured on the 2-core machine of issue 21 (benchmarks/bench_sweep.py prints it in every
#: run: 10-40 ms for 2 workers, more under load); the cut-off uses this upper value.
POOL_START_S = 0.05
#: The same for a pool of spawned workers (platforms without fork, macOS): a new interpreter
#: imports numpy, scipy and model_core before its first task, ~0.5 s (same benchmark).
SPAWN_START_S = 0.5
#: [1] the pool is used only when it is expected to save this many times its start-up: its
#: speed-up is below the ideal w on a loaded machine, and near the cut-off serial costs at
#: most POOL_SAFETY x the start-up more than a perfect choice would.
POOL_SAFETY = 2.0
#: [1] tasks per worker: with 4 waves the last, unequal wave idles a worker for at most about
#: 1/4 of its share; more tasks only add per-task overhead (pickling the spec, ~1 ms).
TASKS_PER_WORKER = 4
#: [s] longest task aimed for: a progress bar that moves, a bounded result per task in flight.
TASK_MAX_S = 2.0
#: [1] tasks in flight per worker: one running, one queued so a worker never waits for the
#: parent; results beyond them are not held.
IN_FLIGHT_PER_WORKER = 2
#: [1] largest local pool by default (a pool above the core count only adds memory)
MAX_DEFAULT_WORKERS = 8


def require_dask():
    """Import dask.distributed or raise a one-line error naming the missing extra."""
    try:
        import distributed
    except ImportError:
        raise CycloidInputError("scheduler", "dask.distributed", "is not installed: "
                                "pip install 'cyclo-fmu[sweep]'") from None
    return distributed


def cpu_count() -> int:
    """CPUs this process may run on (its affinity, not the machine's count)."""
    try:
        return len(os.sched_getaffinity(0))
    except (AttributeError, OSError):
        return os.cpu_count() or 1


def default_workers() -> int:
    return max(1, min(cpu_count(), MAX_DEFAULT_WORKERS))


def start_method() -> str:
    """``fork`` where it is safe and cheap (Linux and other POSIX but macOS), else ``spawn``."""
    if sys.platform != "darwin" and "fork" in multiprocessing.get_all_start_methods():
        return "fork"
    return "spawn"


def pool_start_s() -> float:
    """The measured start-up [s] of the local pool this platform uses."""
    return POOL_START_S if start_method() == "fork" else SPAWN_START_S


def serial_cutoff_s(workers: int) -> float:
    """Serial work [s] below which a local run stays in this process.

    With w workers the pool takes about ``T_start + W / w`` for serial work W, so it is faster
    when ``W (1 - 1/w) > T_start``; the cut-off asks for POOL_SAFETY times that:
    ``POOL_SAFETY * T_start * w / (w - 1)`` (0.2 s for 2 forked workers: 10-20 designs of the
    8 x 8 envelope in two modes)."""
    if workers < 2:
        return math.inf
    return POOL_SAFETY * pool_start_s() * workers / (workers - 1)


def choose_backend(n_items: int, seconds_per_item: float, *, workers: int = None,
                   scheduler: str = None, serial: bool = False) -> str:
    """``serial``, ``pool`` or ``dask`` for ``n_items`` of about ``seconds_per_item`` each
    (measured serially): dask when a scheduler is given, serial when asked or when the
    estimated serial work is below :func:`serial_cutoff_s`, else the local pool."""
    if scheduler:
        return "dask"
    if serial:
        return "serial"
    w = min(workers or default_workers(), max(1, n_items))
    if n_items * seconds_per_item < serial_cutoff_s(w):
        return "serial"
    return "pool"


def task_size(n_items: int, seconds_per_item: float, workers: int) -> int:
    """Items per task: about TASKS_PER_WORKER tasks per worker, none longer than TASK_MAX_S
    (at least one item)."""
    size = math.ceil(n_items / (max(1, workers) * TASKS_PER_WORKER))
    if seconds_per_item > 0:
        size = min(size, max(1, int(TASK_MAX_S / seconds_per_item)))
    return max(1, size)


@contextlib.contextmanager
def client(scheduler: str = None, workers: int = None):
    """A dask Client: connected to ``scheduler`` (an address such as tcp://host:8786) or to a
    new LocalCluster of ``workers`` single-threaded processes (the model is numpy-bound and
    holds the GIL in Python loops, so processes, not threads). The commands use dask only with
    a scheduler; the local default is the process pool (:func:`stream_tasks`)."""
    distributed = require_dask()
    if workers is not None and not 1 <= workers <= 1024:
        raise CycloidInputError("workers", workers, "must be from 1 to 1024")
    if scheduler:
        try:
            c = distributed.Client(scheduler, timeout="10s")
        except (OSError, TimeoutError, ValueError) as exc:
            raise CycloidInputError("scheduler", scheduler, f"cannot connect ({exc})") from None
        try:
            yield c
        finally:
            c.close()
        return
    import dask
    n = workers or default_workers()
    with dask.config.set(local_cluster_config()), \
            distributed.LocalCluster(n_workers=n, threads_per_worker=1, processes=True,
                                     dashboard_address=None, silence_logs=40) as cluster, \
            distributed.Client(cluster) as c:
        yield c


def local_cluster_config() -> dict:
    """dask settings of the LocalCluster ``client`` starts: the workers' environment
    (``worker_environ``) and no statistical profiler in the workers (it samples every worker
    thread's stack each 10 ms for the dashboard, which this cluster does not open; measured
    3-5 % of a task)."""
    return {"distributed.nanny.pre-spawn-environ": worker_environ(),
            "distributed.worker.profile.enabled": False}


def worker_environ() -> dict:
    """The environment of a LocalCluster's worker processes: dask's own
    (``distributed.nanny.pre-spawn-environ``) plus ``MALLOC_MMAP_THRESHOLD_``.

    dask sets ``MALLOC_TRIM_THRESHOLD_`` = 64 KiB in its workers so that they hand freed memory
    back to the kernel. Setting any of glibc's malloc thresholds also switches off its dynamic
    mmap threshold, which in a plain process rises to the size of the large arrays freed; in the
    workers it stays at 128 kB, so every temporary array of the loss model above it (a map's are
    0.1-1.4 MB) is mapped fresh from the kernel and page-faulted in again. A worker then took
    0.42-0.45 s for a task of 25 designs that takes 0.35 s in a plain process, which held a
    2-worker LocalCluster on 2 idle cores at 1.2-1.6x the serial speed. The threshold of
    ``cyclo_fmu.slaves.heap`` (32 MiB; 4 MiB when this was measured) keeps those
    arrays on the heap: the task takes 0.35 s in a worker too (benchmarks/bench_sweep.py).
    Workers of an existing scheduler (``--scheduler``) are started by their owner: the same
    variable belongs in their environment. (The local pool's forked workers inherit the
    settings of the ``cyclo-fmu`` process itself.)
    """
    import dask

    from ..slaves.heap import MMAP_THRESHOLD, TRIM_THRESHOLD
    env = dict(dask.config.get("distributed.nanny.pre-spawn-environ", {}) or {})
    env.update(MALLOC_MMAP_THRESHOLD_=MMAP_THRESHOLD, MALLOC_TRIM_THRESHOLD_=TRIM_THRESHOLD)
    return env


_FN = None      # the task function of a pool worker (set once per worker, not per task)


def _pool_init(fn):
    global _FN
    _FN = fn
    # Ctrl-C reaches the whole process group: the parent says "interrupted" and ends the
    # workers; they must not each print a KeyboardInterrupt traceback
    signal.signal(signal.SIGINT, signal.SIG_IGN)


def _pool_call(item):
    return _FN(item)


class _Pool:
    """A local process pool running ``fn`` (given once, at the workers' start)."""

    def __init__(self, fn, workers):
        from concurrent.futures import ProcessPoolExecutor
        self.ex = ProcessPoolExecutor(workers, mp_context=multiprocessing.get_context(
            start_method()), initializer=_pool_init, initargs=(fn,))

    def submit(self, item):
        return self.ex.submit(_pool_call, item)

    def close(self, ok):
        if not ok:      # interrupted or failed: end the workers now, not after their tasks
            for p in list(getattr(self.ex, "_processes", {}).values()):
                with contextlib.suppress(Exception):
                    p.terminate()
        self.ex.shutdown(wait=True, cancel_futures=True)


class _Dask:
    def __init__(self, fn, scheduler, workers):
        self.fn = fn
        self._cm = client(scheduler, workers)
        self.c = self._cm.__enter__()

    def submit(self, item):
        return self.c.submit(self.fn, item, pure=False)

    def close(self, ok):
        self._cm.__exit__(None, None, None)


def stream_tasks(fn, items, *, backend="serial", workers=None, scheduler=None, progress=True,
                 desc="tasks", total=None):
    """Yield ``fn(item)`` for every item of the iterable ``items``, in the order of the items,
    on ``backend`` (``serial``, ``pool`` or ``dask``). At most IN_FLIGHT_PER_WORKER tasks per
    worker are submitted and not yet yielded; ``items`` is consumed as they finish. A progress
    bar (tqdm, on stderr, ``total`` tasks) when ``progress``."""
    from tqdm import tqdm
    if backend not in BACKENDS:
        raise ValueError(f"backend {backend!r}")
    if backend == "serial":
        with tqdm(total=total, desc=desc, disable=not progress, unit="task") as bar:
            for it in items:
                yield fn(it)
                bar.update()
        return
    w = workers or default_workers()
    runner = _Pool(fn, w) if backend == "pool" else _Dask(fn, scheduler, workers)
    ok = False
    bar = None
    try:
        if backend == "dask":
            w = len(runner.c.scheduler_info().get("workers", {})) or w
        limit = IN_FLIGHT_PER_WORKER * w
        pending = collections.deque()
        it = iter(items)
        for item in it:
            pending.append(runner.submit(item))
            if len(pending) >= limit:
                break
        # (the pool forks its workers at the first submit, before this process starts a
        # thread of its own: tqdm's monitor)
        bar = tqdm(total=total, desc=desc, disable=not progress, unit="task")
        while pending:
            res = pending.popleft().result()
            for item in it:
                pending.append(runner.submit(item))
                break
            yield res
            bar.update()
        ok = True
    finally:
        runner.close(ok)
        if bar is not None:
            bar.close()


def run_tasks(fn, items, *, scheduler=None, workers=None, progress=True, desc="tasks",
              serial=False, backend=None):
    """Results of ``fn(item)`` for every item, in the order of ``items`` (a list): on the
    given backend, else dask with a scheduler, serial when asked, a local pool otherwise."""
    items = list(items)
    if backend is None:
        backend = "dask" if scheduler else "serial" if serial or len(items) < 2 else "pool"
    return list(stream_tasks(fn, items, backend=backend, workers=workers, scheduler=scheduler,
                             progress=progress, desc=desc, total=len(items)))
