"""Recording reader: schema, column mapping, unit conversion, exclusions and every refusal."""
import json
import subprocess
import sys

import numpy as np
import pytest

from cyclo_fmu.bench import write_recording
from cyclo_fmu.recordings import RecordingError, parse_column_map, read_recording


def sample(n=2000, rate=100.0):
    t = np.arange(n) / rate
    return {"time_s": t, "speed_in_rpm": 2800 + 0.5 * np.sin(t), "torque_in_Nm": 0.8 + 0 * t,
            "speed_out_rpm": 186.7 + 0 * t, "torque_out_Nm": 8.0 + 0 * t}


def write(tmp_path, rec, name="r.csv", header=None):
    p = write_recording(tmp_path / name, rec)
    if header:
        lines = p.read_text().splitlines()
        lines[0] = header
        p.write_text("\n".join(lines) + "\n")
    return p


def test_round_trip_and_units(tmp_path):
    r = read_recording(write(tmp_path, sample()))
    assert r.n == 2000 and r.duration == pytest.approx(19.99)
    assert r.sample_rate == pytest.approx(100.0)
    assert np.mean(r.speed_in) == pytest.approx(2800 * np.pi / 30, rel=1e-4)   # 293.2 rad/s
    assert r.exclusions == () and r.temperature is None


def test_column_mapping(tmp_path):
    p = write(tmp_path, sample(), header="t,n1,T22,n2,T30")
    cols = parse_column_map("time_s=t,speed_in_rpm=n1,torque_in_Nm=T22,speed_out_rpm=n2,torque_out_Nm=T30")
    assert read_recording(p, cols).n == 2000
    with pytest.raises(RecordingError, match="'t'|time_s"):
        read_recording(p)
    with pytest.raises(RecordingError, match="spped"):
        parse_column_map("spped_in_rpm=n1")


def test_missing_column_and_non_numeric(tmp_path):
    rec = sample()
    p = tmp_path / "bad.csv"
    p.write_text("time_s,speed_in_rpm,torque_in_Nm,speed_out_rpm\n0,1,2,3\n")
    with pytest.raises(RecordingError, match="torque_out_Nm"):
        read_recording(p)
    p = write(tmp_path, rec)
    lines = p.read_text().splitlines()
    lines[5] = lines[5].replace(lines[5].split(",")[2], "abc", 1)
    p.write_text("\n".join(lines))
    with pytest.raises(RecordingError, match="row 6.*abc|abc.*"):
        read_recording(p)


def test_nan_samples_are_excluded_and_listed(tmp_path):
    rec = sample()
    rec["torque_in_Nm"][100:105] = np.nan
    r = read_recording(write(tmp_path, rec))
    assert r.n == 1995
    (e,) = r.exclusions
    assert e.reason == "NaN in torque_in_Nm" and e.count == 5 and e.first_time == pytest.approx(1.0)
    rec["torque_in_Nm"][:600] = np.nan
    with pytest.raises(RecordingError, match="NaN"):
        read_recording(write(tmp_path, rec))


def test_time_backwards_or_repeated(tmp_path):
    rec = sample()
    rec["time_s"][50] = rec["time_s"][49]
    with pytest.raises(RecordingError, match="time_s"):
        read_recording(write(tmp_path, rec))


def test_units_that_look_wrong(tmp_path):
    rec = sample()
    rec["speed_in_rpm"] = rec["speed_in_rpm"] * np.pi / 30     # rad/s written as r/min
    with pytest.raises(RecordingError, match="rad/s"):
        read_recording(write(tmp_path, rec))
    rec = sample()
    rec["torque_in_Nm"] = rec["torque_in_Nm"] * 1000            # N*mm
    with pytest.raises(RecordingError, match="torque_in_Nm.*N\\*mm"):
        read_recording(write(tmp_path, rec))


def test_too_short_and_unreadable(tmp_path):
    with pytest.raises(RecordingError, match="too short"):
        read_recording(write(tmp_path, sample(n=300)))
    with pytest.raises(RecordingError, match="cannot be read"):
        read_recording(tmp_path / "nope.csv")


def run(*args):
    return subprocess.run([sys.executable, "-m", "cyclo_fmu.cli", *args], capture_output=True,
                          text=True, timeout=300)


def test_cli_synth_and_diagnose(tmp_path):
    rec, truth = tmp_path / "rec.csv", tmp_path / "truth.json"
    r = run("synth", "--effect", "torque_sensor_offset", "--seed", "2", "--mode", "S1",
            "--out", str(rec), "--truth", str(truth))
    assert r.returncode == 0, r.stderr
    assert "offset" not in rec.read_text()[:200]            # the truth stays out of the file
    r = run("diagnose", str(rec), "--mode", "S1", "--json", "--out", str(tmp_path / "d"))
    assert r.returncode == 0, r.stderr
    out = json.loads(r.stdout)
    for key in ("effect", "effect_description", "parameters", "evidence", "located",
                "rmse_before_Nm", "rmse_after_Nm", "zeta_d_before", "zeta_d_after"):
        assert key in out
    assert out["effect"] == json.loads(truth.read_text())["effect"] == "torque_sensor_offset"
    assert out["parameters"]["offset"]["unit"] == "N*m"
    assert len(out["evidence"]) == 8 and "statement" in out["located"]
    assert (tmp_path / "d" / "design_updated.toml").exists()
    bad = tmp_path / "bad.csv"
    bad.write_text("time_s,speed_in_rpm\n0,1\n")
    r = run("diagnose", str(bad), "--mode", "S1")
    assert r.returncode == 2 and len(r.stderr.strip().splitlines()) == 1
    assert "torque_in_Nm" in r.stderr
    r = run("synth", "--effect", "gremlins", "--out", str(tmp_path / "x.csv"))
    assert r.returncode == 2 and "effect" in r.stderr
