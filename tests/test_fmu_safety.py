"""What the FMUs refuse, and that a hostile host cannot make them write memory (issue 20, items 3
and 4; docs/explanation/fmu-safety.md).

Calls that crashed the host before are run in a subprocess, so that a regression fails the test
instead of killing the test run. The sanitizer runs (ASan + UBSan) are in test_sanitize.py.
"""
import ctypes
import json
import math
import os
import shutil
import struct
import subprocess
import sys
import textwrap
import zipfile

import numpy as np
import pytest

fmpy = pytest.importorskip("fmpy")
from fmpy import extract, read_model_description  # noqa: E402
from fmpy.fmi2 import FMU2Slave  # noqa: E402

from cyclo_fmu.native import build as nb  # noqa: E402
from fmu_helpers import Inst  # noqa: E402,F401 (also imported from here)

GCC = shutil.which("gcc") or shutil.which("cc")
pytestmark = pytest.mark.skipif(GCC is None, reason="no C compiler (the FMUs' C parts)")
ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


@pytest.fixture(scope="module")
def native(tmp_path_factory):
    return str(nb.build_native_fmu(dest=tmp_path_factory.mktemp("native")))


def run_py(code, timeout=120):
    """Run ``code`` in a fresh Python (this tree on the path); the completed process."""
    env = dict(os.environ, PYTHONPATH=ROOT)
    return subprocess.run([sys.executable, "-c", textwrap.dedent(code)], capture_output=True,
                          text=True, timeout=timeout, env=env)


def errors(inst):
    return " | ".join(m for s, m in inst.messages if s >= 3)


# -- format strings ---------------------------------------------------------------------------
HOSTILE = "0:%s%s%s%s%n%x"


@pytest.mark.parametrize("fmu_name, parameter", [
    ("FeltBrake", "torque_schedule"), ("InductionMotor", "frequency_schedule"),
    ("CycloidDrive", "mode"), ("CycloidDrive", "profile"), ("CycloidDrive", "losses"),
    ("CycloidDrive", "ring_rollers")])
@pytest.mark.parametrize("logging", [False, True])
def test_printf_directives_in_a_string_parameter_are_text(fmu_dir, fmu_name, parameter,
                                                          logging):
    """A String parameter with printf directives answers fmi2Error, names the value as text,
    and the host survives (pythonfmu hands the message over as a format: %s crashed the host,
    %n wrote memory)."""
    r = run_py(f"""
        from fmpy import simulate_fmu
        msgs = []
        def log(*a):
            msgs.append(a[-1].decode())
        try:
            simulate_fmu({str(fmu_dir / (fmu_name + '.fmu'))!r},
                         start_values={{{parameter!r}: {HOSTILE!r}}}, stop_time=0.01,
                         output_interval=1e-3, debug_logging={logging}, logger=log)
            print("RESULT ok")
        except Exception as exc:
            print("RESULT", type(exc).__name__, exc)
        print("LOG", " | ".join(msgs))
        """)
    assert r.returncode == 0, (r.returncode, r.stderr[-2000:])
    assert "RESULT FMICallException" in r.stdout and "status 3" in r.stdout, r.stdout
    log = r.stdout.split("LOG", 1)[1]
    # the value shown as the user gave it: no directive was executed
    assert HOSTILE.lower() in log.lower(), log


def test_a_percent_in_a_message_reaches_a_plain_host_as_text(fmu_dir):
    """A host that prints the message without formatting it sees no directive either (the
    front doubles every '%')."""
    r = run_py(f"""
        import ctypes
        from fmpy import extract, read_model_description
        from fmpy.fmi2 import FMU2Slave, fmi2CallbackFunctions, fmi2CallbackLoggerTYPE
        path = {str(fmu_dir / 'FeltBrake.fmu')!r}
        md = read_model_description(path)
        msgs = []
        def log(env, name, status, cat, message):
            msgs.append(message.decode())         # printed as it is, not formatted
        cb = fmi2CallbackFunctions()
        cb.logger = fmi2CallbackLoggerTYPE(log)
        f = FMU2Slave(guid=md.guid, unzipDirectory=extract(path), modelIdentifier="FeltBrake",
                      instanceName="b")
        f.instantiate(callbacks=cb)
        f.setupExperiment(startTime=0)
        f.enterInitializationMode()
        vr = {{v.name: v.valueReference for v in md.modelVariables}}
        f.setString([vr["torque_schedule"]], ["0 5%s"])
        try:
            f.exitInitializationMode()
        except Exception as exc:
            print("RESULT", exc)
        print("LOG", " | ".join(msgs))
        """)
    assert r.returncode == 0, r.stderr[-2000:]
    log = r.stdout.split("LOG", 1)[1]
    assert "5%%s" in log and "status 3" in r.stdout, r.stdout


# -- Python FMUs: GUID, state, FMI semantics ---------------------------------------------------
def test_python_fmu_guid_is_deterministic(fmu_dir, tmp_path):
    from cyclo_fmu.fmu_build import build_fmu
    again = build_fmu("FeltBrake", tmp_path)
    a = read_model_description(str(fmu_dir / "FeltBrake.fmu")).guid
    assert read_model_description(str(again)).guid == a
    assert read_model_description(str(fmu_dir / "Transducer.fmu")).guid != a


def _run(inst, n, inputs):
    out = []
    for k in range(n):
        inst.step(**inputs(inst.t))
        out.append(inst.get(*OUTPUTS[inst.md.coSimulation.modelIdentifier]))
    return out


OUTPUTS = {"CycloidDrive": ("tau_in", "P_loss", "tau_housing", "J_load", "P_stored"),
           "FeltBrake": ("tau_out", "T_brake", "torque_shaft"),
           "Transducer": ("y",), "InductionMotor": ("w", "alpha", "T_em", "frequency")}
SETUPS = {
    # dynamic physics (inertia, ripple, warm-up) and the output inertia: internal state
    "CycloidDrive": (dict(input_inertia=1e-4, ripple_1x=0.02, thermal_loss_change=0.1,
                          thermal_tau=0.05, J_out=2e-3),
                     lambda t: dict(w_in=100 + 400 * t, tau_out=-3 - t, alpha_in=400.0)),
    "FeltBrake": (dict(J_out=2e-3, torque_schedule="0 2; 0.01 6"),
                  lambda t: dict(w=10 + 100 * t)),
    "Transducer": (dict(noise=0.1, bandwidth=50.0, resolution=0.001),
                   lambda t: dict(x=math.sin(200 * t))),
    "InductionMotor": (dict(f_first=40.0, f_last=40.0),
                       lambda t: dict(tau_shaft=0.4, J_load=1e-4)),
}


@pytest.mark.parametrize("name", sorted(SETUPS))
def test_python_fmu_state_round_trip_is_exact(fmu_dir, name):
    path = str(fmu_dir / f"{name}.fmu")
    md = read_model_description(path)
    assert md.coSimulation.canGetAndSetFMUstate and md.coSimulation.canSerializeFMUstate
    params, inputs = SETUPS[name]
    a = Inst(path, **params)
    try:
        _run(a, 7, inputs)
        t0 = a.t
        state = a.fmu.getFMUState()
        blob = a.fmu.serializeFMUState(state)
        first = _run(a, 25, inputs)
        a.fmu.setFMUState(state)
        a.t = t0
        again = _run(a, 25, inputs)
        assert again == first                       # bit for bit
        a.fmu.freeFMUState(state)
        # serialised, into a second instance only instantiated (as fmusim's
        # --initial-fmu-state-file does it): the state carries Step Mode and the parameters
        b = Inst(path, name="other", start=False)
        try:
            b.fmu.setFMUState(b.fmu.deserializeFMUState(blob))
            b.t = t0
            assert _run(b, 25, inputs) == first
        finally:
            b.close()
    finally:
        a.close()


@pytest.mark.parametrize("corrupt", ["unknown entry", "wrong type", "unknown internal"])
def test_python_fmu_refuses_a_corrupted_state(fmu_dir, corrupt):
    """A serialised state is JSON of the slave's values: entries it does not know (pythonfmu
    would set them as attributes) or of another type are refused, nothing changed."""
    inst = Inst(str(fmu_dir / "FeltBrake.fmu"), J_out=2e-3)
    try:
        inst.step(w=3.0)
        st = inst.fmu.getFMUState()
        raw = bytes(inst.fmu.serializeFMUState(st))
        header, state = raw[:8], json.loads(raw[8:])      # the front's header: "CFST", phase
        assert header[:4] == b"CFST"
        inst.fmu.freeFMUState(st)
        if corrupt == "unknown entry":
            state["do_step"] = 1
        elif corrupt == "wrong type":
            state["J_out"] = "2e-3"
        else:
            state["_internal"]["_setup"] = None
        before = inst.get("tau_out", "T_brake")
        bad = inst.fmu.deserializeFMUState(header + json.dumps(state).encode())
        with pytest.raises(Exception):
            inst.fmu.setFMUState(bad)
        assert "not a state of this FMU" in errors(inst)
        inst.step(w=3.0)                                   # steps on as before
        assert all(math.isfinite(v) for v in inst.get("tau_out", "T_brake")) and before
    finally:
        inst.close()


MISUSE = """
import ctypes, json, math, sys
from fmpy import extract, read_model_description
from fmpy.fmi2 import FMU2Slave, fmi2CallbackFunctions, fmi2CallbackLoggerTYPE
path, param, bad_value = sys.argv[1], sys.argv[2], float(sys.argv[3])
md = read_model_description(path)
vr = {v.name: v.valueReference for v in md.modelVariables}
d = extract(path)
ident = md.coSimulation.modelIdentifier
msgs = []
def log(env, name, status, cat, message):
    msgs.append(message.decode())
cb = fmi2CallbackFunctions()
cb.logger = fmi2CallbackLoggerTYPE(log)
def report(case, ok):
    print(json.dumps([case, bool(ok), " | ".join(msgs[-2:])]), flush=True)
def new(guid=md.guid, kind=1):
    f = FMU2Slave(guid=guid, unzipDirectory=d, modelIdentifier=ident, instanceName="x")
    f.instantiate(callbacks=cb) if kind == 1 else None
    return f
def fails(fn, *a):
    try:
        fn(*a)
        return False
    except Exception:
        return True
lib = ctypes.CDLL(f"{d}/binaries/linux64/{ident}.so")
inst = lib.fmi2Instantiate
inst.restype = ctypes.c_void_p
inst.argtypes = [ctypes.c_char_p, ctypes.c_int, ctypes.c_char_p, ctypes.c_char_p,
                 ctypes.c_void_p, ctypes.c_int, ctypes.c_int]
d = str(d)
uri = ("file://" + d + "/resources").encode()
report("wrong GUID", fails(new, "{00000000-0000-0000-0000-000000000000}"))
report("model exchange", inst(b"x", 0, md.guid.encode(), uri, ctypes.addressof(cb), 0, 0) is None)
report("NULL instance name", inst(None, 1, md.guid.encode(), uri, ctypes.addressof(cb), 0, 0) is None)
report("NULL resource location", inst(b"x", 1, md.guid.encode(), None, ctypes.addressof(cb), 0, 0) is None)
report("NULL callbacks", inst(b"x", 1, md.guid.encode(), uri, None, 0, 0) is None)
for name in ("fmi2DoStep", "fmi2ExitInitializationMode", "fmi2Terminate"):
    fn = getattr(lib, name)
    fn.argtypes = [ctypes.c_void_p, ctypes.c_double, ctypes.c_double, ctypes.c_int][:4 if name == "fmi2DoStep" else 1]
    report(f"NULL component {name}", fn(None, *((0.0, 1e-3, 1) if name == "fmi2DoStep" else ())) == 3)
f = new()
c = ctypes.c_void_p(f.component)
get = lib.fmi2GetReal
get.argtypes = [ctypes.c_void_p, ctypes.c_void_p, ctypes.c_size_t, ctypes.c_void_p]
report("NULL value arrays get", get(c, None, 2, None) == 3)
setr = lib.fmi2SetReal
setr.argtypes = get.argtypes
report("NULL value arrays set", setr(c, None, 2, None) == 3)
dbg = lib.fmi2SetDebugLogging
dbg.argtypes = [ctypes.c_void_p, ctypes.c_int, ctypes.c_size_t, ctypes.c_void_p]
report("NULL log categories", dbg(c, 1, 2, None) == 3)
report("step before initialization", fails(f.doStep, 0.0, 1e-3))
report("exit before enter", fails(f.exitInitializationMode))
f.setupExperiment(startTime=0.0)
f.enterInitializationMode()
f.exitInitializationMode()
for h in (-1e-3, float("nan"), float("inf")):
    report(f"step size {h}", fails(f.doStep, 0.0, h))
report("parameter after initialization", fails(f.setReal, [vr[param]], [1.0]))
report("a good step still runs", not fails(f.doStep, 0.0, 1e-3))
f.terminate()
f.freeInstance()
g = new()
g.setupExperiment(startTime=0.0)
g.enterInitializationMode()
g.setReal([vr[param]], [bad_value])
report("failed initialization", fails(g.exitInitializationMode))
report("step after failed initialization", fails(g.doStep, 0.0, 1e-3))
report("its message is clear", "AttributeError" not in msgs[-1] and "fmi2ExitInitializationMode" in msgs[-1])
g.freeInstance()
print("END", flush=True)
"""


@pytest.mark.parametrize("name, param, bad", [("CycloidDrive", "alpha_ref", -1.0),
                                              ("FeltBrake", "w_reg", -1.0),
                                              ("Transducer", "noise", -1.0),
                                              ("InductionMotor", "J", -1.0)])
def test_python_fmu_refuses_misuse_with_fmi2error(fmu_dir, name, param, bad):
    """Each misuse answered with fmi2Error (or a NULL instance), never a crash: a wrong GUID,
    Model Exchange, NULL arguments, calls out of order, a bad step size, a parameter set after
    initialization, a step after a failed initialization (with a clear message)."""
    r = subprocess.run([sys.executable, "-c", MISUSE, str(fmu_dir / f"{name}.fmu"), param,
                        repr(bad)], capture_output=True, text=True, timeout=120,
                       env=dict(os.environ, PYTHONPATH=ROOT))
    lines = [json.loads(x) for x in r.stdout.splitlines() if x.startswith("[")]
    assert r.returncode == 0 and r.stdout.rstrip().endswith("END"), (
        r.returncode, lines[-1:] if lines else None, r.stderr[-1500:])
    bad_cases = [(case, msg) for case, ok, msg in lines if not ok]
    assert not bad_cases, bad_cases


def test_python_fmu_leaves_the_hosts_allocator_alone(fmu_dir):
    """The reducer solving a map (a mode not shipped) asks libc for neither mallopt nor
    malloc_trim and leaves the environment as it was."""
    r = run_py(f"""
        import ctypes, os
        looked_up = []
        class Recording(ctypes.CDLL):
            def __getattr__(self, name):
                looked_up.append(name)
                return super().__getattr__(name)
            def __getitem__(self, name):
                looked_up.append(name)
                return super().__getitem__(name)
        ctypes.CDLL = Recording
        env = dict(os.environ)
        from fmpy import simulate_fmu
        simulate_fmu({str(fmu_dir / 'CycloidDrive.fmu')!r}, start_values={{"mode": "12"}},
                     stop_time=0.002, output_interval=1e-3)
        print("LOOKED_UP", sorted(set(looked_up)))
        print("ENV_SAME", dict(os.environ) == env)
        """)
    assert r.returncode == 0, r.stderr[-2000:]
    assert "mallopt" not in r.stdout and "malloc_trim" not in r.stdout, r.stdout
    assert "ENV_SAME True" in r.stdout


def test_python_fmu_refuses_inputs_that_give_no_finite_outputs(fmu_dir):
    inst = Inst(str(fmu_dir / "CycloidDrive.fmu"))
    try:
        with pytest.raises(Exception):
            inst.step(w_in=100.0, tau_out=-1e308)
        assert "not finite" in errors(inst)
    finally:
        inst.close()


@pytest.mark.parametrize("name, params, inputs", [
    ("InductionMotor", {}, dict(tau_shaft=-1e308, J_load=0.0)),
    ("Transducer", dict(scale=1e3), dict(x=1e308)),
    ("FeltBrake", dict(J_out=2e-3), dict(w=1e308))])
def test_python_rig_fmus_refuse_inputs_that_give_no_finite_outputs(fmu_dir, name, params,
                                                                  inputs):
    inst = Inst(str(fmu_dir / f"{name}.fmu"), **params)
    try:
        with pytest.raises(Exception):
            for _ in range(3):
                inst.step(**inputs)
        assert "not a finite number" in errors(inst), inst.messages
    finally:
        inst.close()


def test_slave_messages_escape_percent():
    """pythonfmu hands a message over as a printf format (also in the win64 binary, which has
    no C front): every '%' of a slave's message is escaped."""
    from cyclo_fmu.slaves.brake import FeltBrake
    slave = FeltBrake(instance_name="x")
    slave.log("schedule '0:%s%n' refused")
    assert slave.log_queue[-1].msg == "schedule '0:%%s%%n' refused"


# -- native FMU --------------------------------------------------------------------------------
def _state_blob(native, **params):
    """A serialised state of the native FMU after one step with distinctive values."""
    inst = Inst(native, start=False)
    inst.fmu.setupExperiment(startTime=9876.54321)
    inst.fmu.enterInitializationMode()
    inst.set(J_out=0.0123, alpha_ref=777.25, ripple_1x=0.01, **params)
    inst.fmu.exitInitializationMode()
    inst.t = 9876.54321
    inst.step(dt=0.5, w_in=100.125, tau_out=-3.0, alpha_in=1234.5678)
    st = inst.fmu.getFMUState()
    blob = bytes(inst.fmu.serializeFMUState(st))
    inst.fmu.freeFMUState(st)
    return inst, blob


@pytest.mark.parametrize("field, value, bad", [
    ("alpha_in", 1234.5678, math.nan), ("J_out", 0.0123, -1.0), ("alpha_ref", 777.25, 0.0),
    ("t_start", 9876.54321, math.inf), ("theta", 100.125 * 0.5, math.nan),
    ("w_last", 100.125, math.nan)])
def test_native_refuses_a_corrupted_state(native, field, value, bad):
    inst, blob = _state_blob(native)
    try:
        packed = struct.pack("<d", value)
        assert blob.count(packed) >= 1, field
        corrupted = blob.replace(packed, struct.pack("<d", bad))
        with pytest.raises(Exception):
            inst.fmu.deserializeFMUState(corrupted)
        assert "corrupted state" in errors(inst), errors(inst)
        # the good one is taken and steps on
        inst.fmu.setFMUState(inst.fmu.deserializeFMUState(blob))
        inst.step(w_in=100.0, tau_out=-3.0)
        assert all(math.isfinite(v) for v in inst.get("tau_in", "P_loss", "J_load"))
    finally:
        inst.close()


def test_native_refuses_allocate_without_free(native):
    from fmpy import fmi2
    md = read_model_description(native)
    d = extract(native)
    msgs = []
    cb = fmi2.fmi2CallbackFunctions()
    cb.logger = fmi2.fmi2CallbackLoggerTYPE(lambda *a: msgs.append(a[-1]))
    cb.allocateMemory = fmi2.fmi2CallbackAllocateMemoryTYPE(fmi2.calloc)
    # freeMemory left NULL: the FMU must not hand the host's block to its own free()
    f = FMU2Slave(guid=md.guid, unzipDirectory=d, modelIdentifier="CycloidDriveNative",
                  instanceName="x")
    with pytest.raises(Exception):
        f.instantiate(callbacks=cb)
    assert any(b"freeMemory" in m for m in msgs), msgs
    shutil.rmtree(d, ignore_errors=True)


def test_native_parameter_limits_match_the_declared_ones(native):
    md = read_model_description(native)
    var = {v.name: v for v in md.modelVariables}
    for name in ("stribeck_speed", "thermal_tau", "alpha_ref"):
        lo = float(var[name].min)
        assert 0 < lo <= sys.float_info.min, name
        inst = Inst(native, start=False)
        try:
            inst.fmu.setupExperiment(startTime=0.0)
            inst.fmu.enterInitializationMode()
            inst.set(**{name: lo})                         # the declared min is accepted
            with pytest.raises(Exception):
                inst.set(**{name: 0.0})                    # what lies below it is not
        finally:
            inst.close()
    assert float(var["thermal_loss_change"].min) == -1.0
    inst = Inst(native, start=False)
    try:
        inst.fmu.setupExperiment(startTime=0.0)
        inst.fmu.enterInitializationMode()
        inst.set(thermal_loss_change=-1.0)
        with pytest.raises(Exception):
            inst.set(thermal_loss_change=-1.5)
        assert "thermal_loss_change" in errors(inst)
    finally:
        inst.close()
    # the per-10 K warm-up's reference: a grease temperature (-100 to 200 degC), as T_oil_start
    assert float(var["thermal_T_ref"].min) == 173.15
    inst = Inst(native, start=False)
    try:
        inst.fmu.setupExperiment(startTime=0.0)
        inst.fmu.enterInitializationMode()
        inst.set(thermal_T_ref=250.0, thermal_loss_per_10K=-0.3)
        with pytest.raises(Exception):
            inst.set(thermal_T_ref=150.0)
        assert "thermal_T_ref" in errors(inst)
    finally:
        inst.close()


def test_native_drag_exponent_acts_in_initialization_mode(native):
    md = read_model_description(native)
    init = {u.variable.name: {d.name for d in u.dependencies} for u in md.initialUnknowns}
    inst = Inst(native, start=False)
    try:
        inst.fmu.setupExperiment(startTime=0.0)
        inst.fmu.enterInitializationMode()
        inst.set(drag_torque=0.1, w_in=100.0, tau_out=-3.0)
        a = inst.get("tau_in", "P_loss", "eta")
        inst.set(drag_exponent=1.5)
        b = inst.get("tau_in", "P_loss", "eta")
        changed = {n for n, x, y in zip(("tau_in", "P_loss", "eta"), a, b) if x != y}
        assert changed == {"tau_in", "P_loss", "eta"}
        assert all("drag_exponent" in init[n] for n in changed)
    finally:
        inst.close()


def test_native_refuses_inputs_that_give_no_finite_outputs(native):
    inst = Inst(native, J_out=1e-3)
    try:
        inst.step(w_in=100.0, tau_out=-3.0)
        before = inst.get("tau_in", "P_loss")
        with pytest.raises(Exception):
            inst.step(w_in=100.0, tau_out=-1e308)
        assert "not finite" in errors(inst)
        assert inst.get("tau_in", "P_loss") == before      # the state before the call
        for bad in (math.nan, math.inf, -math.inf):
            with pytest.raises(Exception):
                inst.set(w_in=bad)
    finally:
        inst.close()


@pytest.mark.parametrize("inputs", [dict(w_in=-1e308), dict(alpha_in=1e308),
                                    dict(tau_out=1e200)])
def test_native_clamps_far_inputs_with_a_warning(native, inputs):
    """Inputs far beyond the map whose outputs stay finite: eta0 held at the map's edge, and
    the step that first leaves the map answers fmi2Warning with the reason (documented). The
    grease is held at its temperature: the heat balance would take the loss of such inputs
    (up to 1e308 W) beyond 200 degC and refuse the step (tests/test_thermal.py)."""
    from fmpy import fmi2
    inst = Inst(native, J_out=1e-3, use_T_oil_input=True)
    try:
        inst.step(w_in=100.0, tau_out=-3.0)
        inst.set(**{**dict(w_in=100.0, tau_out=-3.0, alpha_in=0.0), **inputs})
        status = inst.fmu.fmi2DoStep(inst.fmu.component, 1e-3, 1e-3, fmi2.fmi2True)
        assert status == 1                                 # fmi2Warning
        assert any(s == 1 and "beyond the loss map" in m for s, m in inst.messages)
        assert all(math.isfinite(v) for v in inst.get(*OUTPUTS["CycloidDrive"]))
    finally:
        inst.close()


# -- both reducers -----------------------------------------------------------------------------
@pytest.mark.parametrize("mode", ["S1", "S2"])
@pytest.mark.parametrize("which", ["native", "python"])
def test_torque_balance_closes_on_the_housing(native, fmu_dir, mode, which):
    """tau_in + tau_out + tau_housing = 0 with the default (physical) losses: the shafts' drag
    (bearings, seals, grease) reacts on the housing. Before, 0.12-0.14 N*m were missing in S1."""
    path = native if which == "native" else str(fmu_dir / "CycloidDrive.fmu")
    inst = Inst(path, mode=mode)
    try:
        for w, t in ((104.7, -3.0), (293.2, -8.0), (-200.0, 5.0), (150.0, 4.0)):
            inst.step(w_in=w, tau_out=t)
            tau_in, tau_h, PL_support, PL_seal = inst.get("tau_in", "tau_housing",
                                                          "PL_support", "PL_seal")
            assert abs(tau_in + t + tau_h) <= 1e-12 * (abs(tau_in) + abs(t)), (w, t)
            # the drag is there, and the housing carries it (not a zero-loss case)
            assert PL_support + PL_seal > 0.1
    finally:
        inst.close()


# -- the binaries ------------------------------------------------------------------------------
def _elf_checks(so):
    dyn = subprocess.run(["readelf", "-dW", so], capture_output=True, text=True).stdout
    seg = subprocess.run(["readelf", "-lW", so], capture_output=True, text=True).stdout
    syms = subprocess.run(["readelf", "--dyn-syms", "-W", so], capture_output=True,
                          text=True).stdout
    rec = subprocess.run(["readelf", "-p", ".GCC.command.line", so], capture_output=True,
                         text=True).stdout
    return dyn, seg, syms, rec


@pytest.mark.skipif(shutil.which("readelf") is None, reason="no readelf (binutils)")
def test_every_native_binary_is_hardened(native, fmu_dir, tmp_path):
    from cyclo_fmu.bench import _cached_loop
    d = extract(native)
    shim_dir = tmp_path / "shim"
    with zipfile.ZipFile(fmu_dir / "FeltBrake.fmu") as z:
        z.extract("binaries/linux64/FeltBrake.so", shim_dir)
    binaries = {
        "native FMU": (os.path.join(d, "binaries", "linux64", "CycloidDriveNative.so"), True),
        "pythonfmu front": (str(shim_dir / "binaries" / "linux64" / "FeltBrake.so"), True),
        "bench loop": (str(_cached_loop(GCC, cache=tmp_path / "cache")), False)}
    for what, (so, has_buffers) in binaries.items():
        dyn, seg, syms, rec = _elf_checks(so)
        assert "BIND_NOW" in dyn or "NOW" in dyn, what           # full RELRO: bound at load
        assert "GNU_RELRO" in seg, what
        assert "GNU_STACK" in seg and "RWE" not in seg, what     # no executable stack
        assert "-fstack-protector-strong" in rec and "-fPIC" in rec and "-O2" in rec, what
        if has_buffers:   # functions with char arrays: the canary and the checked calls
            assert "__stack_chk_fail" in syms, what
            assert "_chk" in syms.replace("__stack_chk_fail", ""), what    # _FORTIFY_SOURCE
    shutil.rmtree(d, ignore_errors=True)


def test_bench_loop_cache_is_verified(tmp_path):
    from cyclo_fmu.bench import _cached_loop
    lib = _cached_loop(GCC, cache=tmp_path)
    good = lib.read_bytes()
    assert (lib.parent / (lib.name + ".sha256")).is_file()
    lib.write_bytes(good[:-1] + bytes([good[-1] ^ 1]))    # one bit changed
    again = _cached_loop(GCC, cache=tmp_path)
    assert again == lib and again.read_bytes() == good       # rebuilt, not loaded as it was
    # another compiler (or flags) gives another file
    assert _cached_loop(GCC, cache=tmp_path).name == lib.name


def test_bench_loop_refuses_inconsistent_counts(tmp_path):
    from cyclo_fmu.bench import _cached_loop
    lib = ctypes.CDLL(str(_cached_loop(GCC, cache=tmp_path)))
    fn = lib.bench_loop
    fn.restype = ctypes.c_long
    P = ctypes.c_void_p
    n_comp = 1
    dummy = ctypes.CFUNCTYPE(ctypes.c_int)(lambda: 0)
    comps = (P * 1)(1)
    fns = (P * 1)(ctypes.cast(dummy, P).value)
    vrs = (ctypes.POINTER(ctypes.c_uint) * 1)((ctypes.c_uint * 1)(0))
    buf = (ctypes.c_double * 4)()
    rows = (ctypes.c_double * 40)()
    fail = (ctypes.c_int * 3)()

    def call(n_in=1, in_off=0, n_out=1, out_off=1, dst=0, src=1, buf_len=4, rows_cap=10,
             n_steps=10):
        links = (ctypes.c_int * 2)(0, 1)
        return fn(n_comp, comps, fns, fns, fns, vrs, (ctypes.c_size_t * 1)(n_in),
                  (ctypes.c_int * 1)(in_off), vrs, (ctypes.c_size_t * 1)(n_out),
                  (ctypes.c_int * 1)(out_off), links, (ctypes.c_int * 1)(dst),
                  (ctypes.c_int * 1)(src), 1, buf, buf_len, rows, ctypes.c_long(rows_cap), 4,
                  ctypes.c_long(0), ctypes.c_long(n_steps), ctypes.c_double(1e-3), fail)
    for bad in (dict(in_off=4), dict(n_in=5), dict(out_off=-1), dict(dst=4), dict(src=-1),
                dict(n_steps=11), dict(buf_len=3), dict(n_out=1 << 40)):
        assert call(**bad) == -1, bad
