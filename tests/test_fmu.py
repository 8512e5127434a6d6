"""The CycloidDrive FMU in fmpy: model description, agreement with the core, energy balance,
isolation of instances, reset, errors that do not crash the host."""
import subprocess
import sys
import textwrap
import xml.etree.ElementTree as ET
import zipfile

import numpy as np
import pytest

fmpy = pytest.importorskip("fmpy")
from fmpy import read_model_description, simulate_fmu  # noqa: E402
from fmpy.fmi1 import FMICallException  # noqa: E402

from fmu_helpers import Inst  # noqa: E402
from model_core import DriveDesign, Friction, operating_point, rpm_to_rad_s  # noqa: E402

IDX = {"1": 0, "2": 1, "S": 2}


class Instance(Inst):
    """The reducer FMU started with debug logging on (tests/fmu_helpers.py); ``messages``
    holds (status, text) pairs."""

    def __init__(self, path, name="inst", **params):
        super().__init__(path, name, logging=True, **params)


def test_validates_with_units_and_structure(fmu):
    from fmpy.validation import validate_fmu
    assert validate_fmu(fmu) == []
    xml = zipfile.ZipFile(fmu).read("modelDescription.xml")
    root = ET.fromstring(xml)
    assert root.find("CoSimulation").get("needsExecutionTool") == "false"
    units = {u.get("name") for u in root.find("UnitDefinitions")}
    assert {"rad/s", "N.m", "W", "m"} <= units
    for sv in root.find("ModelVariables"):
        real = sv.find("Real")
        if real is not None:
            assert real.get("unit"), sv.get("name")
        assert sv.get("description"), sv.get("name")
    names = [sv.get("name") for sv in root.find("ModelVariables")]
    outs = {names[int(u.get("index")) - 1]: u.get("dependencies")
            for u in root.find("ModelStructure/Outputs")}
    assert outs["w_out"] == str(names.index("w_in") + 1)        # w_out does not depend on tau_out
    assert len(outs["tau_in"].split()) == 4            # w_in, tau_out, alpha_in, T_oil_in
    assert len(root.find("ModelStructure/InitialUnknowns")) == len(outs)


@pytest.mark.parametrize("mode", ["S1", "S2"])
def test_map_and_exact_agree_with_core(fmu, mode):
    d = DriveDesign()
    for exact in (False, True):
        # the grease held at the design's temperature (the heat balance would warm it)
        inst = Instance(fmu, mode=mode, exact=exact, use_T_oil_input=True)
        worst = 0.0
        for rpm in (1000.0, 2800.0):
            for T in (0.3, 0.85):
                op = operating_point(d, mode, rpm_to_rad_s(rpm), T)
                b = mode[1]
                inst.step(w_in=rpm_to_rad_s(rpm), tau_out=float(op.torques[b]))
                eta, tau_in, w_out = inst.get("eta", "tau_in", "w_out")
                worst = max(worst, abs(eta - float(op.eta)))
                assert w_out == pytest.approx(float(op.speeds[b]), rel=1e-12)
                if exact:
                    assert tau_in == pytest.approx(float(op.torques["S"]), rel=1e-9)
        assert worst < (1e-9 if exact else 1e-3), (exact, worst)
        inst.close()


def test_outputs_valid_after_initialization(fmu):
    inst = Instance(fmu, mode="S1", w_in=293.0, tau_out=-8.0)
    tau_in, p_loss = inst.get("tau_in", "P_loss")
    assert tau_in > 0 and p_loss > 0
    inst.close()


PARTS = ("PL1", "PL2", "PL3", "PL5", "PL6", "PL_support", "PL_seal", "PL_churn")


@pytest.mark.parametrize("exact", [False, True])
def test_load_independent_losses_have_their_own_outputs(fmu, exact):
    """The physical profile's seal, support-bearing and churning losses come out under their
    own names, equal to the core's at the operating point (map: within its interpolation),
    and with the load-dependent ones they make up P_loss."""
    inst = Instance(fmu, mode="S1", exact=exact, use_T_oil_input=True)   # the design's T
    inst.step(w_in=250.0, tau_out=-7.0)
    op = operating_point(DriveDesign(), "S1", 250.0, T_out=-7.0)
    got = dict(zip(PARTS, inst.get(*PARTS)))
    for n in ("PL_support", "PL_seal", "PL_churn"):
        assert got[n] == pytest.approx(float(getattr(op.losses, n)), rel=1e-9 if exact else 2e-2)
        assert got[n] > 0
    assert sum(got.values()) == pytest.approx(inst.get("P_loss")[0], rel=1e-9)
    inst.close()


def test_energy_balance_every_step_all_quadrants(fmu):
    inst = Instance(fmu, mode="S2")
    rng = np.random.default_rng(1)
    for k in range(200):
        w = rng.uniform(-300, 300)
        tau = rng.uniform(-9, 9)
        inst.step(w_in=w, tau_out=tau)
        tau_in, w_out, p_loss, parts = inst.get("tau_in", "w_out", "P_loss")[0], \
            inst.get("w_out")[0], inst.get("P_loss")[0], inst.get(*PARTS)
        assert tau_in * w + tau * w_out == pytest.approx(p_loss, rel=1e-9, abs=1e-12)
        assert p_loss >= 0
        assert sum(parts) == pytest.approx(p_loss, rel=1e-9, abs=1e-12)
    inst.close()


def test_two_instances_do_not_interfere(fmu):
    a = Instance(fmu, "a", mode="S1")
    b = Instance(fmu, "b", mode="S2", mu_boundary=0.15)
    d_b = DriveDesign(friction=Friction(mu_boundary=0.15))
    for _ in range(3):
        a.step(w_in=250.0, tau_out=-7.0)
        b.step(w_in=250.0, tau_out=7.0)
    ea, eb = a.get("eta")[0], b.get("eta")[0]
    assert ea == pytest.approx(float(operating_point(DriveDesign(), "S1", 250.0, T_out=-7.0).eta), abs=1e-3)
    assert eb == pytest.approx(float(operating_point(d_b, "S2", 250.0, T_out=7.0).eta), abs=1e-3)
    a.close()
    b.close()


def test_reset(fmu):
    inst = Instance(fmu, mode="S1")
    inst.step(w_in=250.0, tau_out=-7.0)
    first = inst.get("tau_in")[0]
    inst.fmu.reset()
    inst.start(mode="S1")
    inst.step(w_in=250.0, tau_out=-7.0)
    assert inst.get("tau_in")[0] == pytest.approx(first, rel=1e-14)
    inst.fmu.reset()
    inst.start(mode="S2")
    inst.step(w_in=250.0, tau_out=7.0)
    assert inst.get("w_out")[0] == pytest.approx(-250.0 / 14, rel=1e-12)
    inst.close()


def test_nan_input_is_fmi2error_with_message(fmu):
    inst = Instance(fmu, mode="S1")
    with pytest.raises(FMICallException):
        inst.step(w_in=float("nan"), tau_out=-7.0)
    assert any("w_in" in m and "finite" in m for _, m in inst.messages), inst.messages


@pytest.mark.parametrize("params, word", [(dict(mode="S3"), "mode"), (dict(e=-0.002), "e"),
                                          (dict(mesh_loss_k=0.7), "mesh_loss_k"),
                                          (dict(idle_loss_scale=-1.0), "idle_loss_scale"),
                                          (dict(load_loss_scale=11.0), "load_loss_scale"),
                                          (dict(thermal_T_scale=0.5), "thermal_T_scale = 0.5"),
                                          (dict(thermal_T_scale=-20.0), "thermal_T_scale"),
                                          (dict(loss_transition=-0.1), "loss_transition")])
def test_invalid_parameter_fails_at_initialization(fmu, params, word):
    md = read_model_description(fmu)
    inst = Instance.__new__(Instance)
    with pytest.raises(FMICallException):
        Instance.__init__(inst, fmu, **params)
    assert any(word in m and "invalid parameter" in m for _, m in inst.messages), inst.messages


def test_simulate_fmu_in_fresh_process(fmu, tmp_path):
    """The bundled copy runs in a process that never imported the project's packages."""
    script = tmp_path / "run.py"
    script.write_text(textwrap.dedent(f"""
        import sys, numpy as np
        from fmpy import simulate_fmu
        inp = np.array([(0.0, 293.0, -8.0), (1.0, 293.0, -8.0)],
                       dtype=[("time", float), ("w_in", float), ("tau_out", float)])
        r = simulate_fmu({fmu!r}, stop_time=0.1, output_interval=0.01, input=inp,
                         output=["eta", "P_loss"])
        assert "model_core" not in sys.modules and "cyclo_fmu" not in sys.modules
        print(r["eta"][-1], r["P_loss"][-1])
    """))
    r = subprocess.run([sys.executable, str(script)], capture_output=True, text=True,
                       cwd=tmp_path, timeout=300)
    assert r.returncode == 0, r.stderr
    eta, p = map(float, r.stdout.strip().splitlines()[-1].split())   # after any fmpy warning
    assert eta == pytest.approx(float(operating_point(DriveDesign(), "S1", 293.0, T_out=-8.0).eta), abs=1e-3)


def test_load_unload_load_in_one_process(fmu):
    """fmpy unloads the library after each simulate_fmu; loading it again must work."""
    inp = np.array([(0.0, 293.0, -8.0), (1.0, 293.0, -8.0)],
                   dtype=[("time", float), ("w_in", float), ("tau_out", float)])
    etas = [simulate_fmu(fmu, stop_time=0.05, output_interval=0.01, input=inp,
                         output=["eta"])["eta"][-1] for _ in range(3)]
    assert etas[0] > 0.6 and etas[0] == etas[1] == etas[2]


def test_the_profile_is_a_parameter(fmu):
    """profile = 'paper' (with the paper's load-dependent losses) gives the paper profile's
    numbers; the default gives the physical profile's; a bad profile is an fmi2Error naming
    the field."""
    paper = DriveDesign(profile="paper", losses="load_dependent")
    for params, design in (({}, DriveDesign()),
                           ({"profile": "paper", "losses": "load_dependent"}, paper)):
        inst = Instance(fmu, mode="S1", exact=True, use_T_oil_input=True, **params)
        inst.step(w_in=250.0, tau_out=-7.0)
        op = operating_point(design, "S1", 250.0, T_out=-7.0)
        assert inst.get("eta")[0] == pytest.approx(float(op.eta), rel=1e-9)
        inst.close()
    assert float(operating_point(paper, "S1", 250.0, T_out=-7.0).eta) < 0.7 < float(
        operating_point(DriveDesign(), "S1", 250.0, T_out=-7.0).eta)
    with pytest.raises(Exception):
        Instance(fmu, "bad", mode="S1", profile="bogus")
