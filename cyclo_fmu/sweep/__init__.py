"""Design studies and batch diagnosis: in this process, a local process pool, or on
dask.distributed (optional extra ``sweep``, for ``--scheduler``).

- :func:`write_sweep`: many designs (grid, Latin hypercube, table) x modes over an envelope,
  one row per design x mode (see :mod:`cyclo_fmu.sweep.evaluate`), streamed to a partitioned
  Parquet dataset as the results arrive; :func:`run_sweep`: the same as a pandas DataFrame;
- :func:`diagnose_batch`: every recording in a folder, one result folder each plus a summary.

Where the work runs is chosen by :func:`cyclo_fmu.sweep.cluster.choose_backend` from the
serial cost of the first designs, measured in this process (:data:`PROBE_DESIGNS`).
"""
from __future__ import annotations

import contextlib
import dataclasses
import itertools
import os
import shutil
import time
from functools import partial
from pathlib import Path

from .evaluate import (evaluate_chunk, evaluate_design, result_schema,  # noqa: F401
                       stiffness_columns, stiffness_hook)
from .spec import SweepSpec, load_spec  # noqa: F401
from .cluster import (choose_backend, client, default_workers, require_dask,  # noqa: F401
                      run_tasks, stream_tasks, task_size)

#: [1] designs evaluated in this process first, timed, to choose the backend and the task size:
#: the first design carries the one-off warm-up (imports, caches: 19 ms against 8 ms for the
#: next one of the example, measured), the last one probed gives the cost per design. Their
#: rows are kept.
PROBE_DESIGNS = 2
#: [1] rows per Parquet partition: ~150 kB of file and a few MB of Python rows held before a
#: partition is written, whatever the number of designs.
PARTITION_ROWS = 1000


@dataclasses.dataclass
class SweepPlan:
    """How a sweep ran: ``backend`` (serial, pool, dask), ``workers``, ``chunk`` (designs per
    task), ``seconds_per_design`` measured serially in this process, ``n`` designs."""
    backend: str
    workers: int
    chunk: int
    seconds_per_design: float
    n: int
    rows: int = 0
    errors: int = 0
    partitions: int = 0


def _chunks(it, size):
    while True:
        c = list(itertools.islice(it, size))
        if not c:
            return
        yield c


def iter_sweep(spec: SweepSpec, *, scheduler=None, workers=None, serial=False, progress=True,
               chunk=None, backend=None, plan: SweepPlan = None):
    """Yield the rows of ``spec`` in lists, in design order (sorted by design_id, mode), as
    they are computed; at most a few tasks are held (see ``cluster.stream_tasks``). ``plan``
    (a :class:`SweepPlan`), when given, is filled in."""
    n = spec.n if spec.method != "table" else len(spec.table)
    light = dataclasses.replace(spec, table=None)       # the tasks carry their own values
    fn = partial(evaluate_chunk, light)
    it = enumerate(spec.iter_designs())
    cost = 0.0
    for item in itertools.islice(it, min(PROBE_DESIGNS, n)):
        t = time.perf_counter()
        rows = fn([item])
        cost = time.perf_counter() - t
        yield sorted(rows, key=lambda r: (r["design_id"], r["mode"]))
    remaining = max(0, n - PROBE_DESIGNS)
    w = workers or default_workers()
    if backend is None:
        backend = choose_backend(remaining, cost, workers=w, scheduler=scheduler,
                                 serial=serial)
    if backend == "dask" and workers is None and remaining:
        with client(scheduler) as c:      # the tasks are cut for the cluster's workers
            w = len(c.scheduler_info().get("workers", {})) or w
    size = chunk or task_size(remaining, cost, w)
    if plan is not None:
        plan.backend, plan.workers, plan.chunk = backend, (1 if backend == "serial" else w), size
        plan.seconds_per_design, plan.n = cost, n
    if not remaining:
        return
    for rows in stream_tasks(fn, _chunks(it, size), backend=backend, workers=w,
                             scheduler=scheduler, progress=progress, desc="sweep",
                             total=-(-remaining // size)):
        yield sorted(rows, key=lambda r: (r["design_id"], r["mode"]))


def run_sweep(spec: SweepSpec, *, scheduler=None, workers=None, serial=False, progress=True,
              chunk=None, backend=None, plan: SweepPlan = None):
    """Evaluate every design of ``spec``; a DataFrame sorted by design_id, mode (held in
    memory: for large studies :func:`write_sweep`)."""
    import pyarrow as pa
    rows = [r for part in iter_sweep(spec, scheduler=scheduler, workers=workers, serial=serial,
                                     progress=progress, chunk=chunk, backend=backend, plan=plan)
            for r in part]
    return pa.Table.from_pylist(rows, schema=result_schema(spec)).to_pandas()


def is_sweep_dataset(path) -> bool:
    """True for a folder holding only a sweep's partitions (``part-NNNNN.parquet``)."""
    p = Path(path)
    return p.is_dir() and all(q.is_file() and q.name.startswith("part-")
                              and q.suffix == ".parquet" for q in p.iterdir())


@contextlib.contextmanager
def staged_dataset(field: str, path):
    """Yield a new folder next to ``path`` for the partitions; on success it replaces
    ``path`` (nothing, a file, or an earlier sweep's dataset: never another folder), on
    failure it is removed."""
    from model_core import CycloidInputError

    from ..outputs import output_dir, output_file
    p = Path(path)
    if p.is_dir():
        if not is_sweep_dataset(p):
            raise CycloidInputError(field, str(path), "is a folder that is not a sweep's "
                                    "results (only part-*.parquet files are replaced)")
        output_dir(field, p.parent, create=False)
    else:
        output_file(field, p)       # its folder exists and is writable
    tmp = p.with_name(f".{p.name}.partial-{os.getpid()}")
    tmp.mkdir()
    try:
        yield tmp
        if p.is_dir():
            old = p.with_name(f".{p.name}.old-{os.getpid()}")
            os.replace(p, old)
            os.replace(tmp, p)
            shutil.rmtree(old, ignore_errors=True)
        else:
            if p.exists():
                p.unlink()
            os.replace(tmp, p)
    finally:
        if tmp.exists():
            shutil.rmtree(tmp, ignore_errors=True)


def write_sweep(spec: SweepSpec, out, *, scheduler=None, workers=None, serial=False,
                progress=True, chunk=None, backend=None) -> SweepPlan:
    """Evaluate every design of ``spec`` into the folder ``out`` as Parquet partitions of
    PARTITION_ROWS rows (``part-00000.parquet``, ... in design order), each written as soon
    as it is full: ``pandas.read_parquet(out)`` reads them as one table, sorted by design_id,
    mode. Returns the :class:`SweepPlan` (backend, counts)."""
    import pyarrow as pa
    import pyarrow.parquet as pq
    out = Path(out)
    schema = result_schema(spec)
    plan = SweepPlan("serial", 1, 1, 0.0, 0)
    buf = []

    def flush():
        pq.write_table(pa.Table.from_pylist(buf, schema=schema),
                       out / f"part-{plan.partitions:05d}.parquet")
        plan.partitions += 1
        plan.rows += len(buf)
        plan.errors += sum(1 for r in buf if r.get("error"))
        buf.clear()

    for rows in iter_sweep(spec, scheduler=scheduler, workers=workers, serial=serial,
                           progress=progress, chunk=chunk, backend=backend, plan=plan):
        buf.extend(rows)
        if len(buf) >= PARTITION_ROWS:
            flush()
    if buf or not plan.partitions:
        flush()
    return plan


from .batch import diagnose_batch, diagnose_one, find_recordings  # noqa: E402,F401
