"""Diagnose every case of OUT/cases2.json through the CLI (one at a time), compare
with the expectation fixed in gen2.py, write results2.json (and raw/<id>.json).

    python benchmarks/independent/run2.py [-j 2] [case_id ...]
    python benchmarks/independent/run2.py --rescore      # score raw/*.json again

Output folder: the environment variable CYCLO_INDEPENDENT_OUT (default out/independent2).
Written after batch 1's fixes, by a reviewer who fixed every expectation before the first run,
to measure how the diagnosis generalises beyond the recordings it was improved against.
Newer ids (mesh_loss, idle_loss_scale, calibration_fit, a speed x load loss read as a mesh
loss) are read as in run.py; "right" also needs the named set to equal `expect` exactly.
"""
from __future__ import annotations
import json, os, sys
from pathlib import Path

os.environ.setdefault("CYCLO_INDEPENDENT_OUT", "out/independent2")
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import run as R  # noqa: E402  (verdict, gist, run from batch 1's runner)

HERE = Path(os.environ["CYCLO_INDEPENDENT_OUT"]).resolve()


def verdict2(case, res, d=None):
    v = R.verdict(case, res, d)
    if v == "right":
        effs = d["effects"] if d is not None else res["effects_raw"]
        named = set(e["id"] for e in effs)
        strict = named == set(case.get("expect", []))
        return "right" if strict else "right (alt)"
    return v


def main(argv):
    import argparse
    from concurrent.futures import ThreadPoolExecutor
    ap = argparse.ArgumentParser()
    ap.add_argument("-j", type=int, default=1, help="diagnoses at once (default 1)")
    ap.add_argument("--rescore", action="store_true",
                    help="score the JSON of the last run (OUT/raw) again, diagnosing nothing")
    ap.add_argument("ids", nargs="*")
    a = ap.parse_args(argv)
    R.HERE = HERE
    rp = HERE / "results2.json"
    if a.rescore:
        cases = {c["id"]: c for c in json.loads((HERE / "cases2.json").read_text())}
        return R.rescore(cases, rp, verdict2)
    if not (HERE / "cases2.json").exists():     # the recordings first (gen2.py)
        import subprocess
        subprocess.run([sys.executable, os.path.join(os.path.dirname(os.path.abspath(__file__)),
                                                     "gen2.py")], check=True)
    cases = json.loads((HERE / "cases2.json").read_text())
    sel = set(a.ids)
    results = json.loads(rp.read_text()) if rp.exists() and sel else {}
    (HERE / "raw").mkdir(exist_ok=True)

    def one(c):
        res, d = R.run(c)
        if d is not None:
            (HERE / "raw" / (c["id"] + ".json")).write_text(json.dumps(d, indent=1, default=str))
        res["truth"] = c["truth"]
        res["expect"], res["alt"] = c.get("expect"), c.get("alt")
        res["expect_unexplained"] = c.get("unexplained")
        res["fs"], res["dialect"], res["plan"] = c["fs"], c["dialect"], c.get("plan")
        res["verdict"] = verdict2(c, res, d)
        res.pop("effects_raw", None)
        return c["id"], res

    with ThreadPoolExecutor(max_workers=max(1, a.j)) as ex:
        for cid, res in ex.map(one, [c for c in cases if not sel or c["id"] in sel]):
            results[cid] = res
            print(f"{cid:38s} {res['seconds']:6.1f}s {res['verdict']:18s} "
                  f"{res.get('effects', res.get('stderr_tail', ''))} "
                  f"U={res.get('unexplained_present')} {res.get('unexplained_rms_mNm')}",
                  flush=True)
            rp.write_text(json.dumps(results, indent=1, default=str))
    from collections import Counter
    print(Counter(r["verdict"] for r in results.values()))


if __name__ == "__main__":
    main(sys.argv[1:])
