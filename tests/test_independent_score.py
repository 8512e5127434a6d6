"""The independent batches' scoring rules (benchmarks/independent/score.py) on hand-made JSON:
the proposal's powers read from the structured terms and from the feature text, a refused
proposal, the calibration fit's interval and minimum size, the load-ripple substitute."""
from __future__ import annotations

import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks" / "independent"))
import score  # noqa: E402


@pytest.mark.parametrize("text, powers", [
    ("sgn(w_in)*(|w_in|/300 rad/s)^1*(|tau_out|/10 N*m)^1", (1.0, 1.0)),
    ("sgn(w_in)*(|tau_out|/10 N*m)^2", (0.0, 2.0)),
    ("sgn(w_in)*(|tau_out|/10 N*m)^1.5", (0.0, 1.5)),
    ("|w_in|^2", (2.0, 0.0)),
    ("|T|²", (0.0, 2.0)),
    ("sgn(w_in)*(T - T0)", (0.0, 0.0)),
])
def test_term_powers(text, powers):
    assert score.term_powers(text) == powers


def _proposal(feature, before=4e-3, after=1e-3, **kw):
    return dict(proposed=dict(formula="x", terms=[dict(feature=feature, coefficient=0.03,
                                                       unit="N*m", ci95=[0.02, 0.04])],
                              heldout_rms_before_Nm=before, heldout_rms_after_Nm=after,
                              reading="", refused=None, **kw))


def test_judge_proposal_law_and_share():
    u = _proposal("sgn(w_in)*(|tau_out|/10 N*m)^2")
    assert score.judge_proposal(dict(torque=2), u)[0] == "right"
    assert score.judge_proposal(dict(speed=1, torque=1), u)[0] == "other form"
    assert score.judge_proposal(dict(torque=2), _proposal("|T|^2", after=2e-3))[0] == "weak"
    # the structured terms win over the text
    u = _proposal("unreadable", design_terms=[dict(speed_exponent=1.0, load_exponent=1.0)])
    assert score.judge_proposal(dict(speed=1, torque=1), u)[0] == "right"
    u = _proposal("sgn(w_in)*(T - T0)")
    u["proposed"]["terms"][0]["family"] = "temperature"
    assert score.judge_proposal(dict(temperature=True), u)[0] == "right"
    refused = dict(proposed=dict(terms=[], refused="no term stable", heldout_rms_before_Nm=1e-3,
                                 heldout_rms_after_Nm=1e-3))
    assert score.judge_proposal(dict(torque=2), refused)[0] == "refused"
    assert score.judge_proposal(dict(torque=2), dict(proposed=None))[0] == "absent"


def test_calibration_fit_needs_interval_and_size():
    fit = dict(mesh_loss_k=0.002, idle_loss_scale=0.996,
               ci95=dict(mesh_loss_k=1e-5, idle_loss_scale=1e-3))
    d = dict(calibration_fit=fit)
    assert score.found_as_calibration("mesh_loss", d)
    assert not score.found_as_calibration("idle_loss_scale", d)     # 0.4 %: below the size
    fit.update(idle_loss_scale=1.25, ci95=dict(mesh_loss_k=float("nan"),
                                                idle_loss_scale=float("nan")))
    assert score.found_as_calibration("idle_loss_scale", d)         # NaN: size alone
    fit.update(mesh_loss_k=1e-4)
    assert not score.found_as_calibration("mesh_loss", d)


def test_load_ripple_substitutes_only_for_a_load_scaled_ripple():
    assert score.substitutes(["ripple_load"]) == {"mesh_ripple": ["load_ripple"]}
    assert score.substitutes(["ripple"]) == {}
