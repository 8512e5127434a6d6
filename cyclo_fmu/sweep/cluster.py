"""Running work on dask.distributed: a local cluster by default, or an existing scheduler."""
from __future__ import annotations

import contextlib

from model_core import CycloidInputError


def require_dask():
    """Import dask.distributed or raise a one-line error naming the missing extra."""
    try:
        import distributed
    except ImportError:
        raise CycloidInputError("scheduler", "dask.distributed", "is not installed: "
                                "pip install 'cyclo-fmu[sweep]'") from None
    return distributed


@contextlib.contextmanager
def client(scheduler: str = None, workers: int = None):
    """A dask Client: connected to ``scheduler`` (an address such as tcp://host:8786) or to a
    new LocalCluster of ``workers`` single-threaded processes (the model is numpy-bound and
    holds the GIL in Python loops, so processes, not threads)."""
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
    import os

    import dask
    n = workers or max(1, min(os.cpu_count() or 1, 8))
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
    ``cyclo_fmu.slaves.heap`` (4 MiB, the FMU's setting while it solves its map) keeps those
    arrays on the heap: the task takes 0.35 s in a worker too (benchmarks/bench_sweep.py).
    Workers of an existing scheduler (``--scheduler``) are started by their owner: the same
    variable belongs in their environment.
    """
    import dask

    from ..slaves.heap import MMAP_THRESHOLD, TRIM_THRESHOLD
    env = dict(dask.config.get("distributed.nanny.pre-spawn-environ", {}) or {})
    env.update(MALLOC_MMAP_THRESHOLD_=MMAP_THRESHOLD, MALLOC_TRIM_THRESHOLD_=TRIM_THRESHOLD)
    return env


def run_tasks(fn, items, *, scheduler=None, workers=None, progress=True, desc="tasks",
              serial=False):
    """Results of ``fn(item)`` for every item, in the order of ``items``; on dask unless
    ``serial``. A progress bar (tqdm) on stderr when ``progress``."""
    from tqdm import tqdm
    items = list(items)
    bar = tqdm(total=len(items), desc=desc, disable=not progress, unit="task")
    try:
        if serial:
            out = []
            for it in items:
                out.append(fn(it))
                bar.update()
            return out
        distributed = require_dask()
        with client(scheduler, workers) as c:
            futures = c.map(fn, items, pure=False)
            index = {f.key: i for i, f in enumerate(futures)}
            out = [None] * len(items)
            for fut in distributed.as_completed(futures):
                out[index[fut.key]] = fut.result()
                bar.update()
            return out
    finally:
        bar.close()
