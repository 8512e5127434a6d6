"""Design sweeps and batch diagnosis as whole ``cyclo-fmu`` commands: serial against the local
process pool, peak memory at two counts, and the references the backend choice rests on
(issue 9, item 6; issue 21, item 5).

    python benchmarks/bench_sweep.py                 # everything (~10 min on 2 idle cores)
    python benchmarks/bench_sweep.py speed           # 45-design example and 1000 designs
    python benchmarks/bench_sweep.py example         # the 45-design example, 6 pairs
    python benchmarks/bench_sweep.py memory          # 10^3 vs 10^4 designs
    python benchmarks/bench_sweep.py batch           # diagnose-batch, 50 vs 200 recordings
    python benchmarks/bench_sweep.py reference       # cost per design, pool and dask start-up

Every command runs as its own process (``python -m cyclo_fmu.cli``), as a user runs it; for each
the wall time, the CPU time of the command and all its workers (``getrusage`` of the reaped
children), the load average of the machine before it, and the peak memory: the summed PSS of
the command's process tree (proportional set size: pages shared by the forked workers are
counted once), sampled every 50 ms. The ratio serial / parallel is printed twice: by wall time,
which on a machine shared with other jobs depends on their load, and by CPU time per core,
``cpu_serial / (cpu_parallel / workers)``, the speed-up the pool would give on idle cores if it
kept them all busy (its overhead of start-up, pickling and scheduling is in its CPU time).
Each pair runs alternately, REPEATS times, and the best wall time of each is kept.
"""
from __future__ import annotations

import os
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

#: runs of each command in a pair, alternating (the best wall time is kept)
REPEATS = 2

LHS = """[sweep]
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


def _tree_pss(pid):
    import psutil
    try:
        root = psutil.Process(pid)
        procs = [root, *root.children(recursive=True)]
    except psutil.Error:
        return 0
    total = 0
    for p in procs:
        try:
            total += p.memory_full_info().pss
        except psutil.Error:
            pass
    return total


def run(argv, label, check=True):
    """Run ``cyclo-fmu argv``: dict(wall, cpu (command and workers), cpu_root (the command's
    own process), peak_MB (summed PSS of the tree), load (1-min average before), out)."""
    import psutil
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    load = os.getloadavg()[0]
    r0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    t = time.perf_counter()
    p = subprocess.Popen([sys.executable, "-m", "cyclo_fmu.cli", *argv], env=env,
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    peak, root_cpu = [0], [0.0]

    def sample():
        proc = psutil.Process(p.pid)
        while p.poll() is None:
            peak[0] = max(peak[0], _tree_pss(p.pid))
            try:
                c = proc.cpu_times()
                root_cpu[0] = c.user + c.system
            except psutil.Error:
                pass
            time.sleep(0.05)
    th = threading.Thread(target=sample, daemon=True)
    th.start()
    out, err = p.communicate()
    wall = time.perf_counter() - t
    th.join()
    r1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    if check and p.returncode != 0:
        raise SystemExit(f"{label}: exit {p.returncode}\n{err}")
    cpu = (r1.ru_utime - r0.ru_utime) + (r1.ru_stime - r0.ru_stime)
    return {"wall": wall, "cpu": cpu, "cpu_root": min(root_cpu[0], cpu),
            "peak_MB": peak[0] / 2**20, "load": load, "code": p.returncode,
            "out": out.strip().splitlines()[0] if out.strip() else ""}


def idle_wall(r, workers):
    """The wall time on idle cores from the CPU times: the command's own process runs alone
    (start, imports, probe, writing), its workers' CPU time spreads over the workers."""
    return r["cpu_root"] + (r["cpu"] - r["cpu_root"]) / workers


def best(runs):
    b = min(runs, key=lambda r: r["wall"])
    return {**b, "cpu": statistics.median(r["cpu"] for r in runs),
            "cpu_root": statistics.median(r["cpu_root"] for r in runs),
            "load": statistics.mean(r["load"] for r in runs),
            "peak_MB": max(r["peak_MB"] for r in runs)}


def show(label, r):
    print(f"  {label:34s} wall {r['wall']:7.2f} s  cpu {r['cpu']:7.2f} s (own "
          f"{r['cpu_root']:.2f} s)  peak PSS "
          f"{r['peak_MB']:6.0f} MB  load {r['load']:.2f}")


def pair(label, argv_serial, argv_par, out, workers, repeats=None):
    """serial vs default, alternating REPEATS times."""
    rs, rp = [], []
    for _ in range(repeats or REPEATS):
        for argv, acc in ((argv_serial, rs), (argv_par, rp)):
            shutil.rmtree(out, ignore_errors=True)
            acc.append(run(argv, label))
    s, p = best(rs), best(rp)
    print(f"{label}")
    show("--serial", s)
    show(f"default ({p['out'].split(';')[-1].strip(' )')})", p)
    if len(rs) > 2:
        print(f"  median wall: serial {statistics.median(r['wall'] for r in rs):.2f} s, default "
              f"{statistics.median(r['wall'] for r in rp):.2f} s; per pair serial/default: "
              + ", ".join(f"{a['wall'] / b['wall']:.2f}" for a, b in zip(rs, rp)))
    print(f"  ratio serial/default: wall {s['wall'] / p['wall']:.2f}x; from the CPU times "
          f"(idle cores: command's own CPU + workers' CPU / {workers}) "
          f"{s['cpu'] / idle_wall(p, workers):.2f}x (serial {s['cpu']:.2f} s against "
          f"{p['cpu_root']:.2f} + {p['cpu'] - p['cpu_root']:.2f} / {workers} s)")
    return s, p


def example(d, workers):
    """The README example alone, 6 alternating pairs."""
    out = d / "s.parquet"
    pair("README example (examples/sweep.toml, 45 designs x S1, S2 x 8 x 8), 6 pairs",
         ["sweep", str(ROOT / "examples/sweep.toml"), "--out", str(out), "--serial", "--quiet"],
         ["sweep", str(ROOT / "examples/sweep.toml"), "--out", str(out), "--quiet"], out,
         workers, repeats=6)


def speed(d, workers):
    out = d / "s.parquet"
    pair("README example (examples/sweep.toml, 45 designs x S1, S2 x 8 x 8)",
         ["sweep", str(ROOT / "examples/sweep.toml"), "--out", str(out), "--serial", "--quiet"],
         ["sweep", str(ROOT / "examples/sweep.toml"), "--out", str(out), "--quiet"], out,
         workers)
    spec = d / "lhs1000.toml"
    spec.write_text(LHS.format(n=1000))
    s, p = pair("1000 designs (Latin hypercube, S1, S2, 8 x 8)",
                ["sweep", str(spec), "--out", str(out), "--serial", "--quiet"],
                ["sweep", str(spec), "--out", str(out), "--quiet"], out, workers)
    per = s["cpu"] / 1000
    print(f"  per design: {1e3 * per:.1f} ms CPU serially (whole command / 1000); expected wall "
          f"on N idle workers: {p['cpu_root']:.1f} s + 1000 x {1e3 * per:.1f} ms / N")


def memory(d, workers):
    import pandas as pd
    out = d / "m.parquet"
    print("peak memory of a sweep (default backend) against the number of designs")
    rows = {}
    for n in (1000, 10000):
        spec = d / f"lhs{n}.toml"
        spec.write_text(LHS.format(n=n))
        shutil.rmtree(out, ignore_errors=True)
        r = run(["sweep", str(spec), "--out", str(out), "--quiet"], f"sweep {n}")
        rows[n] = r
        df = pd.read_parquet(out)
        show(f"{n:6d} designs ({len(df)} rows, "
             f"{len(list(out.iterdir()))} partitions)", r)
        print(f"  {'':34s} {1e3 * r['wall'] / n:.1f} ms wall and {1e3 * r['cpu'] / n:.1f} ms "
              "CPU per design")
    print(f"  peak ratio 10^4 / 10^3 designs: {rows[10000]['peak_MB'] / rows[1000]['peak_MB']:.2f}")


def batch(d, workers):
    import pandas as pd
    from cyclo_fmu.synth import synthesize, write_synth
    src = d / "distinct"
    src.mkdir()
    effects = ("none", "load_independent_loss", "viscosity_drift", "torque_sensor_gain")
    distinct = []
    for i in range(8):
        p = src / f"r{i}.csv"
        write_synth(p, synthesize(effects[i % len(effects)], i + 1, "S1", "tiny"))
        distinct.append(p)
    print("peak memory of diagnose-batch (default backend) against the number of recordings "
          "(synthetic 'tiny' S1 recordings, 8 distinct, copied)")
    rb = {}
    for n in (50, 200):
        folder = d / f"recs{n}"
        folder.mkdir()
        for i in range(n):
            shutil.copy(distinct[i % len(distinct)], folder / f"rec{i:04d}.csv")
        if n == 50:
            (folder / "rec_broken.csv").write_text("time_s,speed_in_rpm\n0,1\n")
        bo = d / f"batch{n}"
        # (a failed file may make the exit status 1: its row says why)
        r = run(["diagnose-batch", str(folder), "--mode", "S1", "--out", str(bo), "--quiet"],
                f"batch {n}", check=False)
        if not (bo / "summary.csv").exists():
            raise SystemExit(f"diagnose-batch {n}: exit {r['code']}, no summary.csv")
        rb[n] = r
        s = pd.read_csv(bo / "summary.csv", keep_default_na=False)
        show(f"{len(s):4d} recordings ({(s['error'] != '').sum()} failed, kept as rows)", r)
        print(f"  {'':34s} {r['wall'] / len(s):.2f} s wall and {r['cpu'] / len(s):.2f} s CPU "
              "per recording")
    print(f"  peak ratio 200 / 50 recordings: {rb[200]['peak_MB'] / rb[50]['peak_MB']:.2f}")


def _noop(x):
    return x


def reference(d, workers):
    """Serial cost per design, the start-up of each parallel backend (in this process)."""
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor

    from cyclo_fmu.slaves.heap import keep_temporaries_on_heap
    from cyclo_fmu.sweep import cluster, load_spec
    from cyclo_fmu.sweep.evaluate import evaluate_chunk
    keep_temporaries_on_heap()
    spec = load_spec(ROOT / "examples/sweep.toml")
    designs = list(enumerate(spec.designs()))
    evaluate_chunk(spec, designs[:1])
    t = time.perf_counter()
    evaluate_chunk(spec, designs[1:21])
    c = (time.perf_counter() - t) / 20
    print(f"reference (load {os.getloadavg()[0]:.2f}): serial cost per design (S1, S2, 8 x 8) "
          f"{1e3 * c:.1f} ms")
    for method in ("fork", "spawn"):
        ts = []
        for _ in range(3):
            t = time.perf_counter()
            with ProcessPoolExecutor(workers, mp_context=multiprocessing.get_context(method)) as ex:
                list(ex.map(_noop, range(workers)))
            ts.append(time.perf_counter() - t)
        print(f"  {method} pool of {workers}: start, one trivial task each, shut down: "
              f"{1e3 * min(ts):.0f} ms (best of 3; {', '.join(f'{1e3 * x:.0f}' for x in ts)})"
              f"; cluster.{'POOL_START_S' if method == 'fork' else 'SPAWN_START_S'} = "
              f"{cluster.POOL_START_S if method == 'fork' else cluster.SPAWN_START_S} s")
    try:
        import dask
        import distributed
        t = time.perf_counter()
        with dask.config.set(cluster.local_cluster_config()), \
                distributed.LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                                         dashboard_address=None, silence_logs=40) as lc, \
                distributed.Client(lc) as cl:
            cl.gather(cl.map(_noop, range(workers)))
            t_dask = time.perf_counter() - t
        print(f"  dask LocalCluster of {workers} (what --scheduler users run): start and first "
              f"tasks {t_dask:.2f} s")
    except ImportError:
        pass
    cut = cluster.serial_cutoff_s(workers)
    print(f"  cut-off: serial work below {cut:.2f} s = {cut / c:.0f} designs of this cost stays "
          f"serial ({cluster.POOL_SAFETY:g} x start-up x w/(w-1))")


def design_cost(d, workers):
    """CPU time per design of the example sweep, split: the whole evaluation, the efficiency
    maps alone (the reference: what a design cost before the stiffness columns and the static
    rating were added, issue 19), and the stiffness columns with the static rating."""
    from cyclo_fmu.slaves.heap import keep_temporaries_on_heap
    from cyclo_fmu.sweep import load_spec
    from cyclo_fmu.sweep.evaluate import evaluate_chunk, stiffness_columns
    from model_core.maps import efficiency_map
    from model_core.stiffness import static_torque_rating
    keep_temporaries_on_heap()
    spec = load_spec(ROOT / "examples/sweep.toml")
    designs = list(enumerate(spec.designs()))[1:21]
    built = [spec.build(v) for _, v in designs]
    evaluate_chunk(spec, designs[:1])
    env = spec.envelope

    def cpu(fn):
        t = time.process_time()
        for x in range(len(built)):
            fn(x)
        return (time.process_time() - t) / len(built)

    whole = cpu(lambda i: evaluate_chunk(spec, [designs[i]]))
    maps = cpu(lambda i: [efficiency_map(built[i], m, env.speeds(), env.torques())
                          for m in spec.modes])
    # the rating uncached (ring_torque_rating caches it per design)
    stiff = cpu(lambda i: (stiffness_columns(built[i]), static_torque_rating(built[i])))
    print(f"per-design CPU (load {os.getloadavg()[0]:.2f}), {len(built)} designs of "
          f"examples/sweep.toml: whole evaluation {1e3 * whole:.1f} ms; reference, the "
          f"efficiency maps alone ({', '.join(spec.modes)}, 8 x 8) {1e3 * maps:.1f} ms; "
          f"stiffness columns + static rating {1e3 * stiff:.1f} ms "
          f"({whole / maps:.2f} x the maps)")


def main(argv):
    parts = argv or ["reference", "speed", "memory", "batch"]
    workers = min(os.cpu_count() or 1, 8)
    print(f"{os.cpu_count()} CPUs, {workers} workers; load average {os.getloadavg()}")
    with tempfile.TemporaryDirectory() as d:
        d = Path(d)
        for part in parts:
            {"reference": reference, "design": design_cost, "speed": speed, "example": example, "memory": memory,
             "batch": batch}[part](d, workers)
    print(f"load average at the end {os.getloadavg()}")


if __name__ == "__main__":
    main(sys.argv[1:])
