"""Same decisions before and after a performance change: the diagnosis's JSON of a fixed set of
recordings from two versions of the code, compared key by key.

A speed-up must not change what the diagnosis says. This script writes a set of recordings
(clean ones of two plans, library effects alone and in pairs, S2, a temperature column, a
remainder outside the library, the 600 000-sample benchmark recordings (a thermal drift; a
Stribeck friction in a four-quadrant plan), and recordings of the
independent generator in its file dialects: German CSV, catman text, MDF4, UTF-16 with units in
the names), diagnoses each with ``cyclo-fmu diagnose FILE --mode auto --out DIR`` under one
version of the code, and compares two such runs: every key present in both, strings and
booleans equal, numbers equal within ``--rtol`` (default 1e-6) or ``--atol`` (default 1e-9, in
the JSON's SI units: 1e-6 mN*m). The written ``design_updated.toml`` is compared the same way.

    python benchmarks/compare_diagnosis.py make DIR                 # the recordings (once)
    python benchmarks/compare_diagnosis.py run DIR before --commit c773a1f
    python benchmarks/compare_diagnosis.py run DIR after            # this working tree
    python benchmarks/compare_diagnosis.py compare DIR before after

``run --commit REV`` extracts that commit with ``git archive`` into DIR/src-REV and runs it from
there (no worktree is touched). Exit status of ``compare``: 0 when every recording agrees.
"""
from __future__ import annotations

import argparse
import json
import math
import os
import subprocess
import sys
import time
import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
#: cases of benchmarks/independent/gen.py: four file dialects, a clean one, effects, a remainder
INDEPENDENT = ["c02_clean_german_500", "c03_clean_catman_2k5", "c04_clean_mdf_1k_temp",
               "l11_ripple_roller_2k5", "o01_load2_1k", "o06_pickup37_500_utf16",
               "m04_warmup_ripple_2k5", "l05_warmup_2tau_500"]


def _windage(sig):
    """A loss outside the library: windage, k w |w| at the input (about 5 mN*m at 3000 r/min)."""
    w = sig["w_in"]
    return 5e-8 * w * abs(w)


def make(out: Path):
    """Write the recordings to out/recs and their command-line extras to out/cases.json."""
    sys.path.insert(0, str(ROOT))
    from cyclo_fmu.synth import synthesize, write_synth
    recs = out / "recs"
    recs.mkdir(parents=True, exist_ok=True)
    synth = {
        "s_clean_full": dict(effect="none", seed=3),
        "s_clean_4q": dict(effect="none", seed=4, plan="four_quadrant"),
        "s_pair_ripple_stribeck": dict(effect=["mesh_ripple", "low_speed_friction"], seed=5),
        "s_S2_drag": dict(effect="load_independent_loss", seed=6, mode="S2"),
        "s_temperature_warmup": dict(effect="thermal_drift", seed=8, temperature_rise=20.0),
        "s_windage_remainder": dict(effect="none", seed=7, added_torque=_windage),
        "s_large_thermal_600k": dict(effect="thermal_drift", seed=1, size="large"),
        "s_mesh_loss_calibrate": dict(effect="mesh_loss", seed=9),
        # bench_diagnosis.py --stribeck: the width refinement and the re-linearised problem
        # whose compared samples move in a few blocks
        "s_stribeck_4q_600k": dict(effect="low_speed_friction", seed=81, size="large",
                                   plan="four_quadrant", effect_values={"T_stribeck": 0.025},
                                   shape=(30.0, 2.0, 1.5)),
    }
    extra_args = {"s_mesh_loss_calibrate": ["--calibrate"]}
    cases = []
    for name, kw in synth.items():
        path = recs / f"{name}.csv"
        kw = dict(kw)
        effect, seed = kw.pop("effect"), kw.pop("seed")
        write_synth(path, synthesize(effect, seed, **kw))
        cases.append(dict(id=name, file=str(path), args=extra_args.get(name, [])))
        print(f"wrote {path}")
    env = dict(os.environ, CYCLO_INDEPENDENT_OUT=str(out / "independent"),
               PYTHONPATH=str(ROOT))
    subprocess.run([sys.executable, str(ROOT / "benchmarks/independent/gen.py"), *INDEPENDENT],
                   check=True, env=env)
    for c in json.loads((out / "independent" / "cases.json").read_text()):
        if c["id"] in INDEPENDENT:
            cases.append(dict(id=c["id"], file=c["file"], args=c.get("args", [])))
    (out / "cases.json").write_text(json.dumps(cases, indent=1))


def run(out: Path, label: str, commit: str = None, only=()):
    """Diagnose every case (or those in ``only``) with the code of ``commit`` (default: this
    tree) into out/label."""
    src = ROOT
    if commit:
        src = out / f"src-{commit}"
        if not src.exists():
            src.mkdir(parents=True)
            archive = subprocess.run(["git", "-C", str(ROOT), "archive", commit],
                                     check=True, capture_output=True).stdout
            subprocess.run(["tar", "-x", "-C", str(src)], input=archive, check=True)
    env = dict(os.environ, PYTHONPATH=str(src))
    dest = out / label
    dest.mkdir(parents=True, exist_ok=True)
    for c in json.loads((out / "cases.json").read_text()):
        if only and c["id"] not in only:
            continue
        d = dest / c["id"]
        if d.exists():
            subprocess.run(["rm", "-r", str(d)], check=True)
        t0 = time.perf_counter()
        p = subprocess.run([sys.executable, "-m", "cyclo_fmu.cli", "diagnose", c["file"],
                            "--mode", "auto", "--out", str(d)] + c["args"],
                           capture_output=True, text=True, env=env, cwd=str(out))
        dt = time.perf_counter() - t0
        (dest / f"{c['id']}.stdout").write_text(p.stdout + p.stderr)
        print(f"{label}: {c['id']:28s} exit {p.returncode} {dt:6.1f} s")


def _diff(a, b, path, rtol, atol, out):
    if isinstance(a, dict) and isinstance(b, dict):
        for k in sorted(set(a) | set(b)):
            if k not in a or k not in b:
                out.append(f"{path}/{k}: only in {'after' if k not in a else 'before'}")
            else:
                _diff(a[k], b[k], f"{path}/{k}", rtol, atol, out)
    elif isinstance(a, list) and isinstance(b, list):
        if len(a) != len(b):
            out.append(f"{path}: length {len(a)} != {len(b)}")
        for i, (x, y) in enumerate(zip(a, b)):
            _diff(x, y, f"{path}[{i}]", rtol, atol, out)
    elif isinstance(a, bool) or isinstance(b, bool) or isinstance(a, str) or a is None:
        if a != b:
            out.append(f"{path}: {a!r} != {b!r}")
    elif isinstance(a, (int, float)) and isinstance(b, (int, float)):
        if math.isnan(a) and math.isnan(b):
            return
        if not (a == b or abs(a - b) <= atol + rtol * max(abs(a), abs(b))):
            out.append(f"{path}: {a!r} != {b!r}")
    elif a != b:
        out.append(f"{path}: {a!r} != {b!r}")


def compare(out: Path, before: str, after: str, rtol: float, atol: float) -> int:
    bad = 0
    for c in json.loads((out / "cases.json").read_text()):
        diffs = []
        for name, load in (("diagnosis.json", lambda p: json.loads(p.read_text())),
                           ("design_updated.toml", lambda p: tomllib.loads(p.read_text()))):
            pa, pb = out / before / c["id"] / name, out / after / c["id"] / name
            if not (pa.exists() and pb.exists()):
                if pa.exists() != pb.exists():
                    diffs.append(f"{name}: written by one version only")
                continue
            _diff(load(pa), load(pb), name, rtol, atol, diffs)
        if not (out / before / c["id"] / "diagnosis.json").exists():
            a = (out / before / f"{c['id']}.stdout").read_text()
            b = (out / after / f"{c['id']}.stdout").read_text()
            if a != b:
                diffs.append("no output; the messages differ")
        bad += bool(diffs)
        print(f"{c['id']:28s} {'same' if not diffs else f'{len(diffs)} differences'}")
        for line in diffs[:20]:
            print(f"    {line}")
    print(f"{bad} of {len(json.loads((out / 'cases.json').read_text()))} recordings differ "
          f"(rtol {rtol:g}, atol {atol:g})")
    return 1 if bad else 0


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    sub = ap.add_subparsers(dest="cmd", required=True)
    p = sub.add_parser("make")
    p.add_argument("dir", type=Path)
    p = sub.add_parser("run")
    p.add_argument("dir", type=Path)
    p.add_argument("label")
    p.add_argument("--commit")
    p.add_argument("--only", nargs="*", default=())
    p = sub.add_parser("compare")
    p.add_argument("dir", type=Path)
    p.add_argument("before")
    p.add_argument("after")
    p.add_argument("--rtol", type=float, default=1e-6)
    p.add_argument("--atol", type=float, default=1e-9)
    a = ap.parse_args()
    a.dir = a.dir.resolve()
    if a.cmd == "make":
        make(a.dir)
    elif a.cmd == "run":
        run(a.dir, a.label, a.commit, a.only)
    else:
        sys.exit(compare(a.dir, a.before, a.after, a.rtol, a.atol))


if __name__ == "__main__":
    main()
