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
