"""The diagnosis from the command line: several effects and a temperature column written by
``synth`` are found by ``diagnose``, the JSON contract holds, the written design closes the
loop, and bad synth options end in one line."""
import json
import subprocess
import sys

import pytest


def run(*args):
    return subprocess.run([sys.executable, "-m", "cyclo_fmu.cli", *args], capture_output=True,
                          text=True, timeout=300)


def test_several_effects_with_a_temperature_column(tmp_path):
    rec = tmp_path / "rec.csv"
    r = run("synth", "--effect", "thermal_drift,load_independent_loss", "--temperature-rise",
            "30", "--seed", "5", "--out", str(rec))
    assert r.returncode == 0, r.stderr
    assert rec.read_text().splitlines()[0].endswith("temperature_C")
    out = tmp_path / "d"
    r = run("diagnose", str(rec), "--mode", "auto", "--json", "--out", str(out))
    assert r.returncode == 0, r.stderr
    res = json.loads(r.stdout)
    assert {e["id"] for e in res["effects"]} == {"thermal_drift", "load_independent_loss"}
    assert res["effect"] == res["effects"][0]["id"]
    warm = next(e for e in res["effects"] if e["id"] == "thermal_drift")
    # the default hidden warm-up is 0.12 of the losses per 10 K: fitted per 10 K, written so
    assert warm["form"] == "per 10 K of the temperature column"
    assert warm["parameters"]["loss_change"]["value"] == pytest.approx(0.12, rel=0.05)
    assert warm["parameters"]["loss_change"]["unit"] == "1 per 10 K"
    assert res["unexplained"] == {**res["unexplained"], "present": False, "rms_Nm": 0.0}
    assert res["design_check"]["rms_updated_Nm"] < 0.2 * res["design_check"]["rms_given_Nm"]
    toml = (out / "design_updated.toml").read_text()
    assert "thermal_loss_per_10K = 0.1" in toml
    html = (out / "report.html").read_text()
    assert "thermal_drift" in html and "data:image/png;base64," in html
    # closure from the command line: nothing left with the written design
    r = run("diagnose", str(rec), "--mode", "S1", "--json", "--design", str(out / "design_updated.toml"))
    assert r.returncode == 0, r.stderr
    again = json.loads(r.stdout)
    assert again["effects"] == [] and again["unexplained"]["present"] is False


@pytest.mark.parametrize("args, words", [
    (["--effect", "drag"], "effect = 'drag'"),
    (["--effect", "inertia,inertia"], "names an effect twice"),
    (["--effect", "inertia", "--temperature-rise", "1e9"], "temperature-rise"),
    (["--effect", "inertia,torque_sensor_offset", "--engine", "bench"], "engine"),
])
def test_bad_synth_options_are_one_line(tmp_path, args, words):
    out = tmp_path / "r.csv"
    r = run("synth", *args, "--size", "tiny", "--out", str(out))
    assert r.returncode == 2 and words in r.stderr and len(r.stderr.strip().splitlines()) == 1
    assert not out.exists()


def test_a_mismatch_outside_the_library_is_not_called_explained(tmp_path):
    """A load-squared loss outside the library (the friction level exact): the command says
    that no effect of the library explains it, never that the model explains the data."""
    import numpy as np
    from cyclo_fmu.synth import synthesize

    def load_squared(s):
        return np.sign(s["w_in"]) * 0.010 * (s["T_in_model"] / 0.8) ** 2
    r = synthesize("none", 31, "S1", "small", added_torque=load_squared)
    cols = ["time_s", "speed_in_rpm", "torque_in_Nm", "speed_out_rpm", "torque_out_Nm"]
    rec = tmp_path / "rec.csv"
    np.savetxt(rec, np.column_stack([r[c] for c in cols]), delimiter=",",
               header=",".join(cols), comments="")
    out = run("diagnose", str(rec), "--mode", "S1")
    assert out.returncode == 0, out.stderr
    lines = out.stdout.splitlines()
    assert "effects: none - no effect of the library explains the mismatch (see unexplained)" \
        in lines, out.stdout
    assert any(s.startswith("unexplained: a mismatch of") for s in lines), out.stdout
    assert "within its noise" not in out.stdout


@pytest.mark.parametrize("value", ["0", "-80", "nan", "inf", "2e6"])
def test_a_transducer_bandwidth_that_is_no_frequency_is_one_line(tmp_path, value):
    """``diagnose --bandwidth``: zero, negative, not finite or beyond 1 MHz (a unit mistake)
    ends in one line naming the option and its value, exit 2, no folder written."""
    rec = tmp_path / "rec.csv"
    assert run("synth", "--effect", "none", "--size", "tiny", "--out", str(rec)).returncode == 0
    out = tmp_path / "d"
    r = run("diagnose", str(rec), "--mode", "S1", "--bandwidth", value, "--out", str(out))
    assert r.returncode == 2, r.stderr
    assert "bandwidth" in r.stderr and len(r.stderr.strip().splitlines()) == 1
    assert not out.exists()


def test_the_transducer_bandwidth_given_is_the_one_the_model_is_filtered_with(tmp_path):
    """``--bandwidth 80``: the JSON says which bandwidth the model's torque was filtered with
    (80 Hz given, 1000 Hz the stated default, with which the clean recording names nothing)."""
    rec = tmp_path / "rec.csv"
    assert run("synth", "--effect", "none", "--size", "tiny", "--out", str(rec)).returncode == 0
    for args, hz in (([], 1000.0), (["--bandwidth", "80"], 80.0)):
        r = run("diagnose", str(rec), "--mode", "S1", "--json", *args)
        assert r.returncode == 0, r.stderr
        res = json.loads(r.stdout)
        assert res["transducer_bandwidth_Hz"] == hz
        if not args:
            assert res["effects"] == [] and res["unexplained"]["present"] is False
