"""Reading speed and peak memory of the recording readers (issue 10).

Writes a recording of N samples at RATE Hz (default 36 million at 10 kHz: one hour), then, each
in a fresh process (so that peak memory is the reader's own):
  - reference: pyarrow's streaming CSV reader over the same file, nothing else (the floor);
  - ``read_recording(path, block=0.01)``: 10 ms block means while reading (what the diagnosis of
    a long recording uses), plus the plausibility checks (``check_plausibility``);
  - optionally (--full) ``read_recording(path)`` keeping every sample.
Peak memory: ru_maxrss of the child. Target (issue 10): 36 M samples in well under 120 s,
peak memory far below 8 GB. Timings on a shared machine: compare with the reference line.
Run: python benchmarks/bench_read.py [--samples 36e6] [--rate 1e4] [--full] [--keep PATH]
"""
import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

CHILD = r"""
import json, resource, sys, time
path, what = sys.argv[1], sys.argv[2]
t0 = time.perf_counter()
out = {}
if what == "reference":
    import pyarrow.csv as pc
    n = 0
    for b in pc.open_csv(path):
        n += b.num_rows
    out["rows"] = n
else:
    from cyclo_fmu.io.checks import check_plausibility
    from cyclo_fmu.recordings import read_recording
    block = 0.01 if what == "block" else None
    rec = read_recording(path, block=block, check=False)
    t_read = time.perf_counter() - t0
    t1 = time.perf_counter()
    mode, checks = check_plausibility(rec, "S1")
    t_check = time.perf_counter() - t1
    t2 = time.perf_counter()
    from cyclo_fmu.diagnosis import Diagnoser
    d = Diagnoser(mode=mode).fit(rec).diagnosis_
    out.update(rows=rec.raw_samples, kept=rec.n, read_s=t_read, check_s=t_check,
               diagnose_s=time.perf_counter() - t2, mode=mode,
               effects=[e["id"] for e in d.effects], unexplained=d.unexplained["present"])
out["total_s"] = time.perf_counter() - t0
out["peak_MB"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
print(json.dumps(out))
"""


def write_big(path, n, rate, chunk=1_000_000):
    """An S1 run (z1 = 15): speed steps 500..3000 r/min every 60 s, load 2..18 N*m out."""
    import pyarrow as pa
    import pyarrow.csv as pc
    names = ["time_s", "speed_in_rpm", "torque_in_Nm", "speed_out_rpm", "torque_out_Nm"]
    rng = np.random.default_rng(1)
    schema = pa.schema([(c, pa.float64()) for c in names])
    with pc.CSVWriter(str(path), schema) as w:
        for k0 in range(0, n, chunk):
            k = np.arange(k0, min(n, k0 + chunk))
            t = k / rate
            n_in = 500 + 2500 * ((t // 60) % 6) / 5 + rng.normal(0, 0.3, k.size)
            T_out = 10 + 8 * np.sin(t / 7) + rng.normal(0, 0.02, k.size)
            cols = [np.round(t, 6), np.round(n_in, 2), np.round(T_out / 15 / 0.88 + 0.02, 4),
                    np.round(n_in / 15, 3), np.round(T_out, 3)]
            w.write_table(pa.table(dict(zip(names, cols)), schema=schema))


def child(path, what):
    env = dict(os.environ, PYTHONPATH=str(Path(__file__).resolve().parents[1]))
    r = subprocess.run([sys.executable, "-c", CHILD, str(path), what], capture_output=True,
                       text=True, env=env)
    if r.returncode:
        raise SystemExit(r.stderr)
    return json.loads(r.stdout)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--samples", type=float, default=36e6)
    ap.add_argument("--rate", type=float, default=1e4)
    ap.add_argument("--full", action="store_true", help="also read keeping every sample")
    ap.add_argument("--keep", help="write the file here (and reuse it if it exists)")
    a = ap.parse_args()
    n = int(a.samples)
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(a.keep) if a.keep else Path(tmp) / "big.csv"
        if not path.exists():
            t = time.perf_counter()
            write_big(path, n, a.rate)
            print(f"wrote {n} samples ({path.stat().st_size / 1e9:.2f} GB) in "
                  f"{time.perf_counter() - t:.1f} s")
        ref = child(path, "reference")
        print(f"reference (pyarrow streaming parse only): {ref['total_s']:.1f} s, "
              f"peak {ref['peak_MB']:.0f} MB")
        for what in ("block", "full") if a.full else ("block",):
            r = child(path, what)
            print(f"read_recording({'block=0.01' if what == 'block' else 'all samples'}): "
                  f"{r['rows']} samples -> {r['kept']}; read {r['read_s']:.1f} s "
                  f"({r['read_s'] / ref['total_s']:.2f} x reference), checks {r['check_s']:.2f} s, "
                  f"diagnose {r['diagnose_s']:.1f} s; total {r['total_s']:.1f} s (target <= 120 s), "
                  f"peak {r['peak_MB']:.0f} MB (target <= 8 GB); mode {r['mode']}; effects "
                  f"{r['effects']}, unexplained {r['unexplained']}")


if __name__ == "__main__":
    main()
