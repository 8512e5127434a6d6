"""Diagnose every case of OUT/cases2.json through the CLI (one at a time), compare
with the expectation fixed in gen2.py, write results2.json (and raw/<id>.json).

    python benchmarks/independent/run2.py [case_id ...]

Output folder: the environment variable CYCLO_INDEPENDENT_OUT (default out/independent2).
Written after batch 1's fixes, by a reviewer who fixed every expectation before the first run,
to measure how the diagnosis generalises beyond the recordings it was improved against.
"""
from __future__ import annotations
import json, os, sys
from pathlib import Path

os.environ.setdefault("CYCLO_INDEPENDENT_OUT", "out/independent2")
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import run as R  # noqa: E402  (verdict, gist, run from batch 1's runner)

HERE = Path(os.environ["CYCLO_INDEPENDENT_OUT"]).resolve()


def verdict2(case, res):
    v = R.verdict(case, res)
    if v == "right":
        named = set(e["id"] for e in res["effects_raw"])
        strict = named == set(case.get("expect", []))
        return "right" if strict else "right (alt)"
    return v


def main(argv):
    if not (HERE / "cases2.json").exists():     # the recordings first (gen2.py)
        import subprocess
        subprocess.run([sys.executable, os.path.join(os.path.dirname(os.path.abspath(__file__)),
                                                     "gen2.py")], check=True)
    cases = json.loads((HERE / "cases2.json").read_text())
    sel = set(argv)
    rp = HERE / "results2.json"
    results = json.loads(rp.read_text()) if rp.exists() and sel else {}
    (HERE / "raw").mkdir(exist_ok=True)
    for c in cases:
        if sel and c["id"] not in sel:
            continue
        res, d = R.run(c)
        if d is not None:
            (HERE / "raw" / (c["id"] + ".json")).write_text(json.dumps(d, indent=1, default=str))
        res["truth"] = c["truth"]
        res["expect"], res["alt"] = c.get("expect"), c.get("alt")
        res["expect_unexplained"] = c.get("unexplained")
        res["fs"], res["dialect"], res["plan"] = c["fs"], c["dialect"], c.get("plan")
        res["verdict"] = verdict2(c, res)
        res.pop("effects_raw", None)
        results[c["id"]] = res
        print(f"{c['id']:38s} {res['seconds']:6.1f}s {res['verdict']:18s} "
              f"{res.get('effects', res.get('stderr_tail', ''))} "
              f"U={res.get('unexplained_present')} {res.get('unexplained_rms_mNm')}", flush=True)
        rp.write_text(json.dumps(results, indent=1, default=str))
    from collections import Counter
    print(Counter(r["verdict"] for r in results.values()))


if __name__ == "__main__":
    main(sys.argv[1:])
