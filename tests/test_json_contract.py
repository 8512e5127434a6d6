"""One contract test per ``--json`` command (issue 21, item 2): every documented key with its
type, strict JSON (no NaN/Infinity literals: ``parse_constant`` raises), and exit status
exactly 2 with nothing on stdout for bad input.

Documented keys: README "efficiency" (the `--json` sentence), "Stiffness", the `paper` keys of
"Numbers" / "experiment_gap", and the diagnosis's "JSON contract" (docs/reference/errors.md
points here).
"""
import json
import math
import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def run(*args, cwd=None):
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    return subprocess.run([sys.executable, "-m", "cyclo_fmu.cli", *args], capture_output=True,
                          text=True, timeout=300, cwd=cwd, env=env)


def _refuse(name):
    raise ValueError(f"non-strict JSON constant {name}")


def strict(text):
    return json.loads(text, parse_constant=_refuse)


NUM = (int, float)
OPT_NUM = (int, float, type(None))


def check_types(obj, spec, where=""):
    for key, typ in spec.items():
        assert key in obj, f"{where}{key} missing"
        v = obj[key]
        if isinstance(typ, dict):
            assert isinstance(v, dict), f"{where}{key}"
            check_types(v, typ, f"{where}{key}.")
        else:
            assert isinstance(v, typ) and not isinstance(v, bool) or typ is bool and \
                isinstance(v, bool), f"{where}{key}: {type(v).__name__}"
            if isinstance(v, float):
                assert math.isfinite(v), f"{where}{key}"


def assert_bad_input(r, field):
    assert r.returncode == 2, (r.returncode, r.stderr)
    assert r.stdout == "", r.stdout
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and field in lines[0], r.stderr


LOSSES = {k: NUM for k in ("PL1", "PL2", "PL3", "PL5", "PL6")}
EFFICIENCY = {"mode": str, "flow_mode": str, "held_shaft": str, "eta": OPT_NUM, "eta0": NUM,
              "locked": bool, "stalled": bool, "no_load_torque_Nm": NUM, "losses_W": LOSSES,
              "loss_share": LOSSES, "loss_power_W": NUM, "input_speed_rpm": NUM,
              "input_torque_Nm": NUM, "input_power_W": NUM, "output_speed_rpm": NUM,
              "output_torque_Nm": NUM, "output_power_W": NUM, "reaction_torque_Nm": NUM,
              "profile": str, "losses": str,
              "idle_losses_W": {k: NUM for k in ("PL_support", "PL_seal", "PL_churn")},
              "grease_temperature_C": NUM, "grease_viscosity_mm2_s": NUM}


def test_efficiency_json():
    r = run("efficiency", "--mode", "S1", "--speed", "2800", "--torque", "0.85", "--json")
    assert r.returncode == 0, r.stderr
    out = strict(r.stdout)
    check_types(out, EFFICIENCY)
    assert out["mode"] == "S1" and out["flow_mode"] == "S1" and out["held_shaft"] == "2"
    assert out["locked"] is False and out["stalled"] is False
    # the documented relations between the keys
    assert out["input_power_W"] - out["output_power_W"] == pytest.approx(out["loss_power_W"],
                                                                         rel=1e-9)
    assert out["eta"] == pytest.approx(out["output_power_W"] / out["input_power_W"], rel=1e-9)
    for k, v in out["losses_W"].items():
        assert out["loss_share"][k] == pytest.approx(v / out["input_power_W"], rel=1e-12)
    for room in ("ring", "disc"):
        st = out["rollers"][room]
        assert st["state"] in ("roll", "skid", "mixed", "no plain rollers")
        assert 0 <= st["rolling_share"] <= 1 and len(st["pin_hersey_min_max"]) == 2


def test_efficiency_json_stall_is_null_not_nan():
    r = run("efficiency", "--mode", "S1", "--speed", "1000", "--torque", "1e-6", "--json")
    assert r.returncode == 0, r.stderr
    out = strict(r.stdout)
    assert out["stalled"] is True and out["eta"] is None


@pytest.mark.parametrize("args,field", [
    (("--speed", "1e308", "--torque", "1"), "speed"),
    (("--speed", "1000", "--torque", "1e308"), "torque"),
    (("--speed", "1000", "--torque", "nan"), "torque"),
])
def test_efficiency_json_bad_input(args, field):
    assert_bad_input(run("efficiency", "--mode", "S1", *args, "--json"), field)


STIFFNESS = {k: NUM for k in ("rated_torque_Nm", "torsional_rigidity_Nm_per_arcmin",
                              "lost_motion_arcmin", "backlash_arcmin", "twist_at_rated_arcmin",
                              "hysteresis_loss_arcmin", "stiffness_Nm_per_rad", "eta_mesh")}


def test_stiffness_json():
    r = run("stiffness", "--json")
    assert r.returncode == 0, r.stderr
    out = strict(r.stdout)
    check_types(out, STIFFNESS)
    assert out["lost_motion_arcmin"] >= out["backlash_arcmin"] > 0


@pytest.mark.parametrize("value", ["1e308", "1e-300", "-5", "0"])
def test_stiffness_json_bad_input(value):
    assert_bad_input(run("stiffness", "--json", f"--rated-torque={value}"), "rated-torque")


MINMAXMEAN = {"min": NUM, "mean": NUM, "max": NUM}


def test_paper_json(tmp_path):
    r = run("paper", "--json", "--out", str(tmp_path / "p"))
    assert r.returncode == 0, r.stderr
    out = strict(r.stdout)
    check_types(out, {"S1": MINMAXMEAN, "S2": MINMAXMEAN,
                      "physical": {"S1": MINMAXMEAN, "S2": MINMAXMEAN},
                      "theory": {"S1": MINMAXMEAN, "S2": MINMAXMEAN},
                      "experiment": {"S1": MINMAXMEAN, "S2": MINMAXMEAN},
                      "experiment_gap": {"k": NUM, "a": NUM, "load_proportional_W": NUM}})
    for m in ("S1", "S2"):
        assert out[m]["min"] <= out[m]["mean"] <= out[m]["max"]


def test_paper_json_bad_design(tmp_path):
    d = tmp_path / "d.toml"
    d.write_text("[geometry]\nlam = 0.8\n")
    assert_bad_input(run("paper", "--json", "--design", str(d), "--out", str(tmp_path / "p")),
                     "lam")
    assert not (tmp_path / "p").exists()


# diagnose: README "JSON contract"
EFFECT = {"id": str, "description": str, "parameters": dict, "explained_rms_Nm": NUM,
          "torque_rms_Nm": NUM, "share_of_residual": NUM}
DIAGNOSE = {"effects": list, "effect": str, "unexplained": dict, "checks": list,
            "excluded": list, "parameters": dict, "evidence": (dict, list), "located": dict,
            "rmse_before_Nm": NUM, "rmse_after_Nm": NUM, "zeta_d_before": NUM,
            "zeta_d_after": NUM, "indistinguishable_from": list, "mode": str,
            "read_notes": list}
UNEXPLAINED = {"present": bool, "rms_Nm": NUM, "statement": str, "follows": (dict, list, str),
               "could_include": list}


@pytest.fixture(scope="module")
def offset_recording(tmp_path_factory):
    d = tmp_path_factory.mktemp("diag")
    r = run("synth", "--effect", "torque_sensor_offset", "--size", "tiny", "--out",
            str(d / "r.csv"), "--truth", str(d / "truth.json"), cwd=d)
    assert r.returncode == 0, r.stderr
    return d / "r.csv"


def test_diagnose_json(offset_recording):
    r = run("diagnose", str(offset_recording), "--mode", "auto", "--json")
    assert r.returncode == 0, r.stderr
    out = strict(r.stdout)
    check_types(out, DIAGNOSE)
    check_types(out["unexplained"], UNEXPLAINED, "unexplained.")
    assert "whiteness_p_before" in out and "whiteness_p_after" in out
    assert "suggested_test" in out
    assert out["mode"] == "S1"
    assert out["effect"] == (out["effects"][0]["id"] if out["effects"] else "none") or \
        out["effect"] == "calibration"
    for e in out["effects"]:
        check_types(e, EFFECT, f"effects[{e.get('id')}].")
        assert "stability" in e and "separating_run" in e and "form" in e
        for name, p in e["parameters"].items():
            check_types(p, {"value": NUM, "unit": str}, f"{e['id']}.{name}.")
            assert p["ci95"] is None or (len(p["ci95"]) == 2 and p["ci95"][0] <= p["value"]
                                         <= p["ci95"][1])
    for c in out["checks"]:
        assert set(c) >= {"id", "status", "message"} and c["status"] in ("ok", "warning")
    for e in out["excluded"]:
        check_types(e, {"reason": str, "count": int, "unit": str}, "excluded.")
    assert out["effects"] and out["effects"][0]["id"] == "torque_sensor_offset"


@pytest.mark.parametrize("args,field", [
    (("--mode", "S3"), "mode"),
    (("--mode", "S1", "--units", "torque_in_Nm=furlong"), "furlong"),
    (("--mode", "S1", "--columns", "nonsense"), "columns"),
])
def test_diagnose_json_bad_input(offset_recording, tmp_path, args, field):
    assert_bad_input(run("diagnose", str(offset_recording), *args, "--json", "--out",
                         str(tmp_path / "o")), field)
    assert not (tmp_path / "o").exists()
