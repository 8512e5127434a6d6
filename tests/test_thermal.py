"""Temperature in the co-simulation (issue 19 item 6): the housing's lumped heat balance and the
grease temperature in both reducer FMUs.

Physical facts checked: the warm-up at a constant loss is the first-order closed form
T_amb + P R (1 - exp(-t/tau)) at any step sizes; heat is conserved (integrated loss = stored
heat + heat to the ambient); the long-run temperature closes the core's steady heat balance;
the input T_oil_in overrides the internal model; a saved state restores the temperature; the
Python and native FMUs agree for the calibrated preset ``mackic-rig`` while it warms up; at the
design's operating temperature the outputs are exactly the one-temperature map's.
"""
import math
import shutil
import subprocess
import sys

import numpy as np
import pytest

fmpy = pytest.importorskip("fmpy")

from model_core import DriveDesign, thermal  # noqa: E402
from model_core.lossmap import ModeMap, ThermalMap  # noqa: E402

from test_native_fmu import Inst  # noqa: E402

GCC = shutil.which("gcc") or shutil.which("cc")
#: Python and native FMU agreement (the same arithmetic in the same order: as test_native_fmu)
RTOL, ATOL = 1e-9, 1e-12
OUT = ("T_oil", "Q_ambient", "P_loss", "tau_in", "tau_housing", "eta", "eta0", "PL1", "PL3",
       "PL6", "PL_support", "PL_churn", "PL_mesh", "J_load", "tau_in_static")



class _HeatLedger:
    """The heat balance's energy over FMU steps: the loss of each step (held at its value at
    the step's start, as the FMU integrates it) against the heat stored in the housing and
    the heat to the ambient (trapezoid of Q_ambient), from the first step's T_oil on."""

    def __init__(self):
        self.loss = self.to_ambient = 0.0
        self.T_first = self.P_start = self.Q_prev = None

    def add(self, b, h):
        if self.P_start is not None:
            self.loss += self.P_start * h
            self.to_ambient += 0.5 * (self.Q_prev + b["Q_ambient"]) * h
        else:
            self.T_first = b["T_oil"]
        self.P_start, self.Q_prev = b["P_loss"], b["Q_ambient"]

    def heat(self, capacity, T_last):
        """[J] heat stored (``capacity`` [J/K]) plus heat to the ambient."""
        return capacity * (T_last - self.T_first) + self.to_ambient


def _oil_trajectory(k):
    """Step ``k`` of a measured-looking trajectory: grease temperature 12 to 85 degC and back
    [K], across every node of the map and between them; driving speed [rad/s] and load
    [N*m] through all four quadrants."""
    return (321.65 + 36.5 * math.sin(0.037 * k) + 0.3 * math.sin(1.7 * k),
            240.0 * math.sin(0.09 * k + 0.3), 7.0 * math.sin(0.061 * k))

def values(inst, names=OUT):
    return dict(zip(names, inst.fmu.getReal([inst.vr[n] for n in names])))


def advance(inst, dt, **inputs):
    inst.set(**inputs)
    inst.fmu.doStep(currentCommunicationPoint=inst.t, communicationStepSize=dt)
    inst.t += dt
    return values(inst)


@pytest.fixture(scope="module")
def preset_fmus(tmp_path_factory, fmu):
    """CycloidDrive.fmu and CycloidDriveNative.fmu of the calibrated preset mackic-rig, built by
    ``cyclo-fmu build --design mackic-rig`` (after the session's default FMUs)."""
    if GCC is None:
        pytest.skip("no C compiler")
    dest = tmp_path_factory.mktemp("preset")
    r = subprocess.run([sys.executable, "-m", "cyclo_fmu.cli", "build", "--design", "mackic-rig",
                        "--dest", str(dest), "CycloidDrive", "CycloidDriveNative"],
                       capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stderr
    return str(dest / "CycloidDriveNative.fmu"), str(dest / "CycloidDrive.fmu")


# -- the core --------------------------------------------------------------------------------
def test_housing_step_is_exact_for_a_held_loss():
    """Any split of an interval into steps gives the closed form when the loss is held."""
    d = DriveDesign()
    R, C = thermal.housing_resistance(d), d.housing_heat_capacity
    tau = R * C
    assert tau == pytest.approx(thermal.housing_time_constant(d))
    T, t, P, amb = 300.0, 0.0, 40.0, 293.15
    rng = np.random.default_rng(1)
    for h in rng.uniform(0.01, 900.0, 40):
        T = thermal.housing_step(T, P, h, amb, C, R)
        t += h
        closed = amb + P * R + (300.0 - amb - P * R) * math.exp(-t / tau)
        assert T == pytest.approx(closed, rel=1e-12)


def test_housing_heat_balance_by_hand():
    """k_h = 20 W/(m^2 K) over A_h = 0.1 m^2: R = 1/(k_h A_h) = 0.5 K/W; a held 30 W loss warms
    the housing to 15 K above the ambient, where it gives the ambient (T - T_amb)/R = 30 W, the
    loss; 5 K below the ambient it takes 10 W from it. Over one step from the ambient, the loss's
    heat P h is the stored heat C (T(h) - T_amb) plus the heat to the ambient, int (T - T_amb)/R
    dt (Simpson's rule on the step's closed-form trajectory)."""
    d = DriveDesign(housing_heat_transfer=20.0, housing_area=0.1, housing_heat_capacity=600.0)
    R, C = thermal.housing_resistance(d), d.housing_heat_capacity
    assert R == pytest.approx(0.5, rel=1e-15)
    amb = 293.15
    T_end = thermal.housing_step(amb, 30.0, 1e6, amb, C, R)       # 1e6 s = 3333 tau
    assert T_end == pytest.approx(amb + 15.0, rel=1e-12)
    assert thermal.heat_to_ambient(T_end, amb, R) == pytest.approx(30.0, rel=1e-9)
    assert thermal.heat_to_ambient(amb - 5.0, amb, R) == pytest.approx(-10.0, rel=1e-12)
    h = 200.0                                                     # 2/3 of tau = 300 s
    ts = np.linspace(0.0, h, 2001)
    T = np.array([thermal.housing_step(amb, 30.0, t, amb, C, R) for t in ts])
    q = thermal.heat_to_ambient(T, amb, R)
    to_ambient = h / 6000 * (q[0] + q[-1] + 4 * q[1:-1:2].sum() + 2 * q[2:-1:2].sum())
    assert 30.0 * h == pytest.approx(C * (T[-1] - amb) + to_ambient, rel=1e-10)


def test_thermal_map_is_the_one_temperature_map_at_its_nodes():
    d = DriveDesign()
    tm = ThermalMap(d, "S1", 30.0, 350.0)
    assert tm.temperatures[tm.reference] == d.operating_temperature
    assert tm.solved_nodes == 1                     # only the operating temperature's at first
    mm = ModeMap(d, "S1", 30.0, 350.0)
    for w, t in ((300.0, -10.0), (50.0, -0.5), (-120.0, 3.0), (200.0, 2.0)):
        assert tm.solve(w, t, d.operating_temperature) == mm.solve(w, t)   # bit for bit
        hot = ModeMap(thermal.at_temperature(d, tm.temperatures[-1]), "S1", 30.0, 350.0)
        assert tm.solve(w, t, tm.temperatures[-1]) == hot.solve(w, t)
    # between nodes: the energy balance holds as at a node
    for T in (300.0, 318.7, 351.0):
        speeds, torques, losses, *_ = tm.solve(250.0, -6.0, T)
        p = sum(x * y for x, y in zip(torques, speeds))
        assert sum(losses) == pytest.approx(p, rel=1e-12)
    # the paper profile does not depend on the temperature: one node
    assert thermal.map_temperatures(DriveDesign(profile="paper")) == (313.15,)


def test_fitted_viscosity_slope_is_carried_by_the_lubricant():
    d = DriveDesign()
    s = thermal.viscosity_slope(d)
    lub = thermal.lubricant_with_slope(d.lubricant, d.operating_temperature, 1.4 * s)
    new = DriveDesign(lubricant=lub)
    assert thermal.viscosity_slope(new) == pytest.approx(1.4 * s, rel=1e-5)
    assert thermal.lubricant_viscosity(new) == pytest.approx(thermal.lubricant_viscosity(d),
                                                             rel=1e-9)
    with pytest.raises(ValueError):
        thermal.lubricant_with_slope(d.lubricant, 313.15, 0.01)


# -- co-simulation ---------------------------------------------------------------------------
def test_warm_up_follows_the_first_order_closed_form(fmu):
    """Constant losses (paper profile: no temperature dependence, a held operating point):
    T(t) = T_amb + P R (1 - exp(-t/tau)) from a start at the ambient, at irregular steps."""
    amb = 295.0
    p = Inst(fmu, profile="paper", T_oil_start=amb, ambient_temperature=amb, w_in=300.0,
             tau_out=-10.0)
    d = DriveDesign()
    R = thermal.housing_resistance(d)
    tau = R * d.housing_heat_capacity
    P = values(p)["P_loss"]
    assert P > 10
    t = 0.0
    for h in (7.0, 50.0, 200.0, 3.5, 900.0, 1500.0, 4000.0):
        v = advance(p, h, w_in=300.0, tau_out=-10.0)
        t += h
        assert v["P_loss"] == P                         # held: the losses do not change
        closed = amb + P * R * (1 - math.exp(-t / tau))
        assert v["T_oil"] - amb == pytest.approx(closed - amb, rel=1e-10)
        assert v["Q_ambient"] == pytest.approx((v["T_oil"] - amb) / R, rel=1e-12)
    assert v["T_oil"] - amb > 0.9 * P * R                # near its steady rise after 3 tau
    p.close()


def test_energy_balance_of_the_warm_up(fmu):
    """Integrated loss = heat stored in the housing + heat given to the ambient, while the
    losses change with the operating point and with the temperature (physical profile)."""
    d = DriveDesign()
    R, C = thermal.housing_resistance(d), d.housing_heat_capacity
    def u(k):
        return 250.0 + 80.0 * math.sin(k / 90.0), -6.0 - 3.0 * math.sin(k / 37.0)
    p = Inst(fmu, T_oil_start=290.0, ambient_temperature=293.15, w_in=u(0)[0],
             tau_out=u(0)[1])
    h, loss, q, T0 = 2.0, 0.0, [], 290.0
    P_start = values(p)["P_loss"]
    Q_prev = values(p)["Q_ambient"]
    for k in range(1500):
        w, t_out = u(k)
        v = advance(p, h, w_in=w, tau_out=t_out)
        # the loss over the step, as the user sees it: the output at the step's start (the FMU
        # holds the loss of the step's inputs at the start's temperature: the same up to the
        # inputs' change over one step, which cancels in the sum but for the last step)
        loss += P_start * h
        q.append(0.5 * (Q_prev + v["Q_ambient"]) * h)  # trapezoid of the heat flow
        P_start, Q_prev = v["P_loss"], v["Q_ambient"]
    stored = C * (v["T_oil"] - T0)
    assert v["T_oil"] > T0 + 10                         # it warmed up
    assert stored + sum(q) == pytest.approx(loss, rel=2e-4)
    p.close()


def test_long_run_temperature_closes_the_cores_heat_balance(fmu):
    """After many time constants at one operating point the FMU's temperature is the steady
    heat balance the core solves (model_core.thermal.solve_heat_balance, exact core; the FMU
    interpolates its map, so within a fraction of a kelvin)."""
    d = DriveDesign()
    p = Inst(fmu, T_oil_start=300.0, w_in=280.0, tau_out=-8.0)
    for _ in range(40):
        v = advance(p, 1000.0, w_in=280.0, tau_out=-8.0)
    op, T_core = _steady_core(d, 280.0, -8.0)
    assert v["T_oil"] == pytest.approx(T_core, abs=0.5)
    assert v["Q_ambient"] == pytest.approx(v["P_loss"], rel=1e-3)
    p.close()


def _steady_core(d, w_in, tau_out):
    """The steady heat balance of the exact core at a load torque (fixed point in T)."""
    from model_core.efficiency import operating_point
    T = d.ambient_temperature
    for _ in range(200):
        op = operating_point(thermal.at_temperature(d, T), "S1", w_in, T_out=tau_out)
        T_new = float(thermal.housing_temperature(float(op.loss_power), d.ambient_temperature,
                                                  d.housing_heat_transfer, d.housing_area))
        if abs(T_new - T) < 1e-6:
            break
        T = 0.5 * (T + T_new)
    return op, T


def test_input_overrides_the_heat_balance(fmu):
    d = DriveDesign()
    tm = ThermalMap(d, "S1", 30.0, 350.0)
    p = Inst(fmu, use_T_oil_input=True, T_oil_in=345.0, T_oil_start=293.15)
    for k, T_in in enumerate((345.0, 345.0, 301.5, 333.3)):
        v = advance(p, 100.0, w_in=260.0, tau_out=-7.0, T_oil_in=T_in)
        assert v["T_oil"] == T_in                          # not the heat balance's
        assert v["tau_in"] == tm.solve(260.0, -7.0, T_in)[1][2]
    p.close()
    q = Inst(fmu, T_oil_start=293.15)
    assert advance(q, 100.0, w_in=260.0, tau_out=-7.0, T_oil_in=345.0)["T_oil"] < 300.0
    q.close()


def test_defaults_at_the_operating_temperature_give_the_one_temperature_map(fmu):
    """How today's results stay: the operating temperature is a node of the map and a node
    returns its own map's solution unchanged, so while the grease is at the design's operating
    temperature (the heat balance's default start; the input held at it) the outputs are the
    map's of before, bit for bit."""
    d = DriveDesign()
    mm = ModeMap(d, "S1", 30.0, 350.0)
    p = Inst(fmu, use_T_oil_input=True)          # T_oil_in starts at the operating temperature
    for w, t in ((300.0, -10.0), (50.0, -0.5), (-120.0, 3.0)):
        v = advance(p, 1e-3, w_in=w, tau_out=t)
        assert v["T_oil"] == d.operating_temperature
        assert v["tau_in"] == mm.solve(w, t)[1][2]
        assert v["P_loss"] == pytest.approx(sum(mm.solve(w, t)[2]), rel=1e-12)
    p.close()
    q = Inst(fmu, w_in=300.0, tau_out=-10.0)     # the heat balance, at its start
    assert values(q)["tau_in"] == mm.solve(300.0, -10.0)[1][2]
    q.close()


def test_python_and_native_fmus_agree_for_the_calibrated_preset_while_warm(preset_fmus):
    """mackic-rig (calibrated: mesh_loss_k, idle_loss_scale) warming up from 15 degC with 60 s
    steps across the map's temperature nodes (the internal heat balance), then at a held warm
    temperature, then along a temperature trajectory on the input T_oil_in in all four
    quadrants: every output equal to 1e-9."""
    native, python = preset_fmus
    params = dict(T_oil_start=288.15, ambient_temperature=298.15, J_out=2e-3,
                  housing_heat_capacity=600.0)
    n, p = Inst(native, **params), Inst(python, **params)
    seen = set()
    for k in range(150):
        w = 220.0 * math.sin(0.05 * k) + 60.0
        t = -5.0 + 4.0 * math.sin(0.11 * k)
        a, b = advance(n, 60.0, w_in=w, tau_out=t), advance(p, 60.0, w_in=w, tau_out=t)
        for key in OUT:
            assert a[key] == pytest.approx(b[key], rel=RTOL, abs=ATOL), (k, key)
        seen.add(int(a["T_oil"] // 10))
    assert len(seen) >= 3                  # it crossed several nodes of the map
    n.close()
    p.close()
    n, p = (Inst(x, use_T_oil_input=True, T_oil_in=341.7) for x in preset_fmus)
    for k in range(40):
        w, t = 150.0 + 5 * k, -1.0 - 0.2 * k
        a, b = advance(n, 1e-3, w_in=w, tau_out=t), advance(p, 1e-3, w_in=w, tau_out=t)
        for key in OUT:
            assert a[key] == pytest.approx(b[key], rel=RTOL, abs=ATOL), (k, key)
    # and a measured-looking temperature trajectory on the input: 12 to 85 degC and back,
    # across every node of the map and between them, in all four quadrants
    seen = set()
    for k in range(200):
        T_in, w, t = _oil_trajectory(k)
        a = advance(n, 0.05, w_in=w, tau_out=t, T_oil_in=T_in)
        b = advance(p, 0.05, w_in=w, tau_out=t, T_oil_in=T_in)
        assert a["T_oil"] == b["T_oil"] == T_in
        for key in OUT:
            assert a[key] == pytest.approx(b[key], rel=RTOL, abs=ATOL), (k, key)
        seen.add((int(T_in // 10), w > 0, t * w < 0))
    assert len({x[0] for x in seen}) >= 7 and len({x[1:] for x in seen}) == 4
    n.close()
    p.close()


def test_a_warm_up_in_time_is_counted_once(preset_fmus):
    """One warm-up (docs/explanation/thermal.md): a warm-up in time (thermal_loss_change c,
    thermal_tau, what a diagnosis fits against the model held at one temperature) carries the
    losses' change; the heat balance still warms T_oil from the losses, but the losses stay at
    T_oil_start. So tau_in is the held model's plus c (1 - exp(-t/tau)) times its loss torque,
    to the rounding, while T_oil rises by kelvins (it would otherwise be counted twice); the
    heat balance's energy closes; Python and native FMU equal to 1e-9 (mackic-rig: calibrated,
    idle losses, PL_mesh)."""
    native, python = preset_fmus
    c, tau, T0 = 0.12, 400.0, 300.0
    params = dict(T_oil_start=T0, ambient_temperature=298.15, housing_heat_capacity=150.0,
                  thermal_loss_change=c, thermal_tau=tau)
    n, p = Inst(native, **params), Inst(python, **params)
    held = Inst(python, use_T_oil_input=True, T_oil_in=T0)   # the model at T_oil_start
    R = thermal.housing_resistance(DriveDesign())
    h, t, ledger = 10.0, 0.0, _HeatLedger()
    for k in range(120):
        w, tau_out = 260.0 + 30.0 * math.sin(0.07 * k), -6.0 - 2.0 * math.sin(0.13 * k)
        a, b = advance(n, h, w_in=w, tau_out=tau_out), advance(p, h, w_in=w, tau_out=tau_out)
        t += h
        for key in OUT:
            assert a[key] == pytest.approx(b[key], rel=RTOL, abs=ATOL), (k, key)
        m = advance(held, h, w_in=w, tau_out=tau_out)
        ratio = p.fmu.getReal([p.vr["w_out"]])[0] / w
        warm = c * (1 - math.exp(-t / tau)) * (m["tau_in"] + tau_out * ratio)
        assert b["tau_in"] == pytest.approx(m["tau_in"] + warm, rel=1e-12, abs=1e-14), k
        for key in ("PL1", "PL3", "PL6", "PL_support", "PL_churn", "PL_mesh"):
            assert b[key] == m[key], (k, key)       # the gear's losses at T_oil_start
        ledger.add(b, h)
        assert b["Q_ambient"] == pytest.approx((b["T_oil"] - 298.15) / R, rel=1e-12)
    assert b["T_oil"] > T0 + 5                      # the heat balance warmed the grease
    # energy: the loss over the steps = heat stored + heat to the ambient (trapezoid)
    assert ledger.heat(150.0, b["T_oil"]) == pytest.approx(ledger.loss, rel=5e-3)
    for x in (n, p, held):
        x.close()


def _per_10K_law(c, T, T_ref, theta):
    """The warm-up's relative loss change, closed form: c (T - T_ref)/10 K (theta 0), or the
    exponential law c (theta/10 K)(1 - exp(-(T - T_ref)/theta))."""
    if not theta:
        return c * (T - T_ref) / 10.0
    return c * theta / 10.0 * (1.0 - math.exp(-(T - T_ref) / theta))


@pytest.mark.parametrize("theta", [0.0, 25.0])
def test_a_warm_up_per_10K_follows_T_oil(preset_fmus, theta):
    """The warm-up's per-10 K form (thermal_loss_per_10K c, thermal_T_ref T_ref: what a
    diagnosis fits with a temperature column against the model held at one temperature): one
    warm-up, the model's losses held at T_oil_start times (1 + c (T_oil - T_ref)/10 K), or with
    thermal_T_scale theta = 25 K times (1 + c (theta/10 K)(1 - exp(-(T_oil - T_ref)/theta)))
    (the exponential law; not given: the linear law, as before it existed). Along
    a T_oil_in trajectory (12 to 85 degC, all four quadrants) tau_in is the held model's plus
    c (T_oil - T_ref)/10 K times its loss torque, the extra loss appears in P_loss and P_extra
    (tau_in w_in + tau_out w_out = P_loss: the energy balance exact), the gear's partial
    losses are the held model's; Python and native FMU equal to 1e-9; with the heat balance
    too (the grease warming from 15 degC), whose energy closes (mackic-rig: calibrated, idle
    losses, PL_mesh)."""
    native, python = preset_fmus
    c, T_ref = 0.08, 301.4
    extra = dict(thermal_loss_per_10K=c, thermal_T_ref=T_ref,
                 **({"thermal_T_scale": theta} if theta else {}))
    T0 = 305.0      # T_oil_start: the temperature the model is held at
    n, p = (Inst(x, use_T_oil_input=True, T_oil_in=T_ref, T_oil_start=T0, **extra)
            for x in preset_fmus)
    plain = Inst(python, use_T_oil_input=True, T_oil_in=T0)   # the model at T_oil_start
    seen = set()
    for k in range(160):
        T_in, w, t = _oil_trajectory(k)
        a = advance(n, 0.05, w_in=w, tau_out=t, T_oil_in=T_in)
        b = advance(p, 0.05, w_in=w, tau_out=t, T_oil_in=T_in)
        m = advance(plain, 0.05, w_in=w, tau_out=t)
        for key in OUT:
            assert a[key] == pytest.approx(b[key], rel=RTOL, abs=ATOL), (k, key)
        w_out = p.fmu.getReal([p.vr["w_out"]])[0]
        loss_in = m["tau_in"] + t * w_out / w if w else 0.0
        change = _per_10K_law(c, T_in, T_ref, theta) * loss_in
        assert b["tau_in"] == pytest.approx(m["tau_in"] + change, rel=1e-12, abs=1e-14), k
        assert b["P_loss"] == pytest.approx(b["tau_in"] * w + t * w_out, rel=1e-12, abs=1e-12)
        assert b["P_loss"] - m["P_loss"] == pytest.approx(change * w, rel=1e-9, abs=1e-12)
        P_extra = p.fmu.getReal([p.vr["P_extra"]])[0]
        assert P_extra == pytest.approx(change * w, rel=1e-9, abs=1e-12), k
        for key in ("PL1", "PL3", "PL6", "PL_support", "PL_churn", "PL_mesh"):
            assert b[key] == m[key], (k, key)       # the gear's own losses, held
        assert b["T_oil"] == T_in                   # while T_oil follows the input
        seen.add((int(T_in // 10), w > 0, t * w < 0))
    assert len({x[0] for x in seen}) >= 7 and len({x[1:] for x in seen}) == 4
    for x in (n, p, plain):
        x.close()
    # the heat balance: the extra loss heats the grease, and the grease's T drives the loss
    params = dict(T_oil_start=288.15, ambient_temperature=298.15, housing_heat_capacity=300.0,
                  **extra)
    n, p = Inst(native, **params), Inst(python, **params)
    R = thermal.housing_resistance(DriveDesign())
    h, ledger = 20.0, _HeatLedger()
    for k in range(120):
        w, tau_out = 260.0 + 30.0 * math.sin(0.07 * k), -6.0 - 2.0 * math.sin(0.13 * k)
        a, b = advance(n, h, w_in=w, tau_out=tau_out), advance(p, h, w_in=w, tau_out=tau_out)
        for key in OUT:
            assert a[key] == pytest.approx(b[key], rel=RTOL, abs=ATOL), (k, key)
        ledger.add(b, h)
        assert b["Q_ambient"] == pytest.approx((b["T_oil"] - 298.15) / R, rel=1e-12)
    assert b["T_oil"] > T_ref + 5                   # warmed past the reference: losses up
    assert ledger.heat(300.0, b["T_oil"]) == pytest.approx(ledger.loss, rel=5e-3)
    for x in (n, p):
        x.close()


def test_a_reference_temperature_out_of_range_is_refused_by_its_file_key(tmp_path):
    """thermal_T_ref is a grease temperature: the design file's key and degC in the error."""
    from model_core.design import design_from_toml, design_to_toml
    from model_core.errors import CycloidInputError
    text = design_to_toml(DriveDesign())
    assert "thermal_T_ref_degC = 20.0" in text
    p = tmp_path / "d.toml"
    p.write_text(text.replace("thermal_T_ref_degC = 20.0", "thermal_T_ref_degC = 500.0"))
    with pytest.raises(CycloidInputError, match=r"thermal_T_ref_degC = 500.0: must lie between "
                                                r"-100 and 200 degC"):
        design_from_toml(p)


def test_the_temperature_law_s_scale_is_carried_and_checked_by_the_design_file(tmp_path):
    """extra.thermal_T_scale (K): written and read back; 0 (the linear law) or at least
    thermal.T_SCALE_MIN, anything else refused naming the field. The law itself: slope
    1/(10 K) at the reference for every theta, the linear law its limit, and exactly
    (theta/10 K)(1 - 1/e) one theta above the reference."""
    from model_core.design import design_from_toml, design_to_toml, ExtraPhysics
    from model_core.errors import CycloidInputError
    text = design_to_toml(DriveDesign(extra=ExtraPhysics(thermal_T_scale=20.0)))
    assert "thermal_T_scale = 20.0" in text
    p = tmp_path / "d.toml"
    p.write_text(text)
    assert design_from_toml(p).extra.thermal_T_scale == 20.0
    for bad in ("0.5", "-20.0", "nan"):
        p.write_text(text.replace("thermal_T_scale = 20.0", f"thermal_T_scale = {bad}"))
        with pytest.raises(CycloidInputError, match="thermal_T_scale"):
            design_from_toml(p)
    g = thermal.loss_temperature_law
    for theta in (10.0, 20.0, 80.0):
        assert (g(1e-4, theta) - g(-1e-4, theta)) / 2e-4 == pytest.approx(0.1, rel=1e-6)
        assert g(theta, theta) == pytest.approx(theta / 10.0 * (1 - math.exp(-1.0)), rel=1e-14)
    assert g(7.0, 1e7) == pytest.approx(g(7.0), rel=1e-6) and g(7.0) == 0.7


@pytest.mark.parametrize("which", ["native", "python"])
def test_state_round_trip_restores_the_temperature(preset_fmus, which):
    path = preset_fmus[0] if which == "native" else preset_fmus[1]
    inst = Inst(path, T_oil_start=290.0)
    for k in range(5):
        advance(inst, 120.0, w_in=250.0, tau_out=-8.0)
    state = inst.fmu.getFMUstate()
    t_saved = inst.t
    first = [advance(inst, 120.0, w_in=250.0, tau_out=-8.0 + k) for k in range(4)]
    assert first[-1]["T_oil"] > values(inst)["T_oil"] - 1e-9 > 290.0
    inst.fmu.setFMUstate(state)
    inst.t = t_saved
    again = [advance(inst, 120.0, w_in=250.0, tau_out=-8.0 + k) for k in range(4)]
    assert again == first
    if which == "native":
        blob = inst.fmu.serializeFMUstate(state)
        restored = inst.fmu.deSerializeFMUstate(blob)
        inst.fmu.setFMUstate(restored)
        inst.t = t_saved
        assert [advance(inst, 120.0, w_in=250.0, tau_out=-8.0 + k) for k in range(4)] == first
        inst.fmu.freeFMUstate(restored)
    inst.fmu.freeFMUstate(state)
    inst.close()


def test_bad_temperatures_are_refused(preset_fmus):
    from fmpy.fmi1 import FMICallException
    n = Inst(preset_fmus[0], use_T_oil_input=True)
    n.set(T_oil_in=1000.0, w_in=100.0, tau_out=-1.0)
    with pytest.raises(FMICallException):
        n.fmu.doStep(currentCommunicationPoint=0.0, communicationStepSize=1e-3)
    assert any("T_oil_in" in m for _, m in n.messages)
    n.close()
    # an absurd loss (w_in = -1e308) would heat the grease beyond 200 degC: refused, not clamped
    n = Inst(preset_fmus[0])
    n.set(w_in=-1e308, tau_out=-3.0)
    with pytest.raises(FMICallException):
        n.fmu.doStep(currentCommunicationPoint=0.0, communicationStepSize=1e-3)
    assert any("heat balance" in m for _, m in n.messages)
    n.close()
    n = Inst(preset_fmus[0], start=False)
    n.fmu.setupExperiment(startTime=0.0)
    n.fmu.enterInitializationMode()
    with pytest.raises(FMICallException):
        n.set(housing_heat_capacity=-1.0)
    assert any("housing_heat_capacity" in m for _, m in n.messages)


# -- the diagnosis's fits onto the drive's temperature physics -------------------------------
def test_viscosity_fits_map_onto_the_lubricant_and_the_housing():
    """A viscosity drift per 10 K of a temperature column becomes the lubricant's own
    viscosity-temperature slope (the FMUs, given the temperature, then change the viscosity as
    the replay does; the replay keeps its field); a drift in time gives the housing the
    warm-up's time constant."""
    from model_core.effects import EFFECTS
    d = DriveDesign()
    eff = EFFECTS["viscosity_drift"]
    new, notes = eff.apply(d, {"ln_viscosity_change": -0.45}, None, temperature=True)
    assert new.extra.viscosity_ln_per_10K == -0.45           # the replay's, unchanged
    lub = new.lubricant

    def ln_nu(lu, T):
        return math.log(float(thermal.walther_viscosity(T, lu.kinematic_viscosity,
                                                        lu.kinematic_viscosity_100)))
    T0 = d.operating_temperature
    assert ln_nu(lub, T0) == pytest.approx(ln_nu(d.lubricant, T0), abs=1e-12)
    for dT in (-5.0, 5.0):   # the replay's linear form against Walther's line near T0
        assert ln_nu(lub, T0 + dT) - ln_nu(lub, T0) == pytest.approx(-0.045 * dT, rel=0.03)
    assert any("lubricant" in n for n in notes)
    new, notes = eff.apply(d, {"ln_viscosity_change": -0.8}, 600.0)
    assert thermal.housing_time_constant(new) == pytest.approx(600.0, rel=1e-12)
    assert new.extra.viscosity_ln_change == -0.8 and new.extra.viscosity_tau == 600.0
    # the paper profile has no temperature physics: replay only, the design's housing kept
    paper = DriveDesign(profile="paper")
    new, notes = eff.apply(paper, {"ln_viscosity_change": -0.8}, 600.0)
    assert new.housing_heat_capacity == paper.housing_heat_capacity
    assert any("replay only" in n for n in notes)


def test_fmi3_reducer_carries_the_temperature_as_the_fmi2_one(tmp_path):
    """CycloidDriveNative3 (the same C core behind the FMI 3 front): the warm-up and the
    Boolean use_T_oil_input reach it, and its numbers are the FMI 2 reducer's."""
    if GCC is None:
        pytest.skip("no C compiler")
    from fmpy import simulate_fmu
    from cyclo_fmu.fmu_build import build_any
    fmu2, fmu3 = (str(build_any(n, tmp_path)) for n in ("CycloidDriveNative",
                                                          "CycloidDriveNative3"))
    t = np.arange(401) * 0.5
    inp = np.array(list(zip(t, 200 + 60 * np.sin(t / 30), -(6 + 3 * np.cos(t / 20)))),
                   dtype=[("time", float), ("w_in", float), ("tau_out", float)])
    out = ["T_oil", "Q_ambient", "tau_in", "P_loss", "eta"]
    for start in ({"T_oil_start": 290.0, "housing_heat_capacity": 300.0},
                  {"use_T_oil_input": True, "T_oil_in": 345.0}):
        kw = dict(stop_time=200.0, output_interval=0.5, input=inp, start_values=start,
                  output=out)
        a, b = simulate_fmu(fmu2, **kw), simulate_fmu(fmu3, **kw)
        for name in out:
            np.testing.assert_array_equal(a[name], b[name], err_msg=name)
        if "use_T_oil_input" in start:
            assert np.all(b["T_oil"] == 345.0)
        else:
            assert b["T_oil"][-1] > 300.0          # warmed up by its own losses


@pytest.mark.parametrize("per_10K", [0.0, -0.2])
def test_housing_path_is_the_fmus_step_repeated(per_10K):
    """thermal.housing_path (the diagnosis's heat balance driven by the loss power) equals
    housing_step repeated sample by sample with the power of each step's start held, the
    power changed by the warm-up c (T - T_ref)/10 K where c is given (the FMUs' heat balance
    runs on their loss, warm-up included), on equal steps (the vectorised filter) and across a
    logger gap and a duplicated stamp (step by step); at a constant power it is the closed
    form T_amb + P R (1 - e^(-t/tau)) from a cold start."""
    t = np.arange(0.0, 200.0, 0.05)
    P = 18.0 + 6.0 * np.sin(t / 9.0) + 4.0 * (t > 80.0)
    R, C, amb, T_ref = 1.126, 60.0 / 1.126, 300.0, 300.0
    for tt in (t, np.concatenate([t[:1500], t[1500:1501], t[1500:] + 4.2])):
        PP = np.resize(P, tt.size)
        got = thermal.housing_path(tt, PP, amb, amb, C, R, per_10K, T_ref)
        want = [amb]
        for k in range(1, tt.size):
            Pk = PP[k - 1] * (1.0 + per_10K * (want[-1] - T_ref) / 10.0)
            want.append(thermal.housing_step(want[-1], Pk, tt[k] - tt[k - 1], amb, C, R))
        assert np.max(np.abs(got - np.array(want))) < 1e-9
    if not per_10K:
        flat = thermal.housing_path(t, np.full(t.size, 20.0), amb, amb, C, R)
        assert np.allclose(flat - amb, 20.0 * R * (1 - np.exp(-t / 60.0)), rtol=1e-12,
                           atol=1e-12)
