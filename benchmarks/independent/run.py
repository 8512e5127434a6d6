"""Run `cyclo-fmu diagnose FILE --mode auto --json` on every case of cases.json (written by
gen.py), time it, compare with the truth, write results.json.

    python benchmarks/independent/run.py [case_id ...]   # (re)generates missing recordings first

Output folder: the environment variable CYCLO_INDEPENDENT_OUT (default out/independent).
"""
from __future__ import annotations

import json
import os
import subprocess
import sys
import time
from pathlib import Path

HERE = Path(os.environ.get("CYCLO_INDEPENDENT_OUT", "out/independent")).resolve()
GEN = Path(__file__).resolve().parent / "gen.py"
CLI = os.path.join(os.path.dirname(sys.executable), "cyclo-fmu")
OUT_DIR_CASES = {"l05_warmup_2tau_500", "o04_backlash_1k"}   # also run with --out


def verdict(case, res):
    if res.get("error"):
        return res["error"]
    named = [e["id"] for e in res["effects_raw"]]
    exp = set(case.get("expect", []))
    alts = [set(a) for a in case.get("alt", [])] + [exp]
    ok_named = any(set(named) == a for a in alts)
    un = res["unexplained"]["present"]
    ok_un = case.get("unexplained") is None or case["unexplained"] == un
    if ok_named and ok_un:
        return "right"
    extra = set(named) - set().union(*alts)
    if extra:
        return "wrongly named"
    if not ok_named:
        return "missed"
    return "missed (unexplained)" if case["unexplained"] else "false unexplained"


def gist(d):
    effs = []
    for e in d.get("effects", []):
        ps = ", ".join(f"{k}={v['value']:.4g}{v.get('unit', '')}" for k, v in
                       e.get("parameters", {}).items())
        effs.append(f"{e['id']}({ps}; {1e3 * e.get('explained_rms_Nm', 0):.1f} mNm)")
    u = d.get("unexplained", {})
    return dict(effects=effs, unexplained_present=u.get("present"),
                unexplained_rms_mNm=round(1e3 * (u.get("rms_Nm") or 0), 2),
                statement=u.get("statement"), follows=u.get("follows"),
                orders=u.get("orders"), peaks=u.get("peaks_Hz_Nm"),
                could_include=u.get("could_include"), bursts=u.get("bursts"),
                calibration=d.get("calibration"), mode=d.get("mode"),
                rmse_before_mNm=round(1e3 * d.get("rmse_before_Nm", float("nan")), 3),
                rmse_after_mNm=round(1e3 * d.get("rmse_after_Nm", float("nan")), 3),
                notes=d.get("notes"), read_notes=d.get("read_notes"),
                checks=d.get("checks"), withdrawn=d.get("withdrawn"),
                indistinguishable_from=d.get("indistinguishable_from"))


def run(case):
    cmd = [CLI, "diagnose", case["file"], "--mode", "auto", "--json"] + case.get("args", [])
    t0 = time.perf_counter()
    p = subprocess.run(cmd, capture_output=True, text=True)
    dt = time.perf_counter() - t0
    res = dict(cmd=" ".join(cmd), seconds=round(dt, 2), rc=p.returncode)
    if p.returncode != 0:
        res["error"] = "crash" if "Traceback" in p.stderr else "read error/refused"
        res["stderr_tail"] = p.stderr.strip().splitlines()[-8:]
        return res, None
    try:
        d = json.loads(p.stdout)
    except json.JSONDecodeError:
        res["error"] = "bad json"
        res["stdout_head"] = p.stdout[:500]
        return res, None
    res.update(gist(d))
    res["effects_raw"] = d["effects"]
    res["unexplained"] = d["unexplained"]
    if case["id"] in OUT_DIR_CASES:
        od = HERE / "out" / case["id"]
        t0 = time.perf_counter()
        q = subprocess.run(cmd[:-1] + ["--out", str(od)], capture_output=True, text=True)
        res["out_run"] = dict(rc=q.returncode, seconds=round(time.perf_counter() - t0, 2),
                              files=sorted(os.listdir(od)) if od.exists() else [],
                              stderr_tail=q.stderr.strip().splitlines()[-3:])
    return res, d


def main(argv):
    cj = HERE / "cases.json"
    if not cj.exists():
        subprocess.run([sys.executable, str(GEN)], check=True)
    cases = json.loads(cj.read_text())
    missing = [c["id"] for c in cases if not Path(c["file"]).exists()]
    if missing:
        subprocess.run([sys.executable, str(GEN)] + missing, check=True)
    sel = set(argv)
    rp = HERE / "results.json"
    results = json.loads(rp.read_text()) if rp.exists() and sel else {}
    for c in cases:
        if sel and c["id"] not in sel:
            continue
        res, _ = run(c)
        res["truth"] = c["truth"]
        res["expect"] = c.get("expect")
        res["expect_unexplained"] = c.get("unexplained")
        res["fs"], res["dialect"] = c["fs"], c["dialect"]
        res["verdict"] = verdict(c, res)
        results[c["id"]] = res
        print(f"{c['id']:30s} {res['seconds']:6.1f}s {res['verdict']:18s} "
              f"{res.get('effects', res.get('stderr_tail', ''))} "
              f"U={res.get('unexplained_present')} {res.get('unexplained_rms_mNm')}", flush=True)
        rp.write_text(json.dumps(results, indent=1, default=str))


if __name__ == "__main__":
    main(sys.argv[1:])
