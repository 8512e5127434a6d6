"""The fast paths of the core give what the straightforward ones give (issue 8, item 8).

- Losses: solving each distinct contact problem once, ring forces only for the rollers that
  carry load in the batch, disc losses at the distinct problems, the eccentric bearing per
  distinct pair (``dedup=True``) against every mesh position and contact problem on its own
  (``dedup=False``), through the whole operating point, both profiles, forward and back-driven
  modes and needle rollers.
- The fixed point in eta0: a point in a map is solved on its own, so it gives what it gives
  alone (the earlier global iteration stopped when the last point converged and left the
  others ~1e-8 apart, up to 1.5e-5 in mode 21 of the physical profile).
- The physical ModeMap raises no divide-by-zero (the secant used to leave 0 < eta0 <= 1).
"""
import warnings

import numpy as np
import pytest

from model_core import DriveDesign, operating_point, rpm_to_rad_s
from model_core.efficiency import torque_coefficients
from model_core.lossmap import ModeMap
from model_core.losses import LOSS_NAMES

RTOL = 1e-9

DESIGNS = {
    "paper": DriveDesign(profile="paper"),
    "physical": DriveDesign(profile="physical"),
    "physical-needle": DriveDesign(profile="physical", ring_rollers="needle",
                                   disc_rollers="needle"),
}


def _outputs(op):
    out = {"eta": op.eta, "eta0": op.eta0, "locked": op.locked}
    out.update({"T" + k: v for k, v in op.torques.items()})
    out.update({n: getattr(op.losses, n) for n in LOSS_NAMES})
    out["loss_total"] = op.losses.total
    return out


def _assert_same(a, b, rtol=RTOL):
    for k in a:
        x, y = np.asarray(a[k], float), np.asarray(b[k], float)
        np.testing.assert_array_equal(np.isnan(x), np.isnan(y), err_msg=k)
        ok = ~np.isnan(x)
        np.testing.assert_allclose(x[ok], y[ok], rtol=rtol,
                                   atol=1e-12 * (np.max(np.abs(y[ok])) if ok.any() else 0),
                                   err_msg=k)


def _points(mode, n=3):
    """Driving speeds (rad/s) and torques (N*m) spanning a map (n x n); back-driving modes (1S,
    2S) with the torque on the driving shaft 1 or 2, so power flows into S."""
    rpm = np.linspace(500.0, 2800.0, n)
    T = np.linspace(0.1, 0.85, n)
    if mode[0] != "S":     # shaft 1 or 2 drives: geared down speed, geared up torque
        rpm, T = rpm / 15, T * 15
    W, TT = np.meshgrid(rpm_to_rad_s(rpm), T, indexing="ij")
    return W, TT


@pytest.mark.parametrize("name", list(DESIGNS))
@pytest.mark.parametrize("mode", ["S1", "S2", "1S", "2S", "12"])
def test_fast_losses_equal_the_straightforward_path(name, mode):
    d = DESIGNS[name]
    if name == "physical-needle" and mode not in ("S1", "2S"):
        pytest.skip("needle rollers: one forward and one back-driven mode suffice")
    W, T = _points(mode)
    fast = operating_point(d, mode, W, T)
    slow = operating_point(d, mode, W, T, dedup=False)
    assert np.isfinite(fast.eta).any()
    _assert_same(_outputs(fast), _outputs(slow))


@pytest.mark.parametrize("name", ["paper", "physical"])
@pytest.mark.parametrize("mode", ["S1", "2S", "21"])
def test_a_point_in_a_map_is_the_point_alone(name, mode):
    d = DESIGNS[name]
    W, T = _points(mode, 5)   # more points than efficiency._PAIR_START_MAX
    batch = _outputs(operating_point(d, mode, W, T))
    for i in range(W.shape[0]):
        for j in range(W.shape[1]):
            alone = _outputs(operating_point(d, mode, W[i, j], T[i, j]))
            _assert_same({k: v[i, j] for k, v in batch.items()}, alone)


@pytest.mark.parametrize("mode", ["S1", "S2"])
def test_physical_modemap_without_runtime_warnings(mode):
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        m = ModeMap(DESIGNS["physical"], mode, 30.0, 350.0)
    eta0 = np.concatenate([m._arrays[True][..., 0], m._arrays[False][..., 0]])
    assert np.all((eta0 > 0) & (eta0 <= 1))


def test_kreines_coefficients_need_a_positive_eta0_when_the_ring_is_driven():
    c = torque_coefficients(np.array([0.0, 0.5]), np.array([1.0, -1.0]), 0.9)
    np.testing.assert_allclose(c[1], [-0.0, -1.8])
    with pytest.raises(ValueError, match="eta0"):
        torque_coefficients(np.array([0.0]), np.array([-1.0]), 0.9)


def test_inverse_interpolation_is_exact_for_a_polynomial_inverse():
    from model_core.efficiency import _inverse_interpolation
    G = np.array([-0.3, -0.1, 0.2, 0.5])[:, None]
    u = 0.97 + 0.4 * G - 0.2 * G ** 2 + 0.05 * G ** 3       # a cubic u(G): four points
    assert _inverse_interpolation(u, G)[0] == pytest.approx(0.97, abs=1e-15)
    # two points: the secant's root
    assert _inverse_interpolation(u[:2], G[:2])[0] == pytest.approx(
        u[1, 0] - G[1, 0] * (u[1, 0] - u[0, 0]) / (G[1, 0] - G[0, 0]), rel=1e-15)


@pytest.mark.parametrize("name", ["paper", "physical"])
@pytest.mark.parametrize("mode, T", [("S1", 0.6), ("S2", 0.6), ("S1", 0.1), ("S1", -0.6),
                                     ("21", 9.0)])
def test_one_point_takes_three_loss_evaluations(monkeypatch, name, mode, T):
    """A single operating point (efficiency._PAIR_START_MAX): the start nodes in one call,
    the first estimate with its companions in a second, the converged point in a third (the
    secant from two start points took 4-5); the known torque reproduced as in a map."""
    from model_core import efficiency
    calls = []
    real = efficiency.partial_losses

    def counting(*args, **kwargs):
        calls.append(np.size(args[1]))
        return real(*args, **kwargs)
    monkeypatch.setattr(efficiency, "partial_losses", counting)
    w = 290.0 if mode[0] == "S" else 290.0 / 15
    op = operating_point(DESIGNS[name], mode, w, T)
    assert len(calls) <= 3
    assert np.isfinite(op.eta) and abs(float(op.torques[mode[0]]) - T) <= 1e-7 * abs(T)


@pytest.mark.parametrize("profile", ["paper", "physical"])
def test_the_solvers_shortcuts_leave_the_maps_as_they_were(profile, monkeypatch):
    """The 50 x 50 map's shortcuts (docs/explanation/performance.md) change no result beyond
    1e-10: the Newton iteration of the contact problems going on with the points not yet
    converged alone (contact._ACTIVE_SET_SHARE), the secant handing a point that makes no
    progress to the bracket (efficiency._SECANT_PATIENCE) and the bracket's multisection for
    a few points (efficiency._MULTISECTION_MAX), against the same solvers with all three off
    (the whole batch iterated until its last point converged; the secant to _FIXED_POINT_MAX;
    regula falsi alone): the 50 x 50 maps in every mode, efficiencies, basic efficiencies,
    torques and partial losses, and the ModeMap of S1 and S2. The physical S1 map holds the
    point whose losses jump at the root (a plain roller switching between rolling and
    skidding), which the shortcuts reach by another path."""
    import math

    import model_core.contact as C
    import model_core.efficiency as E
    from model_core import efficiency_map
    d = DriveDesign(profile=profile)
    speeds = rpm_to_rad_s(np.linspace(500, 2800, 50))
    torques = np.linspace(0.1, 0.85, 50)

    def run():
        out = {}
        for mode in ("S1", "S2", "12", "21", "1S", "2S"):
            s, t = (speeds, torques) if mode[0] == "S" else (speeds / 15, torques * 15)
            m = efficiency_map(d, mode, s, t)
            out[mode] = dict(eta=m.eta, eta0=m.eta0, locked=m.locked, P_in=m.input_power,
                             **m.losses)
        for mode in ("S1", "S2"):
            mm = ModeMap(d, mode, 30.0, 350.0)
            W, T = np.meshgrid(np.linspace(-340, 340, 23), np.linspace(-29, 29, 19))
            r = mm.solve_arrays(W.ravel() + 0.5, T.ravel())
            out["ModeMap " + mode] = {k: np.asarray(v, float) for k, v in r.items()}
        return out
    fast = run()
    monkeypatch.setattr(C, "_ACTIVE_SET_SHARE", math.inf)
    monkeypatch.setattr(E, "_SECANT_PATIENCE", E._FIXED_POINT_MAX + 1)
    monkeypatch.setattr(E, "_MULTISECTION_MAX", 0)
    plain = run()
    for mode in fast:
        for k in fast[mode]:
            x, y = np.asarray(fast[mode][k], float), np.asarray(plain[mode][k], float)
            np.testing.assert_array_equal(np.isnan(x), np.isnan(y), err_msg=(mode, k))
            ok = ~np.isnan(x)
            assert np.all(np.abs(x[ok] - y[ok]) <= 1e-10 * np.maximum(1.0, np.abs(y[ok]))), \
                (mode, k, np.max(np.abs(x[ok] - y[ok])))
