"""The --band prediction: nominal next to the conservative variant (issue 19 item 4): the
variant changes exactly what it says, never raises the efficiency, and both commands print it."""
import json
import subprocess
import sys

import numpy as np
import pytest

from model_core import DriveDesign, operating_point
from model_core.design import (CONSERVATIVE_HERSEY_TRANSITION, conservative_variant,
                               design_to_dict)
from model_core.friction import stribeck_pin_mu
from model_core.presets import load_preset


def _diff(a, b):
    da, db = design_to_dict(a), design_to_dict(b)
    return {(s, k) for s in da for k in da[s] if da[s][k] != db[s][k]}


def test_variant_changes_exactly_the_named_fields():
    d = DriveDesign()
    assert _diff(d, conservative_variant(d)) == {("friction", "hersey_transition")}
    rig = load_preset("mackic-rig").replace(seals="none")
    assert _diff(rig, conservative_variant(rig)) == {
        ("friction", "hersey_transition"), ("calibration", "idle_loss_scale"),
        ("geometry", "seals")}
    c = conservative_variant(rig)
    assert c.calibration.idle_loss_scale == 1.0 and c.seals == "lip"
    assert c.calibration.mesh_loss_k == rig.calibration.mesh_loss_k


def test_variant_pins_are_at_boundary_friction():
    """exp(-H/H_t) = 1 within 1e-6 over every Hersey number of a greased pin in the drive."""
    fr = conservative_variant(DriveDesign()).friction
    H = np.logspace(-10, -6, 9)
    mu, _ = stribeck_pin_mu(H, fr.mu_pin_boundary, fr.hersey_transition, fr.pin_clearance_ratio)
    np.testing.assert_allclose(mu, fr.mu_pin_boundary + 2 * np.pi ** 2 * H / fr.pin_clearance_ratio,
                               rtol=1e-6)
    assert fr.hersey_transition == CONSERVATIVE_HERSEY_TRANSITION


@pytest.mark.parametrize("design", [DriveDesign(), load_preset("mackic-rig")])
def test_conservative_never_above_nominal(design):
    """More friction and more idle losses can only lower the efficiency."""
    w = np.linspace(1000, 2800, 5) * np.pi / 30
    t = np.linspace(0.3, 0.85, 5)
    W, T = np.meshgrid(w, t)
    for mode in ("S1", "S2"):
        nom = np.asarray(operating_point(design, mode, W, T).eta, float)
        con = np.asarray(operating_point(conservative_variant(design), mode, W, T).eta, float)
        assert np.all(con <= nom + 1e-12)
        assert np.mean(nom - con) > 0.005


def test_cli_band():
    r = subprocess.run([sys.executable, "-m", "cyclo_fmu.cli", "efficiency", "--mode", "S1",
                        "--speed", "1500", "--torque", "0.5", "--band", "--json"],
                       capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    b = json.loads(r.stdout)["band"]
    assert b["eta_conservative"] < b["eta_nominal"] and "boundary" in b["variant"]
    r = subprocess.run([sys.executable, "-m", "cyclo_fmu.cli", "paper", "--band", "--json",
                        "--design", "mackic-rig", "--out", ""], capture_output=True, text=True,
                       timeout=300)
    assert r.returncode == 0, r.stderr
    out = json.loads(r.stdout)
    for m in ("S1", "S2"):
        assert out["band"]["nominal"][m] == pytest.approx(out["physical"][m])
        assert out["band"]["conservative"][m]["mean"] < out["band"]["nominal"][m]["mean"]
