"""Print the score and one Markdown line per miss of an independent batch's last run.

    python benchmarks/independent/misses.py DIR [DIR ...]
    python benchmarks/independent/misses.py --table DIR     # one table row per case

DIR is a batch's output folder (CYCLO_INDEPENDENT_OUT of its run: results*.json, cases*.json
and raw/<id>.json). Each miss line gives the case, its plan, mode, rate and dialect, the hidden
truth, the expectation, what the diagnosis named (with its explained size), its unexplained
claims (size in mN*m, what the remainder follows, bursts with their p-values) and its
proposal. Reads only the JSON the command printed (score.py's reading).
"""
from __future__ import annotations

import json
import os
import sys
from collections import Counter
from pathlib import Path

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from score import unexplained_claims  # noqa: E402

RIGHT = ("right", "right (alt)")


def _load(d):
    res = next((p for p in sorted(d.glob("results*.json"))), None)
    cas = next((p for p in sorted(d.glob("cases*.json"))), None)
    if res is None or cas is None:
        raise SystemExit(f"{d}: no results*.json / cases*.json")
    return json.loads(res.read_text()), {c["id"]: c for c in json.loads(cas.read_text())}


def truth_text(case):
    tr = case.get("truth") or []
    if isinstance(tr, dict):
        tr = tr.get("effects", [])
    if not tr:
        return "clean"
    out = []
    for t in tr:
        size = t.get("rms_mNm_actual", t.get("rms_mNm"))
        pars = {k: v for k, v in t.items() if k not in ("kind", "rms_mNm_actual", "rms_mNm")
                and isinstance(v, (int, float, str)) and len(str(v)) < 12}
        ps = ",".join(f"{k}={v}" for k, v in list(pars.items())[:3])
        out.append(f"{t.get('kind')}" + (f"({ps})" if ps else "")
                   + (f" {size} mN*m" if size is not None else ""))
    return " + ".join(out)


def expect_text(case):
    exp = case.get("expect", [])
    if exp and isinstance(exp[0], list):
        s = " + ".join("/".join(g) for g in exp) or "nothing"
    else:
        s = "{" + ", ".join(exp) + "}" if exp else "nothing"
        for a in case.get("alt") or []:
            s += " or {" + ", ".join(a) + "}"
    if case.get("tolerate"):
        s += " (tol. " + ", ".join(case["tolerate"]) + ")"
    u = case.get("unexplained")
    s += {True: "; unexplained", False: "; nothing unexplained", None: ""}[u]
    return s


def named_text(d):
    out = []
    for e in d.get("effects", []):
        out.append(f"{e['id']} {1e3 * (e.get('explained_rms_Nm') or 0):.2f}")
    cal = d.get("calibration") or {}
    for k, v in cal.items():
        if isinstance(v, dict) and "value" in v:
            out.append(f"[cal {k} {v['value']:+.3f}]")
    fit = d.get("calibration_fit")
    if isinstance(fit, dict):
        out.append(f"[fit k={fit.get('mesh_loss_k', 0):.2g} "
                   f"idle={fit.get('idle_loss_scale', 1):.3f}]")
    return ", ".join(out) or "nothing"


def proposal_text(d):
    p = (d.get("unexplained") or {}).get("proposed")
    if not p:
        return ""
    if p.get("refused"):
        return f"proposal refused ({p['refused']})"
    b, a = p.get("heldout_rms_before_Nm"), p.get("heldout_rms_after_Nm")
    rem = f", held-out {1e3 * b:.2f} -> {1e3 * a:.2f} mN*m" if b and a is not None else ""
    return f"proposal `{p.get('formula')}`{rem}"


def plan_text(r, case):
    plan = case.get("plan") or r.get("plan")
    if isinstance(plan, dict):
        plan = plan.get("kind") or ",".join(f"{k}={v}" for k, v in plan.items())
    return "/".join(str(x) for x in (plan or "std", case.get("mode", r.get("mode_found", "")),
                                     f"{case.get('fs')} Hz", case.get("dialect")) if x != "")


def report(d):
    d = Path(d)
    results, cases = _load(d)
    c = Counter(r["verdict"] for r in results.values())
    ok = sum(c[v] for v in RIGHT)
    lines = [f"**{d}**: {ok} of {len(results)} right (" +
             ", ".join(f"{k} {v}" for k, v in sorted(c.items())) + ")", ""]
    pc = Counter(r["proposal"] for r in results.values() if "proposal" in r)
    if pc:
        lines += ["proposals: " + ", ".join(f"{k} {v}" for k, v in sorted(pc.items())), ""]
    for cid, r in results.items():
        if r["verdict"] in RIGHT:
            continue
        raw = d / "raw" / (cid + ".json")
        case = cases.get(cid, {})
        if not raw.exists():
            lines.append(f"- `{cid}` ({plan_text(r, case)}): **{r['verdict']}**; "
                         f"{r.get('stderr_tail', '')}")
            continue
        j = json.loads(raw.read_text())
        prop = proposal_text(j)
        lines.append(f"- `{cid}` ({plan_text(r, case)}): **{r['verdict']}**; truth "
                     f"{truth_text(case)}; expected {expect_text(case)}; named "
                     f"{named_text(j)}; unexplained {unexplained_claims(j)}"
                     + (f"; {prop}" if prop else ""))
    return "\n".join(lines)


def table(d):
    """A Markdown table of every case: truth, expectation, names, remainder, proposal,
    verdict."""
    d = Path(d)
    results, cases = _load(d)
    rows = ["| case | truth (mN·m) | expected | named | unexplained (mN·m) | proposal | verdict |",
            "|---|---|---|---|---|---|---|"]
    for cid, r in results.items():
        case = cases.get(cid, {})
        raw = d / "raw" / (cid + ".json")
        j = json.loads(raw.read_text()) if raw.exists() else {}
        u = j.get("unexplained") or {}
        un = f"{1e3 * (u.get('rms_Nm') or 0):.2f}" if u.get("present") else "no"
        named = ", ".join(e["id"] for e in j.get("effects", [])) or "—"
        rows.append(f"| `{cid}` | {truth_text(case)} | {expect_text(case)} | {named} | {un} | "
                    f"{r.get('proposal', '')} | **{r['verdict']}** |")
    return "\n".join(rows)


if __name__ == "__main__":
    args = sys.argv[1:]
    if args and args[0] == "--table":
        for a in args[1:]:
            print(table(a))
    else:
        for a in args:
            print(report(a))
            print()
