"""Speed of the diagnosis: a 10-minute recording at 1 kHz (600 000 samples) written by
``synth``, read, checked and diagnosed (replay, location, 8 candidates with their shape grids,
BIC and 5-fold blocked cross-validation). Target (issue 4): at most 60 s on this machine.
Run: python benchmarks/bench_diagnosis.py
"""
import tempfile
import time
from pathlib import Path

from cyclo_fmu.diagnosis import Diagnoser
from cyclo_fmu.synth import synthesize, write_synth


def main():
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "large.csv"
        t = time.perf_counter()
        rec = synthesize("thermal_drift", 1, "S1", "large")
        write_synth(path, rec)
        t_synth = time.perf_counter() - t
        from cyclo_fmu.recordings import read_recording
        t = time.perf_counter()
        r = read_recording(path)
        t_read = time.perf_counter() - t
        t = time.perf_counter()
        d = Diagnoser(mode="S1").fit(r)
        t_fit = time.perf_counter() - t
        print(f"600 000 samples: synth + write {t_synth:.1f} s, read + check {t_read:.1f} s, "
              f"diagnose {t_fit:.1f} s; total read + diagnose {t_read + t_fit:.1f} s "
              f"(target <= 60 s); effect found: {d.effect}")


if __name__ == "__main__":
    main()
