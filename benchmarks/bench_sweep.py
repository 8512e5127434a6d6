"""Design sweep: N designs (Latin hypercube over lam, mu_boundary, viscosity) x modes S1, S2 x
the 8 x 8 bench envelope, serial vs a dask LocalCluster (issue 9, item 6).

    python benchmarks/bench_sweep.py            # N = 1000
    python benchmarks/bench_sweep.py 100 2      # N = 100 designs, 2 workers

Prints both wall times next to a reference measured in the same run (one design evaluated
serially, and dask's cost of an empty task round trip), so that numbers taken on a loaded
machine stay comparable; checks that both runs give identical tables.
"""
from __future__ import annotations

import os
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import pandas as pd  # noqa: E402

from cyclo_fmu.sweep import load_spec, run_sweep  # noqa: E402

SPEC = """[sweep]
method = "lhs"
n = {n}
seed = 1
modes = ["S1", "S2"]
[envelope]
n_speed = 8
n_torque = 8
[fields]
lam = [1.6, 2.0]
"friction.mu_boundary" = [0.07, 0.12]
kinematic_viscosity_mm2_s = [100.0, 400.0]
"""


def main(n=1000, workers=None):
    import dask
    import distributed

    from cyclo_fmu.slaves.heap import keep_temporaries_on_heap
    from cyclo_fmu.sweep.cluster import local_cluster_config
    workers = workers or os.cpu_count() or 1
    # the allocator as the cyclo-fmu command sets it for its own process (cyclo_fmu.slaves.heap)
    keep_temporaries_on_heap()
    with tempfile.TemporaryDirectory() as d:
        p = Path(d) / "spec.toml"
        p.write_text(SPEC.format(n=n))
        spec = load_spec(p)
    t = time.perf_counter()
    run_sweep(spec.__class__(**{**spec.__dict__, "n": 1}), serial=True, progress=False)
    t_one = time.perf_counter() - t
    t = time.perf_counter()
    serial = run_sweep(spec, serial=True, progress=False)
    t_serial = time.perf_counter() - t
    # the workers as cyclo_fmu.sweep.cluster.client starts them (local_cluster_config: glibc's
    # mmap threshold at 4 MiB, no profiler), and as reference with dask's defaults
    runs = {}
    # (dask's nanny writes the variables into this process's environment before it spawns a
    # worker, and later workers inherit them: the reference runs first)
    for label, cfg in (("  with dask's default worker settings", {}),
                       ("dask LocalCluster", local_cluster_config())):
        t = time.perf_counter()
        with dask.config.set(cfg), \
                distributed.LocalCluster(n_workers=workers, threads_per_worker=1,
                                         processes=True, dashboard_address=None,
                                         silence_logs=40) as cluster, \
                distributed.Client(cluster) as c:
            t_start = time.perf_counter() - t
            t0 = time.perf_counter()
            c.gather(c.map(lambda x: x, range(100), pure=False))
            t_rt = (time.perf_counter() - t0) / 100
            t1 = time.perf_counter()
            table = run_sweep(spec, scheduler=cluster.scheduler_address, progress=False)
            runs[label] = (time.perf_counter() - t1, t_start, t_rt)
        pd.testing.assert_frame_equal(serial, table)
    t_dask, t_start, t_rt = runs["dask LocalCluster"]
    print(f"sweep: {n} designs x 2 modes x 8 x 8 envelope ({len(serial)} rows), "
          f"{os.cpu_count()} CPUs, {workers} workers")
    print(f"  reference: one design serial {1e3 * t_one:.1f} ms; dask empty-task round trip "
          f"{1e3 * t_rt:.2f} ms (amortised over 100); cluster start {t_start:.1f} s")
    print(f"  serial          {t_serial:7.2f} s  ({1e3 * t_serial / n:.1f} ms/design)")
    for label, (t_d, _, _) in reversed(runs.items()):
        print(f"  {label} {t_d:5.2f} s  ({1e3 * t_d / n:.1f} ms/design), speed-up "
              f"{t_serial / t_d:.2f}x (cluster start not included); tables identical")


if __name__ == "__main__":
    a = sys.argv[1:]
    main(int(a[0]) if a else 1000, int(a[1]) if len(a) > 1 else None)
