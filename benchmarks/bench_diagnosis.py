"""Speed and memory of the diagnosis as a user runs it (issue 18):

    cyclo-fmu diagnose FILE --mode auto --out DIR

run as a subprocess (imports, reading, checks, the stages replay, select, twins, remainder,
discover, report, and the written folder: diagnosis.json, report.html, diagnosis.png,
design_updated.toml). Measured per run: wall time, CPU time of the process tree, peak memory as
the summed PSS of the process tree (sampled every 50 ms) and the command's max RSS
(``wait4``), and the 1-minute load average just before it.

- 600 000 samples: a 10-minute recording at 1 kHz written by ``synth`` (a thermal drift).
  Target: <= 4 s, <= 0.5 GB.
- ``--stribeck``: the 600 000 samples as a four-quadrant recording (speed reversals,
  back-driving) with a hidden Stribeck friction of 25 mN*m (w_s = 30 rad/s, delta = 2, a
  reversal width w_r = 1.5 rad/s; ``synth``, seed 81), so the diagnosis names
  ``low_speed_friction`` and refines its width and exponent on the larger candidate set.
  Same targets.
- ``--big``: 36 million samples (1 h at 10 kHz, 1.4 GB CSV, ``bench_read.write_big``; the
  command reads it as 10 ms block means). Target: <= 120 s, <= 2 GB. Long: opt-in.

Reference measured in the same run: a bare interpreter importing what the command imports
(numpy, scipy.ndimage, scipy.special, scipy.fft, pyarrow.csv, matplotlib.figure; before
2026-11-26 afternoon: numpy, scipy.signal, scipy.stats, pyarrow.csv, matplotlib.pyplot), and
for the 36 M case
pyarrow's bare streaming parse of the file. ``--before PATH`` also runs the command from another
copy of the code (e.g. ``git archive`` of an older commit), alternating with this one, so a
before/after pair shares the machine's load. ``--inprocess`` adds read, check and diagnose
timed inside one process for the 600 000 samples.

``--json`` runs ``cyclo-fmu diagnose FILE --mode auto --json`` instead (the diagnosis printed:
no folder, figure or report; the form issue 18's target names).

    python benchmarks/bench_diagnosis.py [--repeat 3] [--big] [--keep DIR] [--before PATH]
                                          [--json] [--stribeck]
"""
from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
_EMPTY = tempfile.mkdtemp(prefix="bench_diagnosis_cwd_")


def write_600k(path):
    sys.path.insert(0, str(ROOT))
    from cyclo_fmu.synth import synthesize, write_synth
    write_synth(path, synthesize("thermal_drift", 1, "S1", "large"))


def write_600k_stribeck(path):
    sys.path.insert(0, str(ROOT))
    from cyclo_fmu.synth import synthesize, write_synth
    write_synth(path, synthesize("low_speed_friction", 81, "S1", "large", plan="four_quadrant",
                                 effect_values={"T_stribeck": 0.025}, shape=(30.0, 2.0, 1.5)))


def write_36m(path):
    sys.path.insert(0, str(ROOT / "benchmarks"))
    from bench_read import write_big
    write_big(path, 36_000_000, 1e4)


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


def run(argv, src=ROOT):
    """Run ``argv`` with PYTHONPATH=src: dict(wall, cpu, pss_MB, rss_MB, load, code, err)."""
    env = dict(os.environ, PYTHONPATH=str(src))
    load = os.getloadavg()[0]
    t = time.perf_counter()
    # (cwd: an empty folder; ``python -m`` puts it first on the path, so a source tree or a
    # stray package in a shared /tmp would shadow the installed ones)
    p = subprocess.Popen(argv, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                         cwd=_EMPTY)
    peak = [0]
    done = threading.Event()

    def sample():
        while not done.is_set():
            peak[0] = max(peak[0], _tree_pss(p.pid))
            done.wait(0.05)
    th = threading.Thread(target=sample, daemon=True)
    th.start()
    err = p.stderr.read()
    _, status, ru = os.wait4(p.pid, 0)
    wall = time.perf_counter() - t
    done.set()
    th.join()
    p.returncode = os.waitstatus_to_exitcode(status)
    return {"wall": wall, "cpu": ru.ru_utime + ru.ru_stime, "pss_MB": peak[0] / 2 ** 20,
            "rss_MB": ru.ru_maxrss / 1024, "load": load, "code": p.returncode,
            "err": err.decode(errors="replace").strip().splitlines()[-1:]}


#: ``--json``: the command as ``cyclo-fmu diagnose FILE --mode auto --json`` (the diagnosis
#: printed; no folder, no figure, no report) instead of ``--out DIR``
AS_JSON = []


def diagnose(path, out, src):
    cli = [sys.executable, "-m", "cyclo_fmu.cli"]
    where = ["--json"] if AS_JSON else ["--out", str(out)]
    return run(cli + ["diagnose", str(path), "--mode", "auto"] + where, src)


def show(label, r, target=""):
    fail = "" if r["code"] == 0 else f"  EXIT {r['code']}: {' '.join(r['err'])}"
    print(f"  {label:30s} wall {r['wall']:6.2f} s  cpu {r['cpu']:6.2f} s  peak PSS "
          f"{r['pss_MB']:5.0f} MB  max RSS {r['rss_MB']:5.0f} MB  load {r['load']:.2f}"
          f"{'  ' + target if target else ''}{fail}", flush=True)


def reference_imports():
    code = "import numpy, scipy.ndimage, scipy.special, scipy.fft, pyarrow.csv, matplotlib.figure"
    return run([sys.executable, "-c", code])


def reference_parse(path):
    code = ("import sys, pyarrow.csv as pc\nn = 0\nfor b in pc.open_csv(sys.argv[1]):\n"
            "    n += b.num_rows\n")
    return run([sys.executable, "-c", code, str(path)])


def inprocess(path):
    """Read, check and diagnose inside this process (the command's allocator setting)."""
    sys.path.insert(0, str(ROOT))
    from cyclo_fmu.slaves.heap import keep_temporaries_on_heap
    keep_temporaries_on_heap()
    from cyclo_fmu.diagnosis import Diagnoser
    from cyclo_fmu.io.checks import check_plausibility
    from cyclo_fmu.recordings import read_recording
    t = time.perf_counter()
    r = read_recording(path, check=False)
    t_read = time.perf_counter() - t
    t = time.perf_counter()
    mode, _ = check_plausibility(r, "S1")
    t_check = time.perf_counter() - t
    t = time.perf_counter()
    d = Diagnoser(mode=mode).fit(r).diagnosis_
    t_fit = time.perf_counter() - t
    print(f"  in-process: read {t_read:.2f} s, checks {t_check:.2f} s, diagnose {t_fit:.2f} s "
          f"(load {os.getloadavg()[0]:.2f}); effects {[e['id'] for e in d.effects]}")


def series(label, path, out, repeat, before, target):
    """``repeat`` runs of the command (alternating with ``before``'s code when given)."""
    mine, theirs = [], []
    for k in range(repeat):
        if before:
            theirs.append(diagnose(path, out / f"before{k}", before))
            show(f"{label}, before ({Path(before).name})", theirs[-1])
        mine.append(diagnose(path, out / f"after{k}", ROOT))
        show(f"{label}, this code", mine[-1], target)
    for name, rs in (("before", theirs), ("this code", mine)):
        if rs:
            b = min(rs, key=lambda r: r["wall"])
            print(f"  -> {label}, {name}: best wall {b['wall']:.2f} s (cpu {b['cpu']:.2f} s, "
                  f"load {b['load']:.2f}), peak PSS {max(r['pss_MB'] for r in rs):.0f} MB, max "
                  f"RSS {max(r['rss_MB'] for r in rs):.0f} MB over {len(rs)} runs", flush=True)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--big", action="store_true", help="also the 36 million samples (long)")
    ap.add_argument("--only-big", action="store_true", help="the 36 million samples alone")
    ap.add_argument("--keep", type=Path, help="write the recordings here (reused if present)")
    ap.add_argument("--before", help="a copy of older code to run alternately (PYTHONPATH)")
    ap.add_argument("--inprocess", action="store_true")
    ap.add_argument("--stribeck", action="store_true",
                    help="the 600 000 samples: four quadrants with a hidden Stribeck friction")
    ap.add_argument("--json", action="store_true",
                    help="run the command with --json (printed, no folder) instead of --out")
    a = ap.parse_args()
    if a.json:
        AS_JSON.append(True)
    with tempfile.TemporaryDirectory() as tmp:
        d = a.keep or Path(tmp)
        d.mkdir(parents=True, exist_ok=True)
        out = Path(tmp) / "out"
        print(f"machine: {os.cpu_count()} CPUs; load average {os.getloadavg()}")
        show("reference: bare imports", reference_imports())
        if not a.only_big:
            f = d / ("diagnosis_600k_stribeck.csv" if a.stribeck else "diagnosis_600k.csv")
            if not f.exists():
                (write_600k_stribeck if a.stribeck else write_600k)(f)
            print(f"600 000 samples ({f.stat().st_size / 1e6:.0f} MB CSV):")
            series("600k", f, out / "600k", a.repeat, a.before, "(target <= 4 s, <= 0.5 GB)")
            if a.inprocess:
                inprocess(f)
        if a.big or a.only_big:
            f = d / "diagnosis_36M.csv"
            if not f.exists():
                t = time.perf_counter()
                write_36m(f)
                print(f"wrote {f} in {time.perf_counter() - t:.0f} s")
            print(f"36 million samples ({f.stat().st_size / 1e9:.2f} GB CSV):")
            show("reference: pyarrow parse", reference_parse(f))
            series("36M", f, out / "36M", 1, a.before, "(target <= 120 s, <= 2 GB)")


if __name__ == "__main__":
    main()
