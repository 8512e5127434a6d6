"""Mutation testing of the physics, the readers and the diagnosis rules (issue 21, item 2).

Outside the default suite: ``python benchmarks/mutation.py [--random N] [--seed S]``.
A small self-written mutator (no mutmut: its runner assumes one test command for the whole
tree and takes hours here). Three sets of one-change mutants:

* **curated**: the one-line changes of the issue 21 audit (bounds no longer enforced, the
  speed-ratio tolerance 3 % -> 12 % / 30 %, the spike threshold 8 -> 5 / 3 / 40 robust sigma,
  the spike share 2 % -> 20 %, Walther's 0.7, the Hertz radius doubled, degF inverted, ...),
  each an exact text replacement;
* **regression**: the real survivors of earlier runs (the random sample moves with the code;
  these stay measured), exact text replacements too;
* **random**: a deterministic sample (``--seed``) of AST mutants over ``model_core/``,
  ``cyclo_fmu/io/``, ``cyclo_fmu/recordings.py`` and the diagnosis's rules
  (``cyclo_fmu/diagnosis/residual.py``, ``selection.py``): a number doubled (an integer
  + 1), a comparison swapped (< <=, > >=, == !=), + <-> -, * <-> /. Numbers inside f-strings
  and docstrings are left alone (they change messages, not behaviour).

Each mutant is applied to a scratch copy of the tree and the test files mapped to its source
file run there (``pytest -x -q``, the default markers, 300 s limit). A mutant is *killed* when
they fail or time out, *survived* when they pass. The table of results goes to stdout and to
``--out`` (Markdown; the survivor list of docs/explanation/testing.md comes from it).
"""
from __future__ import annotations

import argparse
import ast
import os
import random
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

MODEL_TESTS = ["tests/test_pinned_numbers.py", "tests/test_physics.py",
               "tests/test_efficiency.py", "tests/test_kinematics.py",
               "tests/test_geometry_contact.py", "tests/test_friction.py",
               "tests/test_stiffness.py", "tests/test_velocities.py", "tests/test_design.py",
               "tests/test_rule_boundaries.py"]
IO_TESTS = ["tests/test_rule_boundaries.py", "tests/test_units_table.py",
            "tests/test_recordings.py", "tests/test_io_checks.py", "tests/test_io_formats.py",
            "tests/test_reader_fuzz.py"]
DIAG_TESTS = ["tests/test_rule_boundaries.py", "tests/test_diagnosis.py"]


def tests_for(path: str) -> list:
    if path == "model_core/thermal.py":       # its own file last (it also runs FMUs: ~30 s)
        return MODEL_TESTS + ["tests/test_thermal.py"]
    if path.startswith("model_core/"):
        return MODEL_TESTS
    if path.startswith("cyclo_fmu/diagnosis/"):
        return DIAG_TESTS
    return IO_TESTS


# (name, file, old text, new text): the issue 21 audit's sample and its neighbours
CURATED = [
    ("bounds not enforced", "cyclo_fmu/diagnosis/selection.py",
     "admissible = bool(np.all((coef >= lo) & (coef <= hi))) if len(idx) else True",
     "admissible = True"),
    ("ratio tolerance 3 % -> 12 %", "cyclo_fmu/io/checks.py", "RATIO_TOL = 0.03",
     "RATIO_TOL = 0.12"),
    ("ratio tolerance 3 % -> 30 %", "cyclo_fmu/io/checks.py", "RATIO_TOL = 0.03",
     "RATIO_TOL = 0.30"),
    ("ratio tolerance 3 % -> 5 %", "cyclo_fmu/io/checks.py", "RATIO_TOL = 0.03",
     "RATIO_TOL = 0.05"),
    ("spike threshold 8 -> 5 sigma", "cyclo_fmu/diagnosis/residual.py", "SPIKE_SIGMA = 8.0",
     "SPIKE_SIGMA = 5.0"),
    ("spike threshold 8 -> 3 sigma", "cyclo_fmu/diagnosis/residual.py", "SPIKE_SIGMA = 8.0",
     "SPIKE_SIGMA = 3.0"),
    ("spike threshold 8 -> 40 sigma", "cyclo_fmu/diagnosis/residual.py", "SPIKE_SIGMA = 8.0",
     "SPIKE_SIGMA = 40.0"),
    ("spike share 2 % -> 20 %", "cyclo_fmu/diagnosis/residual.py", "MAX_SPIKE_SHARE = 0.02",
     "MAX_SPIKE_SHARE = 0.20"),
    ("Walther 0.7 -> 0.6", "model_core/thermal.py", "np.log10(np.log10(nu * 1e6 + 0.7))",
     "np.log10(np.log10(nu * 1e6 + 0.6))"),
    # the ring contacts' Hertz radius doubled: that element's rating x2 (the rating moved from
    # contact.py to stiffness.py's elements; the drive's rating is now their minimum)
    ("Hertz radius doubled (ring-contact rating x2)", "model_core/stiffness.py",
     "line_contact_pressure(F_r, design.b1, design.d_v1 / 2)",
     "line_contact_pressure(F_r, design.b1, design.d_v1)"),
    ("degF inverted", "cyclo_fmu/io/units.py", '"degf": 5.0 / 9.0}', '"degf": 9.0 / 5.0}'),
    ("N*mm as 1e-6", "cyclo_fmu/io/units.py", '"n*mm": 1e-3', '"n*mm": 1e-6'),
    ("efficiency max 1.05 -> 1.5", "cyclo_fmu/io/checks.py", "EFFICIENCY_MAX = 1.05",
     "EFFICIENCY_MAX = 1.5"),
    ("N*mm suspicion 1000 -> 10000 N*m", "cyclo_fmu/io/checks.py",
     "N_MM_SUSPECT_NM = 1000.0", "N_MM_SUSPECT_NM = 10000.0"),
    ("NaN share 20 % -> 50 %", "cyclo_fmu/recordings.py", "MAX_EXCLUDED = 0.20",
     "MAX_EXCLUDED = 0.50"),
    ("model torque factor 10 -> 100", "cyclo_fmu/io/checks.py", "MODEL_TORQUE_FACTOR = 10.0",
     "MODEL_TORQUE_FACTOR = 100.0"),
    ("design drag bound x10", "model_core/design.py",
     "cap = ring_torque_rating(d) / (d.z1 - 1)", "cap = 10 * ring_torque_rating(d) / (d.z1 - 1)"),
    ("speed bound 1e5 -> 1e6 r/min", "cyclo_fmu/limits.py", "MAX_SPEED_RPM = 1.0e5",
     "MAX_SPEED_RPM = 1.0e6"),
]

# (name, file, old text, new text): the real survivors of earlier runs (the random sample moves
# with the code; these stay measured), each killed since by a test with a known answer
REGRESSION = [
    ("Legendre basis [0]*k -> [1]*k (was residual.py line 59)", "cyclo_fmu/diagnosis/residual.py",
     "legendre.legval(x, [0] * k + [1])", "legendre.legval(x, [1] * k + [1])"),
    ("burst run count 1 + -> 2 + (was residual.py line 339)", "cyclo_fmu/diagnosis/residual.py",
     "runs = 1 + int(", "runs = 2 + int("),
    ("peak level: median window width -> width + 2 bins", "cyclo_fmu/diagnosis/residual.py",
     'median_filter(P, size=width, mode="nearest")',
     'median_filter(P, size=width + 2, mode="nearest")'),
    ("peak level: flank median 3 -> 4 bins (was: window 3 -> 4, line 227)",
     "cyclo_fmu/diagnosis/residual.py", "sliding_window_view(P, 3)", "sliding_window_view(P, 4)"),
    ("power-balance sum offset 1 W (io/checks.py line 196)", "cyclo_fmu/io/checks.py",
     '"forward": [0, 0.0, 0.0]', '"forward": [0, 1.0, 0.0]'),
]

RANDOM_FILES = ["model_core/thermal.py", "model_core/contact.py", "model_core/kinematics.py",
                "model_core/friction.py", "model_core/drag.py", "model_core/stiffness.py",
                "model_core/losses.py", "model_core/efficiency.py", "cyclo_fmu/io/checks.py",
                "cyclo_fmu/io/units.py", "cyclo_fmu/io/text.py", "cyclo_fmu/recordings.py",
                "cyclo_fmu/diagnosis/residual.py", "cyclo_fmu/diagnosis/selection.py"]

_SWAP_CMP = {ast.Lt: ast.LtE, ast.LtE: ast.Lt, ast.Gt: ast.GtE, ast.GtE: ast.Gt,
             ast.Eq: ast.NotEq, ast.NotEq: ast.Eq}
_SWAP_BIN = {ast.Add: ast.Sub, ast.Sub: ast.Add, ast.Mult: ast.Div, ast.Div: ast.Mult}


def _skip_nodes(tree) -> set:
    """Nodes inside f-strings and docstrings (messages, not behaviour)."""
    skip = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.JoinedStr):
            skip |= {id(n) for n in ast.walk(node)}
        if isinstance(node, (ast.Module, ast.FunctionDef, ast.ClassDef)) and node.body and \
                isinstance(node.body[0], ast.Expr) and isinstance(node.body[0].value,
                                                                   ast.Constant):
            skip.add(id(node.body[0].value))
    return skip


def candidates(tree):
    skip = _skip_nodes(tree)
    out = []
    for node in ast.walk(tree):
        if id(node) in skip:
            continue
        if isinstance(node, ast.Constant) and type(node.value) in (int, float) and \
                not isinstance(node.value, bool):
            out.append(("number", node))
        elif isinstance(node, ast.Compare) and type(node.ops[0]) in _SWAP_CMP:
            out.append(("compare", node))
        elif isinstance(node, ast.BinOp) and type(node.op) in _SWAP_BIN:
            out.append(("binop", node))
    return out


def mutate(source: str, index: int):
    """(description, mutated source) of the index-th candidate of ``source``."""
    tree = ast.parse(source)
    kind, node = candidates(tree)[index]
    line = node.lineno
    if kind == "number":
        old = node.value
        node.value = old + 1 if isinstance(old, int) else (old * 2 if old else 1.0)
        what = f"{old!r} -> {node.value!r}"
    elif kind == "compare":
        old = type(node.ops[0])
        node.ops[0] = _SWAP_CMP[old]()
        what = f"{old.__name__} -> {type(node.ops[0]).__name__}"
    else:
        old = type(node.op)
        node.op = _SWAP_BIN[old]()
        what = f"{old.__name__} -> {type(node.op).__name__}"
    return f"line {line}: {kind} {what}", ast.unparse(tree)


def run_tests(tree: Path, tests: list, timeout: float) -> tuple:
    env = dict(os.environ, PYTHONPATH=str(tree), HYPOTHESIS_PROFILE="ci")
    t0 = time.perf_counter()
    try:
        r = subprocess.run([sys.executable, "-m", "pytest", "-x", "-q", "-p", "no:cacheprovider",
                            *tests], cwd=tree, env=env, capture_output=True, text=True,
                           timeout=timeout)
        status = "survived" if r.returncode == 0 else "killed"
        if r.returncode not in (0, 1):        # collection/usage error: the mutant broke import
            status = "killed (error)"
    except subprocess.TimeoutExpired:
        status = "killed (timeout)"
    return status, time.perf_counter() - t0


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--random", type=int, default=24, help="random AST mutants (default 24)")
    ap.add_argument("--seed", type=int, default=21)
    ap.add_argument("--no-curated", action="store_true")
    ap.add_argument("--no-regression", action="store_true")
    ap.add_argument("--timeout", type=float, default=300.0)
    ap.add_argument("--select", action="append", default=[],
                    help="run only the mutants whose 'file: description' contains this text "
                         "(repeatable; the sample is drawn as without it)")
    ap.add_argument("--out", default=str(ROOT / "benchmarks" / "mutation_results.md"))
    args = ap.parse_args(argv)

    scratch = Path(tempfile.mkdtemp(prefix="cyclo-mutation-"))
    tree = scratch / "tree"
    shutil.copytree(ROOT, tree, ignore=shutil.ignore_patterns(
        ".git", "out", "dist", "__pycache__", "*.fmu", ".pytest_cache", ".hypothesis",
        "*.so", "*.egg-info", "build"))
    mutants = []
    if not args.no_curated:
        for name, path, old, new in CURATED:
            src = (ROOT / path).read_text()
            if src.count(old) != 1:
                print(f"curated mutant {name!r}: text not found once in {path}; skipped")
                continue
            mutants.append(("curated", path, name, src.replace(old, new)))
    if not args.no_regression:
        for name, path, old, new in REGRESSION:
            src = (ROOT / path).read_text()
            if src.count(old) != 1:
                print(f"regression mutant {name!r}: text not found once in {path}; skipped")
                continue
            mutants.append(("regression", path, name, src.replace(old, new)))
    rng = random.Random(args.seed)
    sizes = {p: len(candidates(ast.parse((ROOT / p).read_text()))) for p in RANDOM_FILES}
    picked = set()
    while len(picked) < args.random:      # a file at random, then a site in it (stratified:
        path = rng.choice(RANDOM_FILES)   # the large modules do not take the whole sample)
        picked.add((path, rng.randrange(sizes[path])))
    for path, i in sorted(picked):
        desc, src = mutate((ROOT / path).read_text(), i)
        mutants.append(("random", path, desc, src))

    if args.select:
        mutants = [m for m in mutants if any(t in f"{m[1]}: {m[2]}" for t in args.select)]
    rows = []
    try:
        for k, (kind, path, desc, src) in enumerate(mutants, 1):
            target = tree / path
            original = target.read_text()
            target.write_text(src)
            try:
                status, secs = run_tests(tree, tests_for(path), args.timeout)
            finally:
                target.write_text(original)
            rows.append((kind, path, desc, status, secs))
            print(f"[{k}/{len(mutants)}] {status:16} {secs:6.1f} s  {path}: {desc}", flush=True)
    finally:
        shutil.rmtree(scratch, ignore_errors=True)

    lines = ["| set | file | mutant | result | s |", "|---|---|---|---|---|"]
    lines += [f"| {a} | `{b}` | {c} | {d} | {e:.0f} |" for a, b, c, d, e in rows]
    for kind in ("curated", "regression", "random"):
        sub = [r for r in rows if r[0] == kind]
        if sub:
            killed = sum(r[3].startswith("killed") for r in sub)
            lines.append(f"\n{kind}: {killed} of {len(sub)} killed "
                         f"({100 * killed / len(sub):.0f} %)")
    killed = sum(r[3].startswith("killed") for r in rows)
    share = 100 * killed / max(1, len(rows))
    lines.append(f"\nall: {killed} of {len(rows)} killed ({share:.0f} %)")
    text = "\n".join(lines) + "\n"
    print(text)
    Path(args.out).write_text(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
