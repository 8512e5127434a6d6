"""Diagnose every recording of the fourth independent batch (gen4.py) through the command line,
`cyclo-fmu diagnose FILE --mode auto --json --out DIR` (no --calibrate: the default a user
gets), and score it against the truth gen4.py fixed before the first run: run3.py's runner and
rules (score.py), with batch 4's files and categories. Writes OUT/results4.json, OUT/raw/<id>.json
and OUT/diag/<id>/.

    nice python benchmarks/independent/run4.py [-j 2] [case_id ...]
    python benchmarks/independent/run4.py --rescore      # score the last run's JSON again

OUT: the environment variable CYCLO_INDEPENDENT_OUT (default out/independent4). Missing
recordings are generated first (gen4.py).
"""
from __future__ import annotations

import os
import sys
from pathlib import Path

os.environ.setdefault("CYCLO_INDEPENDENT_OUT", "out/independent4")
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import run3 as R  # noqa: E402

R.GEN = Path(__file__).resolve().parent / "gen4.py"
R.CASES_JSON, R.RESULTS_JSON = "cases4.json", "results4.json"
# gen4.build fades every loss through standstill as tanh(|w|/gen4.W_STICK), W_STICK = 0.1 rad/s,
# in every recording: the library's loss_transition since the batch was fixed (README)
R.ALWAYS_TOLERATED = ["loss_transition"]
R.CATEGORIES = ("clean", "single", "forms", "triple", "outside")


def category4(cid):
    return {"clean": "clean", "lib": "single", "form": "forms", "tri": "triple",
            "out": "outside"}[cid.split("_", 1)[0]]


R.CATEGORY = category4

if __name__ == "__main__":
    R.main(sys.argv[1:])
