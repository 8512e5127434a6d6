"""Recording reader: schema, column mapping, unit conversion, exclusions and every refusal."""
import json
import math
import subprocess
import sys

import numpy as np
import pytest

from model_core.effects import DEFAULT_CANDIDATES
from cyclo_fmu.bench import RECORDING_COLUMNS, write_recording
from cyclo_fmu.recordings import (Exclusion, Recording, RecordingError, parse_column_map,
                                  read_recording, recording_from_arrays)


def sample(n=2000, rate=100.0, seed=0):
    """Plausible S1 data: 2800 r/min in with a little noise, 0.8 N*m in, 8 N*m out."""
    t = np.arange(n) / rate
    noise = np.random.default_rng(seed).normal(0, 0.5, n)
    return {"time_s": t, "speed_in_rpm": 2800 + noise, "torque_in_Nm": np.full(n, 0.8),
            "speed_out_rpm": np.full(n, 186.7), "torque_out_Nm": np.full(n, 8.0)}


def write(tmp_path, rec, name="r.csv", header=None):
    p = write_recording(tmp_path / name, rec)
    if header:
        lines = p.read_text().splitlines()
        lines[0] = header
        p.write_text("\n".join(lines) + "\n")
    return p


def edit_cell(path, line, column, text):
    """Replace one cell; ``line`` counts file lines from 1 (the header)."""
    lines = path.read_text().splitlines()
    cells = lines[line - 1].split(",")
    cells[column] = text
    lines[line - 1] = ",".join(cells)
    path.write_text("\n".join(lines) + "\n")
    return path


# --- what a good recording gives -----------------------------------------------------------

def test_round_trip_with_bench_writer(tmp_path):
    rec = sample()
    r = read_recording(write(tmp_path, rec))
    assert isinstance(r, Recording) and r.source.endswith("r.csv")
    assert r.n == 2000 and r.duration == pytest.approx(19.99)
    assert r.sample_rate == pytest.approx(100.0)
    assert r.exclusions == () and r.temperature is None
    np.testing.assert_allclose(r.time, rec["time_s"], atol=1e-6)
    np.testing.assert_allclose(r.speed_in, rec["speed_in_rpm"] * math.pi / 30, rtol=1e-5)
    np.testing.assert_allclose(r.torque_out, 8.0)


def test_rpm_converted_to_rad_s_once(tmp_path):
    rec = sample()
    rec["speed_in_rpm"] = np.full(2000, 2800.0)
    r = read_recording(write(tmp_path, rec))
    assert r.speed_in[0] == pytest.approx(293.215, abs=1e-3)
    assert r.speed_out[0] == pytest.approx(186.7 * math.pi / 30)
    assert r.torque_in[0] == 0.8                                   # torques stay N*m


def test_from_arrays_and_optional_temperature(tmp_path):
    rec = sample()
    r = recording_from_arrays(*(rec[c] for c in RECORDING_COLUMNS), temperature_C=np.full(2000, 41.5))
    assert r.source == "<array>" and r.n == 2000 and r.temperature[0] == 41.5
    p = tmp_path / "temp.csv"
    p.write_text("time_s,speed_in_rpm,torque_in_Nm,speed_out_rpm,torque_out_Nm,temperature_C\n"
                 + "".join(f"{k / 50},2800,0.8,186.7,8.0,{40 + k / 1000}\n" for k in range(300)))
    r = read_recording(p)
    assert r.temperature[-1] == pytest.approx(40.299) and r.sample_rate == pytest.approx(50.0)


def test_non_uniform_sampling_uses_median(tmp_path):
    rec = sample()
    rec["time_s"] = rec["time_s"].copy()
    rec["time_s"][1000:] += 0.005                                  # one longer step
    r = read_recording(write(tmp_path, rec))
    assert r.sample_rate == pytest.approx(100.0) and r.exclusions == ()


def test_column_mapping_and_extra_columns(tmp_path):
    p = tmp_path / "other.csv"
    p.write_text("Time,n1,T22,n2,T30,comment\n"
                 + "".join(f"{k / 100},2800,0.8,186.7,8.0,ok\n" for k in range(600)))
    cols = parse_column_map("time_s=Time, speed_in_rpm=n1,torque_in_Nm=T22,"
                            "speed_out_rpm=n2,torque_out_Nm=T30")
    assert cols == {"time_s": "Time", "speed_in_rpm": "n1", "torque_in_Nm": "T22",
                    "speed_out_rpm": "n2", "torque_out_Nm": "T30"}
    r = read_recording(p, cols)
    assert r.n == 600 and r.exclusions == ()                       # 'comment' is ignored
    # 'Time' is recognised as time_s by name (and reported); n1, T22 are not names we guess
    with pytest.raises(RecordingError, match="'speed_in_rpm' is missing; found: Time, n1"):
        read_recording(p)
    with pytest.raises(RecordingError, match=r"'T23' \(torque_in_Nm\) is missing"):
        read_recording(p, dict(cols, torque_in_Nm="T23"))
    with pytest.raises(RecordingError, match="'torqe_in_Nm' is not a recording column"):
        read_recording(p, {"torqe_in_Nm": "T22"})


@pytest.mark.parametrize("text, word", [("spped_in_rpm=n1", "spped_in_rpm"),
                                        ("time_s", "time_s"), ("time_s=", "time_s="),
                                        ("time_s=t,time_s=u", "mapped twice")])
def test_column_map_syntax(text, word):
    with pytest.raises(RecordingError, match=word):
        parse_column_map(text)


# --- exclusions ------------------------------------------------------------------------------

def test_isolated_nan_samples_are_excluded_and_listed(tmp_path):
    rec = sample()
    rec["torque_in_Nm"][[100, 101, 102, 500, 501]] = np.nan
    rec["speed_out_rpm"][[101, 700]] = np.nan        # 101 already excluded under torque_in_Nm
    r = read_recording(write(tmp_path, rec))
    assert r.n == 1994
    assert r.exclusions == (Exclusion("NaN in torque_in_Nm", 5, pytest.approx(1.0)),
                            Exclusion("NaN in speed_out_rpm", 1, pytest.approx(7.0)))
    assert not np.isnan(r.torque_in).any() and 1.0 not in r.time


def test_empty_cells_and_long_nan_runs_are_excluded(tmp_path):
    p = write(tmp_path, sample())
    edit_cell(p, 12, 4, "")                                        # sample 10, t = 0.10 s
    rec = sample()
    rec["speed_in_rpm"][300:350] = np.nan                          # a run of 50 (2.5 %)
    r = read_recording(edit_cell(write(tmp_path, rec, "b.csv"), 12, 4, ""))
    assert r.n == 1949
    assert [(e.reason, e.count) for e in r.exclusions] == [("NaN in speed_in_rpm", 50),
                                                           ("NaN in torque_out_Nm", 1)]
    assert r.exclusions[0].first_time == pytest.approx(3.0)
    assert read_recording(p).exclusions[0].first_time == pytest.approx(0.1)


def test_nan_in_time_is_excluded_with_unknown_first_time(tmp_path):
    rec = sample()
    rec["time_s"][[40, 41]] = np.nan
    r = read_recording(write(tmp_path, rec))
    (e,) = r.exclusions
    assert e.reason == "NaN in time_s" and e.count == 2 and math.isnan(e.first_time)


def test_too_many_nan_samples(tmp_path):
    rec = sample()
    rec["torque_in_Nm"][:401] = np.nan                             # 20.05 %
    with pytest.raises(RecordingError, match="401 of 2000 .* 401 in torque_in_Nm"):
        read_recording(write(tmp_path, rec))
    rec["torque_in_Nm"][400] = 0.8                                 # exactly 20 %: allowed
    assert read_recording(write(tmp_path, rec)).n == 1600


# --- refusals --------------------------------------------------------------------------------

def test_missing_or_unreadable_file(tmp_path):
    with pytest.raises(RecordingError, match="nope.csv.*cannot be read"):
        read_recording(tmp_path / "nope.csv")
    with pytest.raises(RecordingError, match="cannot be read"):
        read_recording(tmp_path)                                   # a folder


def test_empty_file_header_only_and_no_header(tmp_path):
    p = tmp_path / "e.csv"
    p.write_text("\n\n")
    with pytest.raises(RecordingError, match="is empty"):
        read_recording(p)
    p.write_text(",".join(RECORDING_COLUMNS) + "\n")
    with pytest.raises(RecordingError, match="no samples"):
        read_recording(p)
    p.write_text("0.0,2800,0.8,186.7,8.0\n0.01,2800,0.8,186.7,8.0\n")
    with pytest.raises(RecordingError, match="no header row.*time_s"):
        read_recording(p)


def test_missing_required_column(tmp_path):
    p = tmp_path / "bad.csv"
    p.write_text("time_s,speed_in_rpm,torque_in_Nm,speed_out_rpm\n0,1,2,3\n")
    with pytest.raises(RecordingError, match="'torque_out_Nm' is missing; found: time_s, "
                                             "speed_in_rpm, torque_in_Nm, speed_out_rpm"):
        read_recording(p)


@pytest.mark.parametrize("text", ["abc", "1,5", "inf"])
def test_non_numeric_cell(tmp_path, text):
    p = edit_cell(write(tmp_path, sample()), 6, 2, '"' + text + '"' if "," in text else text)
    with pytest.raises(RecordingError, match=f"'torque_in_Nm', row 6: '{text}' is not a number"):
        read_recording(p)


def test_time_out_of_order(tmp_path):
    rec = sample()
    rec["torque_in_Nm"][10] = np.nan                    # row numbers count excluded samples too
    rec["time_s"][50] = rec["time_s"][49] - 0.01
    with pytest.raises(RecordingError, match="time_s goes backwards at row 52: 0.49 s then "):
        read_recording(write(tmp_path, rec))
    with pytest.raises(RecordingError, match="time_s goes backwards at sample 50"):
        recording_from_arrays(*(rec[c] for c in RECORDING_COLUMNS))


def test_duplicated_timestamp_is_averaged_and_reported(tmp_path):
    """Deliberate change (issue 10): a repeated time stamp no longer refuses the recording; the
    samples of one time become their mean, counted as an exclusion naming the row."""
    rec = sample()
    rec["time_s"][50] = rec["time_s"][49]
    rec["torque_out_Nm"][49:51] = [7.0, 9.0]
    r = read_recording(write(tmp_path, rec))
    assert r.n == 1999 and r.torque_out[49] == pytest.approx(8.0)
    (e,) = r.exclusions
    assert e.count == 1 and "duplicated timestamp" in e.reason and "row 52" in e.reason


def test_speed_that_looks_like_rad_s(tmp_path):
    """The input speed alone in rad/s: the power balance (6.4 times more power out than in)
    refuses it; the old 'non-integer peak below 350' rule is gone (it refused genuine slow
    runs); standing still is refused as nothing to diagnose."""
    rec = sample()
    rec["speed_in_rpm"] = rec["speed_in_rpm"] * math.pi / 30       # rad/s written as r/min
    with pytest.raises(RecordingError, match=r"power balance: .* 6\.\d+ times .*speed unit"):
        read_recording(write(tmp_path, rec))
    slow = dict(rec, speed_in_rpm=np.full(2000, 300.0) + rec["speed_in_rpm"] % 0.1,
                speed_out_rpm=np.full(2000, 20.0), torque_out_Nm=np.full(2000, 10.0))
    r = read_recording(write(tmp_path, slow))                      # a slow run in r/min
    assert r.n == 2000 and any(c["id"] == "speed_unit" for c in r.checks)
    rec["speed_in_rpm"] = np.zeros(2000)                           # standing still
    with pytest.raises(RecordingError, match="stands still, nothing to diagnose"):
        read_recording(write(tmp_path, rec))


def test_torque_that_looks_like_N_mm(tmp_path):
    rec = sample()
    rec["torque_in_Nm"] = np.full(2000, 1.25) * 1000                # 1.25 N*m written in N*mm
    with pytest.raises(RecordingError, match=r"torque_in_Nm peaks at 1250: .*N\*mm"):
        read_recording(write(tmp_path, rec))


def test_too_short(tmp_path):
    with pytest.raises(RecordingError, match="too short: 300 samples over 2.99 s.*"
                                             "at least 200 samples and 5 s"):
        read_recording(write(tmp_path, sample(n=300)))
    with pytest.raises(RecordingError, match="150 samples .*at least 200 samples"):
        read_recording(write(tmp_path, sample(n=150, rate=20.0)))
    rec = sample(n=600)                                     # 5.99 s, but 100 NaN at the end
    rec["torque_out_Nm"][500:] = np.nan
    with pytest.raises(RecordingError, match="500 samples over 4.99 s after exclusions"):
        read_recording(write(tmp_path, rec))
    assert read_recording(write(tmp_path, sample(n=300)), min_duration=2.0).n == 300


def test_arrays_of_different_length():
    rec = sample()
    with pytest.raises(RecordingError, match="'torque_out_Nm' has 1999 samples, time_s has 2000"):
        recording_from_arrays(rec["time_s"], rec["speed_in_rpm"], rec["torque_in_Nm"],
                              rec["speed_out_rpm"], rec["torque_out_Nm"][1:])


# --- the command line on top ---------------------------------------------------------------

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
    assert len(out["evidence"]) == len(DEFAULT_CANDIDATES) and "statement" in out["located"]
    for key in ("effects", "unexplained", "checks", "excluded"):
        assert key in out
    assert out["effects"][0]["id"] == out["effect"] and out["unexplained"]["present"] is False
    assert (tmp_path / "d" / "report.html").read_text().startswith("<!DOCTYPE html>")
    assert (tmp_path / "d" / "design_updated.toml").exists()
    bad = tmp_path / "bad.csv"
    bad.write_text("time_s,speed_in_rpm\n0,1\n")
    r = run("diagnose", str(bad), "--mode", "S1")
    assert r.returncode == 2 and len(r.stderr.strip().splitlines()) == 1
    assert "torque_in_Nm" in r.stderr
    r = run("synth", "--effect", "gremlins", "--out", str(tmp_path / "x.csv"))
    assert r.returncode == 2 and "effect" in r.stderr


def test_torque_in_n_mm_caught_by_the_power_balance(tmp_path):
    """0.8 N*m written as 800 N*mm stays below the 1000 limit; the power balance catches it,
    and a back-driven recording (output power above input power) still passes."""
    import numpy as np
    from cyclo_fmu.bench import write_recording
    from cyclo_fmu.recordings import RecordingError, read_recording
    t = np.arange(2000) / 100.0
    rec = {"time_s": t, "speed_in_rpm": 2800 + 0.5 * np.sin(t), "torque_in_Nm": 800.0 + 0 * t,
           "speed_out_rpm": 186.7 + 0 * t, "torque_out_Nm": 8.0 + 0 * t}
    with pytest.raises(RecordingError, match="torque_in_Nm.*N\\*mm"):
        read_recording(write_recording(tmp_path / "nmm.csv", rec))
    back = dict(rec, torque_in_Nm=-0.5 + 0 * t, torque_out_Nm=-12.0 + 0 * t)
    assert read_recording(write_recording(tmp_path / "back.csv", back)).n == 2000
