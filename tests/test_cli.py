"""Command line: JSON contract, errors as one line with non-zero exit."""
import json
import subprocess
import sys

import pytest

from model_core import DriveDesign, operating_point, rpm_to_rad_s


def run(*args):
    return subprocess.run([sys.executable, "-m", "cyclo_fmu.cli", *args], capture_output=True,
                          text=True, timeout=120)


def test_efficiency_json_contract():
    r = run("efficiency", "--mode", "S1", "--speed", "2800", "--torque", "0.8", "--json")
    assert r.returncode == 0, r.stderr
    out = json.loads(r.stdout)
    for key in ("eta", "eta0", "locked", "losses_W", "input_power_W", "output_speed_rpm",
                "output_torque_Nm"):
        assert key in out
    assert set(out["losses_W"]) == {"PL1", "PL2", "PL3", "PL5", "PL6"}
    op = operating_point(DriveDesign(), "S1", rpm_to_rad_s(2800), 0.8)
    assert out["eta"] == pytest.approx(float(op.eta), rel=1e-12)
    assert out["output_speed_rpm"] == pytest.approx(2800 / 15)
    assert out["input_power_W"] * out["eta"] == pytest.approx(
        out["output_torque_Nm"] * out["output_speed_rpm"] * 3.141592653589793 / 30, rel=1e-9)
    assert out["locked"] is False


def test_efficiency_text_mentions_losses():
    r = run("efficiency", "--mode", "s2", "--speed", "-1500", "--torque", "-0.5")
    assert r.returncode == 0, r.stderr
    assert "PL6" in r.stdout and "efficiency" in r.stdout


@pytest.mark.parametrize("args, word", [
    (("--mode", "S3", "--speed", "100", "--torque", "1"), "mode"),
    (("--mode", "S1", "--speed", "0", "--torque", "1"), "speed"),
    (("--mode", "S1", "--speed", "nan", "--torque", "1"), "speed"),
    (("--mode", "S1", "--speed", "100", "--torque", "abc"), "torque"),
])
def test_bad_input_one_line(args, word):
    r = run("efficiency", *args)
    assert r.returncode == 2, (r.returncode, r.stderr)
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and word in lines[0], r.stderr


def test_invalid_design_file(tmp_path):
    f = tmp_path / "bad.toml"
    f.write_text("[geometry]\nlam = 0.8\n")
    r = run("efficiency", "--mode", "S1", "--speed", "100", "--torque", "1", "--design", str(f))
    assert r.returncode == 2, (r.returncode, r.stderr)
    assert len(r.stderr.strip().splitlines()) == 1 and "lam" in r.stderr


def test_paper_json(tmp_path):
    r = run("paper", "--out", str(tmp_path), "--json")
    assert r.returncode == 0, r.stderr
    out = json.loads(r.stdout)
    # S1/S2: the paper profile (its theory); physical and the paper's experiment beside them
    assert set(out) == {"S1", "S2", "physical", "theory", "experiment", "experiment_gap"}
    assert 0.6425 <= out["S1"]["mean"] <= 0.6625
    assert set(out["physical"]) == {"S1", "S2"}
    assert out["experiment"]["S2"] == {"min": 0.5821, "mean": 0.6090, "max": 0.6300}
    assert {"k", "a", "inferred", "load_proportional_W"} <= set(out["experiment_gap"])
    assert (tmp_path / "efficiency_S1_S2.png").stat().st_size > 10000
    assert (tmp_path / "partial_losses.png").stat().st_size > 10000


def test_negative_scientific_torque_and_stall_message():
    r = run("efficiency", "--mode", "S1", "--speed", "1000", "--torque", "-1e-6", "--json")
    assert r.returncode == 0, r.stderr
    json.loads(r.stdout)   # valid JSON (no NaN literals)
    r = run("efficiency", "--mode", "S1", "--speed", "1000", "--torque", "1e-6")
    assert r.returncode == 0, r.stderr
    assert "stall" in r.stdout
    out = json.loads(run("efficiency", "--mode", "S1", "--speed", "1000", "--torque", "1e-6",
                         "--json").stdout)
    assert out["stalled"] is True and out["eta"] is None
