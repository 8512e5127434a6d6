"""Diagnose every recording of the sixth independent batch (gen6.py) through the command line,
`cyclo-fmu diagnose FILE --mode auto --json --out DIR` (no option beyond what a user gets by
default, but for the one dialect whose sign convention a user states: `neg_out` runs with
`--units torque_out_Nm=-N*m`), and score it against the truth gen6.py fixed before the first
run: run3.py's runner and rules (score.py), with batch 6's files and categories. Writes
OUT/results6.json, OUT/raw/<id>.json and OUT/diag/<id>/.

    nice python benchmarks/independent/run6.py [-j 1] [case_id ...]
    python benchmarks/independent/run6.py --rescore      # score the last run's JSON again

OUT: the environment variable CYCLO_INDEPENDENT_OUT (default out/independent6). Missing
recordings are generated first (gen6.py).
"""
from __future__ import annotations

import os
import sys
from pathlib import Path

os.environ.setdefault("CYCLO_INDEPENDENT_OUT", "out/independent6")
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import run3 as R  # noqa: E402

R.GEN = Path(__file__).resolve().parent / "gen6.py"
R.CASES_JSON, R.RESULTS_JSON = "cases6.json", "results6.json"
R.CATEGORIES = ("clean", "single", "calibration", "pair", "triple", "outside")


def category6(cid):
    return {"clean": "clean", "lib": "single", "cal": "calibration", "pair": "pair",
            "tri": "triple", "out": "outside"}[cid.split("_", 1)[0]]


R.CATEGORY = category6

if __name__ == "__main__":
    R.main(sys.argv[1:])
