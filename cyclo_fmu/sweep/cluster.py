"""Running work on dask.distributed: a local cluster by default, or an existing scheduler."""
from __future__ import annotations

import contextlib

from model_core import CycloidInputError


def require_dask():
    """Import dask.distributed or raise a one-line error naming the missing extra."""
    try:
        import distributed  # noqa: F401
    except ImportError:
        raise CycloidInputError("scheduler", "dask.distributed", "is not installed: "
                                "pip install 'cyclo-fmu[sweep]'") from None
    import distributed
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
    n = workers or max(1, min(os.cpu_count() or 1, 8))
    with distributed.LocalCluster(n_workers=n, threads_per_worker=1, processes=True,
                                  dashboard_address=None, silence_logs=40) as cluster, \
            distributed.Client(cluster) as c:
        yield c


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
