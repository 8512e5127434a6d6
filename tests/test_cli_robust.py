"""Every subcommand answers each class of bad input with one line on stderr naming the field,
exit status 2, and leaves nothing behind (issue 9, item 4; issue 10, bad input in diagnose and
synth). Each case must fail before any expensive work, so the matrix stays quick.

A new subcommand joins the matrix by one entry in ``OUTPUT_COMMANDS`` (if it writes files)
and/or ``DESIGN_COMMANDS`` / ``SEED_COMMANDS``; ``test_every_output_option_is_covered`` fails
until it is listed.
"""
from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from cyclo_fmu.cli import build_parser

ROOT = Path(__file__).resolve().parents[1]

# name: (argv before the output option, output option, "dir" or "file")
OUTPUT_COMMANDS = {
    "paper": (["paper"], "--out", "dir"),
    "build": (["build"], "--dest", "dir"),
    "bench": (["bench", "--mode", "S1"], "--out", "dir"),
    "synth": (["synth", "--effect", "none", "--size", "tiny"], "--out", "file"),
    "diagnose": (["diagnose", "missing-recording.csv", "--mode", "S1"], "--out", "dir"),
    "sweep": (["sweep", "{spec}"], "--out", "file"),
    "diagnose-batch": (["diagnose-batch", "{recdir}", "--mode", "S1"], "--out", "dir"),
    "export-modelica": (["export-modelica", "--mode", "S1"], "--out", "dir"),
    "stiffness": (["stiffness"], "--out", "dir"),
    "verify": (["verify", "missing-recording.csv", "--mode", "S1"], "--out", "dir"),
}

# name: argv that takes ``--design`` and would otherwise run
DESIGN_COMMANDS = {
    "efficiency": ["efficiency", "--mode", "S1", "--speed", "1000", "--torque", "2"],
    "paper": ["paper", "--out", "{tmp}/paper_out"],
    "bench": ["bench", "--mode", "S1", "--out", "{tmp}/bench_out"],
    "diagnose": ["diagnose", "missing-recording.csv", "--mode", "S1"],
    "diagnose-batch": ["diagnose-batch", "{recdir}", "--mode", "S1", "--out", "{tmp}/batch"],
    "build": ["build", "--dest", "{tmp}/build_out", "CycloidDriveNative"],
    "export-modelica": ["export-modelica", "--mode", "S1", "--out", "{tmp}/mo_out"],
    "stiffness": ["stiffness"],
    "verify": ["verify", "missing-recording.csv", "--mode", "S1"],
}

SEED_COMMANDS = {
    "synth": ["synth", "--effect", "none", "--size", "tiny", "--out", "{tmp}/rec.csv"],
    "bench": ["bench", "--mode", "S1", "--out", "{tmp}/bench_out"],
}

BAD_DESIGNS = {
    "binary": b"\x7fELF\x02\x01\x01\x00\xd0\xff\xfe" * 20,
    "wrong_type": b'[geometry]\nz1 = "fifteen"\n',
    "drive_cannot_run": b"[friction]\nmu_boundary = 5\n",
    "z1_exhausts_memory": b"[geometry]\nz1 = 100000\n",
    "n_positions_exhausts_memory": b"[geometry]\nn_positions = 100000000\n",
    "not_toml": b"z1 = = 3\n",
}

SPEC = """[sweep]
method = "grid"
[fields]
lam = [1.6, 2.0, 2]
"""


def _commands():
    sub = next(a for a in build_parser()._actions if a.choices and isinstance(a.choices, dict))
    return sub.choices


def _run(argv, cwd):
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    return subprocess.run([sys.executable, "-m", "cyclo_fmu.cli", *argv], cwd=cwd, env=env,
                          capture_output=True, text=True, timeout=120)


def _tree(path):
    return sorted(str(p.relative_to(path)) for p in Path(path).rglob("*"))


def _assert_one_line(r, *names):
    assert r.returncode == 2, (r.returncode, r.stdout, r.stderr)
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1, r.stderr
    assert "Traceback" not in r.stderr
    for n in names:
        assert n in lines[0], (n, lines[0])


def _fill(argv, tmp):
    spec = tmp / "spec.toml"
    spec.write_text(SPEC)
    recdir = tmp / "recordings"
    recdir.mkdir(exist_ok=True)
    (recdir / "r.csv").write_text("time_s\n0\n")
    return [a.format(tmp=tmp, spec=spec, recdir=recdir) for a in argv]


def test_every_output_option_is_covered():
    for name, parser in _commands().items():
        opts = {o for a in parser._actions for o in a.option_strings}
        if opts & {"--out", "--dest"}:
            assert name in OUTPUT_COMMANDS, f"list {name} in OUTPUT_COMMANDS"
        if "--design" in opts:
            assert name in DESIGN_COMMANDS, f"list {name} in DESIGN_COMMANDS"
        if "--seed" in opts:
            assert name in SEED_COMMANDS, f"list {name} in SEED_COMMANDS"


# bad-output classes per kind of option: an output folder is created with its missing parents
# (documented), an existing output file is replaced at the end (atomically)
OUTPUT_CASES = {"dir": ("is_file", "under_file", "unwritable"),
                "file": ("under_file", "missing_parent", "unwritable", "is_folder")}


def _output_cases():
    for name, (_, _, kind) in OUTPUT_COMMANDS.items():
        for case in OUTPUT_CASES[kind]:
            yield name, case


@pytest.mark.parametrize("name,case", list(_output_cases()))
def test_bad_output(tmp_path, name, case):
    if name not in _commands():
        pytest.skip(f"{name} is not on this branch")
    argv, opt, kind = OUTPUT_COMMANDS[name]
    argv = _fill(argv, tmp_path)
    (tmp_path / "a_file").write_text("keep me")
    if case == "is_file":
        target = tmp_path / "a_file"
    elif case == "under_file":
        target = tmp_path / "a_file" / "sub"
    elif case == "missing_parent":
        target = tmp_path / "missing" / "out.x"
    elif case == "unwritable":
        target = Path("/proc/cyclo-fmu-test/out")        # not writable even for root
    else:   # a folder where a file is expected
        (tmp_path / "a_folder").mkdir()
        target = tmp_path / "a_folder"
    before = _tree(tmp_path)
    r = _run([*argv, opt, str(target)], tmp_path)
    _assert_one_line(r, str(target) if case != "unwritable" else "/proc/cyclo-fmu-test")
    assert _tree(tmp_path) == before
    assert (tmp_path / "a_file").read_text() == "keep me"


@pytest.mark.parametrize("name", list(DESIGN_COMMANDS))
@pytest.mark.parametrize("case", list(BAD_DESIGNS))
def test_bad_design(tmp_path, name, case):
    if name not in _commands():
        pytest.skip(f"{name} is not on this branch")
    design = tmp_path / "design.toml"
    design.write_bytes(BAD_DESIGNS[case])
    argv = _fill(DESIGN_COMMANDS[name], tmp_path)
    before = _tree(tmp_path)
    r = _run([*argv, "--design", str(design)], tmp_path)
    field = {"binary": "design file", "wrong_type": "z1", "drive_cannot_run": "mu_boundary",
             "z1_exhausts_memory": "z1", "n_positions_exhausts_memory": "n_positions",
             "not_toml": "design file"}[case]
    _assert_one_line(r, field)
    assert _tree(tmp_path) == before


@pytest.mark.parametrize("name", list(SEED_COMMANDS))
def test_negative_seed(tmp_path, name):
    if name not in _commands():
        pytest.skip(f"{name} is not on this branch")
    argv = _fill(SEED_COMMANDS[name], tmp_path)
    before = _tree(tmp_path)
    r = _run([*argv, "--seed=-5"], tmp_path)
    _assert_one_line(r, "seed", "-5")
    assert _tree(tmp_path) == before


@pytest.mark.parametrize("mode", ["12", "1S", "21", "X3"])
def test_bench_mode_checked_before_the_fmus_run(tmp_path, mode):
    r = _run(["bench", "--mode", mode, "--out", str(tmp_path / "b")], tmp_path)
    _assert_one_line(r, "mode", mode)
    assert not (tmp_path / "b").exists()


def test_export_modelica_mode_checked(tmp_path):
    r = _run(["export-modelica", "--mode", "X3", "--out", str(tmp_path / "m")], tmp_path)
    _assert_one_line(r, "mode", "X3")
    assert not (tmp_path / "m").exists()


@pytest.mark.parametrize("torque,words", [("0", "no power flows"), ("1e30", "rating"),
                                          ("-1e30", "rating")])
def test_impossible_operating_points(tmp_path, torque, words):
    r = _run(["efficiency", "--mode", "S1", "--speed", "1000", f"--torque={torque}"], tmp_path)
    _assert_one_line(r, "torque", words)


def test_rated_torque_still_answers(tmp_path):
    r = _run(["efficiency", "--mode", "S1", "--speed", "1000", "--torque", "2"], tmp_path)
    assert r.returncode == 0 and "efficiency eta" in r.stdout and "nan" not in r.stdout


def test_staged_file_leaves_nothing_on_failure(tmp_path):
    from cyclo_fmu.cli import _staged_file
    target = tmp_path / "out.csv"
    with pytest.raises(RuntimeError):
        with _staged_file("out", target) as tmp:
            tmp.write_text("half")
            raise RuntimeError("mid-way")
    assert _tree(tmp_path) == []


def test_staged_dir_removes_what_it_created(tmp_path):
    from cyclo_fmu.cli import _staged_dir
    (tmp_path / "old").mkdir()
    (tmp_path / "old" / "kept.txt").write_text("x")
    with pytest.raises(RuntimeError):
        with _staged_dir("out", tmp_path / "new" / "deep") as d:
            (d / "half.json").write_text("{")
            raise RuntimeError("mid-way")
    with pytest.raises(RuntimeError):
        with _staged_dir("out", tmp_path / "old") as d:
            (d / "half.json").write_text("{")
            raise RuntimeError("mid-way")
    assert _tree(tmp_path) == ["old", "old/kept.txt"]


FMU_FAILS = """
import sys
from cyclo_fmu import cli

def failing(args):          # stands in for any FMU-running command
    from fmpy import extract, read_model_description
    from fmpy.fmi2 import FMU2Slave
    md = read_model_description(sys.argv[1])
    var = {v.name: v.valueReference for v in md.modelVariables}
    f = FMU2Slave(guid=md.guid, unzipDirectory=extract(sys.argv[1]),
                  modelIdentifier=md.coSimulation.modelIdentifier, instanceName="drive")
    f.instantiate()
    f.setupExperiment(startTime=0.0)
    f.enterInitializationMode()
    f.exitInitializationMode()
    f.setReal([var["w_in"], var["tau_out"]], [100.0, float("inf")])
    f.doStep(0.0, 1e-3)

cli.cmd_bench = failing
sys.exit(cli.main(["bench", "--mode", "S1", "--out", sys.argv[2]]))
"""


def test_fmu_error_surfaces_its_logged_message(tmp_path, fmu):
    """An FMU that fails ends in one line carrying the FMU's own logged message."""
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    r = subprocess.run([sys.executable, "-c", FMU_FAILS, fmu, str(tmp_path / "o")],
                       cwd=tmp_path, env=env, capture_output=True, text=True, timeout=120)
    _assert_one_line(r, "FMU failed", "tau_out = inf")
    assert not (tmp_path / "o").exists()


def test_closed_stdout_stops_quietly():
    """`cyclo-fmu paper | head -1`: the reader leaves, the command stops without an error line
    (a broken pipe is an OSError, which the CLI otherwise reports as a path it could not
    write)."""
    r, w = os.pipe()
    os.close(r)                      # the reader has gone before the first write
    try:
        proc = subprocess.run([sys.executable, "-m", "cyclo_fmu.cli", "paper"], stdout=w,
                              stderr=subprocess.PIPE, text=True, timeout=120)
    finally:
        os.close(w)
    assert proc.returncode == 0, proc.stderr
    assert "error" not in proc.stderr.lower(), proc.stderr


# ---- issue 21: the audit's tracebacks, silent accepts and wrong messages ---------------------
# Each case: one line on stderr naming the field the user set, exit exactly 2, nothing written
# and nothing of the user's changed.

def _model_csv(path, rows=3000, torque_unit="N*m"):
    """An S1 recording (100 Hz) whose input torque is the default design's own for the
    recorded output torque and speed: plausible in every check, > 64 KiB of text."""
    import numpy as np
    from model_core import DriveDesign, operating_point, rpm_to_rad_s
    t = np.arange(rows) / 100.0
    n_in = 1500 + 500 * np.sin(t / 5)
    T_out = 6 + 3 * np.sin(t / 3)
    op = operating_point(DriveDesign(), "S1", rpm_to_rad_s(n_in), T_out=-T_out)
    T_in = np.asarray(op.torques["S"], float)
    lines = ["time_s,speed_in_rpm,torque_in_Nm,speed_out_rpm,torque_out_Nm"]
    lines += [f"{a:.3f},{b:.4f},{c:.6f},{d:.5f},{e:.5f}"
              for a, b, c, d, e in zip(t, n_in, T_in, n_in / 15, T_out)]
    path.write_text("\n".join(lines) + "\n")
    return path


def _spec(tmp, text, name="spec.toml"):
    p = tmp / name
    p.write_text(text)
    return str(p)


def _design(tmp, text):
    p = tmp / "design.toml"
    p.write_text(text)
    return str(p)


def _bytes_after_64k(tmp):
    raw = _model_csv(tmp / "base.csv").read_bytes()
    (tmp / "base.csv").unlink()
    i = raw.index(b"\n", 70000)
    p = tmp / "bad_utf8.csv"
    p.write_bytes(raw[:i] + b"\n1.0\xff\xfe,2,3,4,5" + raw[i:])
    return str(p)


def _huge_cell(tmp):
    raw = _model_csv(tmp / "base.csv").read_bytes()
    (tmp / "base.csv").unlink()
    i = raw.index(b"\n", 70000)
    p = tmp / "huge_cell.csv"
    p.write_bytes(raw[:i] + b"\n" + b"7" * 20_000_000 + b"x,1,2,3,4" + raw[i:])
    return str(p)


def _no_newline(tmp):
    p = tmp / "one_line.csv"
    with open(p, "wb") as f:
        for _ in range(50):
            f.write(b"1;" * 500_000)
    return str(p)


ENVELOPE_SPEC = "[envelope]\n{}\n[fields]\nlam = [1.6, 2.0, 2]\n"

# name: (argv builder (tmp -> argv), words the line must hold, words it must not hold)
ISSUE21 = {
    "diagnose_invalid_utf8_after_64k": (
        lambda t: ["diagnose", _bytes_after_64k(t), "--mode", "S1"],
        ["recording", "row ", "not utf-8", "1.0"], ["Traceback"]),
    "efficiency_speed_1e308": (
        lambda t: ["efficiency", "--mode", "S1", "--speed", "1e308", "--torque", "1"],
        ["speed = 1e+308", "r/min"], []),
    "stiffness_rated_1e308": (
        lambda t: ["stiffness", "--rated-torque", "1e308"],
        ["rated-torque = 1e+308", "static rating"], []),
    "sweep_envelope_1e300_rpm": (
        lambda t: ["sweep", _spec(t, ENVELOPE_SPEC.format("speed_max_rpm = 1e300")), "--out",
                   str(t / "o.parquet"), "--serial"],
        ["envelope.speed_max_rpm = 1e+300"], []),
    "sweep_n_speed_fraction": (
        lambda t: ["sweep", _spec(t, ENVELOPE_SPEC.format("n_speed = 1.5")), "--out",
                   str(t / "o.parquet"), "--serial"],
        ["envelope.n_speed = 1.5", "whole number"], []),
    "sweep_base_number": (
        lambda t: ["sweep", _spec(t, "[sweep]\nbase = 5\n[fields]\nlam = [1.6, 2.0, 2]\n"),
                   "--out", str(t / "o.parquet"), "--serial"],
        ["sweep.base = 5"], []),
    "sweep_table_number": (
        lambda t: ["sweep", _spec(t, '[sweep]\nmethod = "table"\ntable = 7\n'), "--out",
                   str(t / "o.parquet"), "--serial"],
        ["sweep.table = 7"], []),
    "sweep_section_number": (
        lambda t: ["sweep", _spec(t, "sweep = 5\n[fields]\nlam = [1.6, 2.0, 2]\n"), "--out",
                   str(t / "o.parquet"), "--serial"],
        ["sweep = 5", "table"], []),
    "sweep_fields_number": (
        lambda t: ["sweep", _spec(t, "fields = 3\n"), "--out", str(t / "o.parquet"),
                   "--serial"],
        ["fields = 3", "table"], []),
    "efficiency_torque_1e308": (
        lambda t: ["efficiency", "--mode", "S1", "--speed", "1000", "--torque", "1e308"],
        ["torque = 1e+308", "static rating"], ["stall"]),
    "diagnose_N_mm_given_on_N_m_data": (
        lambda t: ["diagnose", str(_model_csv(t / "r.csv")), "--mode", "S1", "--units",
                   "torque_in_Nm=N*mm,torque_out_Nm=N*mm"],
        ["torque_in_Nm", "times what the design needs", "--units"], ["mismatch"]),
    "design_drag_1e6": (
        lambda t: ["efficiency", "--mode", "S1", "--speed", "1000", "--torque", "1",
                   "--design", _design(t, "[extra]\ndrag_torque = 1e6\n")],
        ["[extra].drag_torque = 1000000.0", "could not turn"], ["mu_boundary", "torque = 1.0"]),
    "efficiency_speed_1e-300": (
        lambda t: ["efficiency", "--mode", "S1", "--speed", "1e-300", "--torque", "1"],
        ["speed = 1e-300", "stands still"], []),
    "stiffness_rated_1e-300": (
        lambda t: ["stiffness", "--rated-torque", "1e-300"],
        ["rated-torque = 1e-300", "static rating", "clearances alone"], []),
    "sweep_envelope_torque_zero": (
        lambda t: ["sweep", _spec(t, ENVELOPE_SPEC.format("torque_min = 0\ntorque_max = 0")),
                   "--out", str(t / "o.parquet"), "--serial"],
        ["envelope.torque_min = 0", "no power flows"], []),
    "design_negative_viscosity": (
        lambda t: ["efficiency", "--mode", "S1", "--speed", "1000", "--torque", "1",
                   "--design", _design(t, "[lubricant]\nkinematic_viscosity_mm2_s = -5\n")],
        ["[lubricant].kinematic_viscosity_mm2_s = -5.0", "positive"],
        ["kinematic_viscosity_100"]),
    "design_temperature_minus_300": (
        lambda t: ["efficiency", "--mode", "S1", "--speed", "1000", "--torque", "1",
                   "--design", _design(t, "[model]\noperating_temperature_degC = -300\n")],
        ["operating_temperature_degC = -300.0", "between -100 and 200 degC"], ["-26.85"]),
    "efficiency_speed_1e9": (
        lambda t: ["efficiency", "--mode", "S1", "--speed", "1e9", "--torque", "1"],
        ["speed = 1000000000.0"], ["torque"]),
    "efficiency_grease_at_minus_99": (
        lambda t: ["efficiency", "--mode", "S1", "--speed", "1000", "--torque", "1",
                   "--temperature", "-99"],
        ["temperature = -99.0", "no-load running torque"], ["torque = 1.0"]),
    "efficiency_heat_balance_beyond_200": (
        # 30 N*m at 1000 r/min: 450 N*m on the ring, within its static rating (962 N*m), and
        # about 3 kW of input the housing cannot shed below 200 degC at 20 degC ambient
        lambda t: ["efficiency", "--mode", "S1", "--speed", "1000", "--torque", "30",
                   "--ambient", "20"],
        ["torque = 30.0", "heat balance"], ["473.15", "operating_temperature"]),
    "diagnose_20_MB_cell": (
        lambda t: ["diagnose", _huge_cell(t), "--mode", "S1"],
        ["20000001 characters", "is not a number"], []),
    "diagnose_50_MB_without_newline": (
        lambda t: ["diagnose", _no_newline(t), "--mode", "S1"],
        ["no line break"], ["empty"]),
    "diagnose_empty_file_path_once": (
        lambda t: ["diagnose", str((t / "empty.csv").absolute()), "--mode", "S1"],
        ["recording = ", "is empty"], []),
}


@pytest.mark.parametrize("name", list(ISSUE21))
def test_issue21_matrix(tmp_path, name):
    build, words, absent = ISSUE21[name]
    (tmp_path / "empty.csv").write_text("")
    argv = build(tmp_path)
    before = {p: p.stat().st_mtime_ns for p in tmp_path.rglob("*")}
    r = _run(argv, tmp_path)
    _assert_one_line(r, *words)
    line = r.stderr.strip()
    assert len(line) <= 700, len(line)
    for w in absent:
        assert w not in line, (w, line)
    assert {p: p.stat().st_mtime_ns for p in tmp_path.rglob("*")} == before
    if name == "diagnose_empty_file_path_once":
        assert line.count("empty.csv") == 1, line


def test_synth_truth_onto_its_recording_is_refused(tmp_path):
    """--truth naming --out would write the truth over the recording: refused before any
    work, the user's existing file untouched."""
    (tmp_path / "r.csv").write_text("keep me")
    for truth in ("r.csv", "./r.csv", str(tmp_path / "r.csv")):
        r = _run(["synth", "--effect", "none", "--size", "tiny", "--out", "r.csv", "--truth",
                  truth], tmp_path)
        _assert_one_line(r, "truth", "overwrite the recording")
        assert (tmp_path / "r.csv").read_text() == "keep me"
        assert _tree(tmp_path) == ["r.csv"]


def test_diagnose_batch_reports_every_file_and_fails_when_one_fails(tmp_path):
    """--mode auto and --units are taken; a failed file makes the exit status 1 (partial
    results written, summary.csv lists every file with its reason); stdout a per-file line."""
    import csv
    rec = tmp_path / "recs"
    rec.mkdir()
    _model_csv(rec / "good.csv", rows=2000)
    (rec / "bad.csv").write_text("x\n")
    r = _run(["diagnose-batch", str(rec), "--mode", "auto", "--units", "time_s=s", "--out",
              str(tmp_path / "out"), "--serial"], tmp_path)
    assert r.returncode == 1, (r.stdout, r.stderr)
    assert "1 diagnosed, 1 failed" in r.stdout
    assert "good.csv: " in r.stdout and "(mode S1)" in r.stdout
    assert "bad.csv: failed: " in r.stdout
    assert len(r.stderr.strip().splitlines()) == 1 and "1 of 2 recordings" in r.stderr
    rows = {row["recording"]: row for row in csv.DictReader(open(tmp_path / "out" /
                                                                 "summary.csv"))}
    assert rows["good.csv"]["error"] == "" and rows["good.csv"]["mode"] == "S1"
    assert rows["bad.csv"]["error"] != ""


def test_diagnose_batch_bad_units_one_line(tmp_path):
    rec = tmp_path / "recs"
    rec.mkdir()
    (rec / "r.csv").write_text("time_s\n0\n")
    r = _run(["diagnose-batch", str(rec), "--mode", "auto", "--units", "torque_in_Nm=furlong",
              "--out", str(tmp_path / "out"), "--serial"], tmp_path)
    _assert_one_line(r, "units", "furlong")
    assert not (tmp_path / "out").exists()


def test_internal_temporary_names_are_not_shown():
    from cyclo_fmu.cli import _user_path
    assert _user_path("/x/.out.parquet.partial-1234.parquet") == "/x/out.parquet"
    assert _user_path("/d/.CycloidDriveNative.fmu.partial-77") == "/d/CycloidDriveNative.fmu"
    assert _user_path("/d/plain.csv") == "/d/plain.csv"


INTERRUPT = """
import os, signal, sys, time
from pathlib import Path
from cyclo_fmu import cli
SIG = getattr(signal, sys.argv[2])

def slow(args):          # stands in for bench: writes into its staged folder, then is stopped
    with cli._staged_dir("out", args.out) as out:
        (out / "TestBench.ssp").write_text("half")
        (out / "fmus").mkdir()
        os.kill(os.getpid(), SIG)
        time.sleep(30)
    return 0

cli.cmd_bench = slow
sys.argv = ["cyclo-fmu", "bench", "--mode", "S1", "--out", sys.argv[1]]
cli.run()
"""


@pytest.mark.parametrize("sig,code", [("SIGINT", 130), ("SIGTERM", 143)])
def test_interrupt_says_interrupted_and_removes_partial_outputs(tmp_path, sig, code):
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    (tmp_path / "keep").write_text("mine")
    r = subprocess.run([sys.executable, "-c", INTERRUPT, str(tmp_path / "b"), sig],
                       cwd=tmp_path, env=env, capture_output=True, text=True, timeout=120)
    assert r.returncode == code, (r.returncode, r.stderr)
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and "interrupted" in lines[0] and sig in lines[0], r.stderr
    assert "Traceback" not in r.stderr and "FMU failed" not in r.stderr
    assert _tree(tmp_path) == ["keep"]


@pytest.mark.slow
@pytest.mark.parametrize("sig", ["SIGINT", "SIGTERM"])
def test_real_bench_interrupted(tmp_path, sig):
    """The real bench, stopped while its FMUs run (a signal inside a slave's Python code: the
    Python FMUs, ``--fmus python``; the native set runs the 48 s paper series in under half a
    second after the SSP is written, so a signal sent then finds the bench done)."""
    import signal
    import time
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    p = subprocess.Popen([sys.executable, "-m", "cyclo_fmu.cli", "bench", "--mode", "S1",
                          "--out", str(tmp_path / "b"), "--quiet", "--fmus", "python"],
                         cwd=tmp_path, env=env,
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    while not (tmp_path / "b" / "TestBench.ssp").exists() and p.poll() is None:
        time.sleep(0.05)
    time.sleep(0.5)
    p.send_signal(getattr(signal, sig))
    out, err = p.communicate(timeout=120)
    assert p.returncode == 128 + getattr(signal, sig), (p.returncode, err)
    assert "interrupted" in err and "FMU failed" not in err
    assert not (tmp_path / "b").exists()


def test_help_texts():
    """Every option has a help text; bench --mode offers only what it accepts; diagnose says
    it reads MDF4."""
    for name, parser in _commands().items():
        for a in parser._actions:
            if a.dest != "help":
                assert a.help, (name, a.option_strings or a.dest)
    bench = _commands()["bench"]
    mode_help = next(a.help for a in bench._actions if "--mode" in a.option_strings)
    assert "S1 or S2" in mode_help and "..." not in mode_help
    dg = _commands()["diagnose"]
    assert "MDF4" in next(a.help for a in dg._actions if a.dest == "recording")


def test_output_file_that_is_a_pipe_is_refused_and_kept(tmp_path):
    """An output path naming a FIFO (or a device such as /dev/full) is refused: the staged
    write would have replaced it with a plain file."""
    fifo = tmp_path / "fifo"
    os.mkfifo(fifo)
    r = _run(["synth", "--effect", "none", "--size", "tiny", "--out", str(fifo)], tmp_path)
    _assert_one_line(r, "out", "not a regular file")
    assert fifo.is_fifo()


def test_units_for_an_absent_column_are_refused(tmp_path):
    path = _model_csv(tmp_path / "r.csv", rows=800)
    r = _run(["diagnose", str(path), "--mode", "S1", "--units", "temperature_C=degF"], tmp_path)
    _assert_one_line(r, "temperature_C=degF", "does not have")
