"""Design studies and batch diagnosis on dask.distributed (optional extra ``sweep``).

- :func:`run_sweep`: many designs (grid, Latin hypercube, table) x modes over an envelope,
  one row per design x mode (see :mod:`cyclo_fmu.sweep.evaluate`), as a pandas DataFrame;
- :func:`diagnose_batch`: every recording in a folder, one result folder each plus a summary.
"""
from __future__ import annotations

from functools import partial

from .evaluate import evaluate_chunk, evaluate_design, stiffness_columns, stiffness_hook  # noqa: F401
from .spec import SweepSpec, load_spec  # noqa: F401
from .cluster import client, require_dask, run_tasks  # noqa: F401

#: Designs per task [1]: one design-mode costs ~20 ms; 25 designs make a task of ~1 s, long
#: against dask's ~1 ms per-task overhead and short enough for a smooth progress bar.
CHUNK = 25


def run_sweep(spec: SweepSpec, *, scheduler=None, workers=None, serial=False, progress=True,
              chunk=CHUNK):
    """Evaluate every design of ``spec``; a DataFrame sorted by design_id, mode."""
    import pandas as pd
    designs = list(enumerate(spec.designs()))
    chunks = [designs[i:i + chunk] for i in range(0, len(designs), chunk)]
    parts = run_tasks(partial(evaluate_chunk, spec), chunks, scheduler=scheduler,
                      workers=workers, progress=progress, desc="sweep", serial=serial)
    rows = [r for p in parts for r in p]
    df = pd.DataFrame(rows)
    return df.sort_values(["design_id", "mode"], kind="stable").reset_index(drop=True)


from .batch import diagnose_batch, diagnose_one, find_recordings  # noqa: E402,F401
