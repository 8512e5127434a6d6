"""CycloidDriveNative.fmu: the reducer as an FMI 2.0 co-simulation FMU in C.

It validates clean, carries no Python, runs in a bare C host with an empty environment, agrees
with the Python FMU CycloidDrive.fmu (map mode) to 1e-9 relative in every quadrant and at
self-locking points, restores saved and serialised states, gives its f_init outputs in
Initialization Mode, keeps two designs in one process apart, and answers bad input with
fmi2Error and a logged message. The C re-expressions of the Python formulas (map look-up,
Kreines torques, drag, Stribeck, inertia, ripple, warm-up) are compared one by one.
"""
import ctypes
import math
import os
import shutil
import subprocess
import sys
import zipfile

import numpy as np
import pytest

fmpy = pytest.importorskip("fmpy")
from fmpy import extract, read_model_description  # noqa: E402
from fmpy.fmi1 import FMICallException  # noqa: E402

from cyclo_fmu.native import build as nb  # noqa: E402
from fmu_helpers import REDUCER_OUTPUTS, Inst  # noqa: E402,F401 (Inst: imported from here too)
from model_core import DriveDesign, Friction, kinematics  # noqa: E402
from model_core.design import ExtraPhysics, design_to_toml  # noqa: E402
from model_core.lossmap import ModeMap  # noqa: E402

GCC = shutil.which("gcc") or shutil.which("cc")
pytestmark = pytest.mark.skipif(GCC is None, reason="no C compiler")

OUT = REDUCER_OUTPUTS
#: agreement required with the Python FMU (issue 7)
RTOL = 1e-9
#: absolute floor for values that are zero in one FMU and a rounding residue in the other [W,
#: N*m]: P_loss = tau_in w_in + tau_out w_out is a difference of products of order 1e3
ATOL = 1e-12


@pytest.fixture(scope="module")
def native(tmp_path_factory):
    return str(nb.build_native_fmu(dest=tmp_path_factory.mktemp("native")))


@pytest.fixture(scope="module")
def native_dir(native):
    return extract(native)


def assert_same(a, b, what=""):
    for k in OUT:
        assert math.isclose(a[k], b[k], rel_tol=RTOL, abs_tol=ATOL), (what, k, a[k], b[k])
    assert a["locked"] == b["locked"], (what, "locked")


def quadrant_points(mode, n, rng):
    """Random operating points in all four quadrants of (w_in, tau_out) inside the map."""
    w = np.exp(rng.uniform(np.log(2.0), np.log(340.0), n)) * rng.choice([-1.0, 1.0], n)
    t = np.exp(rng.uniform(np.log(0.05), np.log(29.0), n)) * rng.choice([-1.0, 1.0], n)
    # every quadrant at least n // 8 times
    q = n // 8
    for k, (sw, st) in enumerate(((1, 1), (1, -1), (-1, 1), (-1, -1))):
        w[k * q:(k + 1) * q] = sw * np.abs(w[k * q:(k + 1) * q])
        t[k * q:(k + 1) * q] = st * np.abs(t[k * q:(k + 1) * q])
    return list(zip(w.tolist(), t.tolist()))


# -- the package -----------------------------------------------------------------------------
def test_validates_clean_and_carries_no_python(native, native_dir):
    from fmpy.validation import validate_fmu
    assert validate_fmu(native) == []
    so = os.path.join(native_dir, "binaries", "linux64", "CycloidDriveNative.so")
    syms = subprocess.run(["nm", "-D", "--undefined-only", so], capture_output=True,
                          text=True, check=True).stdout
    assert "fmi2" not in syms and "calloc" in syms       # the listing is real
    assert not [s for s in syms.split() if s.startswith(("Py", "_Py"))]
    needed = subprocess.run(["readelf", "-d", so], capture_output=True, text=True,
                            check=True).stdout
    needed = [ln for ln in needed.splitlines() if "NEEDED" in ln]
    assert needed and not any("python" in ln.lower() for ln in needed)
    exported = subprocess.run(["nm", "-D", "--defined-only", so], capture_output=True,
                              text=True, check=True).stdout.split()
    assert "fmi2DoStep" in exported and "cd_solve" not in exported and "CD_MAP" not in exported
    names = set(zipfile.ZipFile(native).namelist())
    for f in ("fmi2_cycloid.c", "cd_model.c", "cd_model.h", "cd_map_data.c", "fmi2Functions.h",
              "fmi2FunctionTypes.h", "fmi2TypesPlatform.h", "buildDescription.xml"):
        assert "sources/" + f in names


def test_model_description_metadata(native, fmu):
    md = read_model_description(native)
    assert md.fmiVersion == "2.0" and md.license == "MIT" and md.version and md.copyright
    assert md.coSimulation.canGetAndSetFMUstate and md.coSimulation.canSerializeFMUstate
    assert float(md.defaultExperiment.stepSize) == 0.001
    var = {v.name: v for v in md.modelVariables}
    assert var["w_in"].unit == "rad/s" and var["tau_out"].unit == "N.m"
    assert var["w_in"].displayUnit == "r/min" and var["eta"].displayUnit == "%"
    units = {u.name: u for u in md.unitDefinitions}
    rpm = next(d for d in units["rad/s"].displayUnits if d.name == "r/min")
    assert math.isclose(rpm.factor * 2 * math.pi, 60.0)          # display = factor * SI
    assert var["mode"].causality == "parameter" and var["mode"].start == "S1"
    assert var["mode_number"].min == "0" and var["mode_number"].max == "6"
    assert var["drag_torque"].min == "0.0" and var["drag_torque"].variability == "fixed"
    assert var["mu_boundary"].variability == "constant"    # the map depends on it
    assert var["z1"].start == "15"
    # same ports, units and parameters as the Python FMU (minus what a build fixes)
    py = {v.name: v for v in read_model_description(fmu).modelVariables}
    # no full solver in C; _failed: the Python FMU's flag for its C status front
    assert set(py) - set(var) == {"exact", "_failed"}
    for name, v in py.items():
        if name in var:
            assert (var[name].type, var[name].unit) == (v.type, v.unit), name
    out = {md.modelVariables.index(u.variable): u for u in md.outputs}
    deps = {u.variable.name: {d.name for d in u.dependencies} for u in md.outputs}
    assert deps["w_out"] == {"w_in"} and deps["tau_in"] == {"w_in", "tau_out", "alpha_in",
                                                            "T_oil_in"}
    assert deps["T_oil"] == deps["Q_ambient"] == {"T_oil_in"}
    py_md = read_model_description(fmu)
    py_deps = {u.variable.name: {d.name for d in u.dependencies} for u in py_md.outputs}
    assert all(deps[n] == py_deps[n] for n in deps if n in py_deps)
    init = {u.variable.name: {d.name for d in u.dependencies} for u in md.initialUnknowns}
    assert init["w_out"] == {"w_in", "mode", "mode_number"}
    assert {"drag_torque", "ripple_1x", "tau_out"} <= init["tau_in"]
    # the drag's reaction closes the torque balance on the housing (issue 20)
    assert {"drag_torque", "drag_exponent"} <= init["tau_housing"]
    assert "drag_torque" not in init["PL1"]
    for name in ("tau_in", "P_loss", "eta"):     # drag_exponent acts in Initialization Mode
        assert "drag_exponent" in init[name], name
    assert {"J_out", "alpha_ref"} <= init["J_load"]
    assert {"use_T_oil_input", "T_oil_start"} <= init["T_oil"]
    assert {"ambient_temperature", "housing_area"} <= init["Q_ambient"]
    # 23 Real outputs (PL_mesh, T_oil, Q_ambient at 52..54) and locked
    assert len(out) == len(init) == 24


# -- the C host ------------------------------------------------------------------------------
C_HOST = r"""
#include <dlfcn.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include "fmi2Functions.h"

static void logger(fmi2ComponentEnvironment e, fmi2String name, fmi2Status s, fmi2String cat,
                   fmi2String msg, ...) {
    (void)e; fprintf(stderr, "[%s %d %s] %s\n", name, (int)s, cat, msg);
}

#define LOAD(f) f##TYPE *f = (f##TYPE *)dlsym(lib, #f); if (!f) { printf("no %s\n", #f); return 3; }

int main(int argc, char **argv) {
    void *lib;
    fmi2CallbackFunctions cb = {logger, calloc, free, NULL, NULL};
    fmi2ValueReference in[2] = {0, 1}, out[4] = {10, 11, 13, 19};
    fmi2ValueReference mode_vr = 0, use_T_oil_vr = 11;
    fmi2Boolean hold = fmi2True;   /* the grease held at T_oil_in's start: the map's own T */
    fmi2String mode = "S1";
    fmi2Real u[2], y[4], t = 0.0, h = 1e-3;
    fmi2Component c;
    int k;
    if (argc != 5) return 2;
    lib = dlopen(argv[1], RTLD_NOW | RTLD_LOCAL);
    if (!lib) { printf("dlopen: %s\n", dlerror()); return 3; }
    LOAD(fmi2Instantiate) LOAD(fmi2SetupExperiment) LOAD(fmi2EnterInitializationMode)
    LOAD(fmi2ExitInitializationMode) LOAD(fmi2SetReal) LOAD(fmi2GetReal) LOAD(fmi2SetString)
    LOAD(fmi2DoStep) LOAD(fmi2Terminate) LOAD(fmi2FreeInstance) LOAD(fmi2SetBoolean)
    c = fmi2Instantiate("host", fmi2CoSimulation, argv[2], "file:///tmp", &cb, fmi2False,
                        fmi2False);
    if (!c) { printf("instantiate failed\n"); return 4; }
    u[0] = atof(argv[3]); u[1] = atof(argv[4]);
    if (fmi2SetupExperiment(c, fmi2False, 0.0, 0.0, fmi2False, 0.0) != fmi2OK) return 5;
    if (fmi2EnterInitializationMode(c) != fmi2OK) return 5;
    if (fmi2SetString(c, &mode_vr, 1, &mode) != fmi2OK) return 5;
    if (fmi2SetReal(c, in, 2, u) != fmi2OK) return 5;
    if (fmi2SetBoolean(c, &use_T_oil_vr, 1, &hold) != fmi2OK) return 5;
    if (fmi2ExitInitializationMode(c) != fmi2OK) return 5;
    for (k = 0; k < 3; k++) {
        if (fmi2DoStep(c, t, h, fmi2True) != fmi2OK) return 6;
        t += h;
    }
    if (fmi2GetReal(c, out, 4, y) != fmi2OK) return 7;
    printf("%.17g %.17g %.17g %.17g\n", y[0], y[1], y[2], y[3]);
    fmi2Terminate(c);
    fmi2FreeInstance(c);
    dlclose(lib);
    return 0;
}
"""


def test_runs_in_a_bare_c_host_with_an_empty_environment(native, native_dir, tmp_path):
    src = tmp_path / "host.c"
    src.write_text(C_HOST)
    exe = tmp_path / "host"
    subprocess.run([GCC, "-std=c99", "-O1", "-o", str(exe), str(src),
                    f"-I{native_dir}/sources", "-ldl"], check=True, capture_output=True)
    so = os.path.join(native_dir, "binaries", "linux64", "CycloidDriveNative.so")
    guid = read_model_description(native).guid
    r = subprocess.run([str(exe), so, guid, "300", "-10"], env={}, capture_output=True,
                       text=True, timeout=30)
    assert r.returncode == 0, (r.stdout, r.stderr)
    w_out, tau_in, p_loss, eta = map(float, r.stdout.split())
    # the physics core's map, as the Python FMU steps it
    speeds, torques, losses, eta_py, *_ = ModeMap(DriveDesign(), "S1", 30.0, 350.0).solve(
        300.0, -10.0)
    assert w_out == pytest.approx(300.0 / 15, rel=1e-15)
    assert tau_in == pytest.approx(torques[2], rel=RTOL)
    assert eta == pytest.approx(eta_py, rel=RTOL) and 0.5 < eta < 0.9
    assert p_loss == pytest.approx(tau_in * 300.0 - 10.0 * w_out, rel=1e-12)
    # a wrong GUID is refused with a message, not a crash
    r = subprocess.run([str(exe), so, "{not-this-one}", "300", "-10"], env={},
                       capture_output=True, text=True, timeout=30)
    assert r.returncode == 4 and "GUID" in r.stderr


# -- agreement with the Python FMU -----------------------------------------------------------
@pytest.mark.parametrize("mode", ["S1", "S2"])
def test_agrees_with_python_fmu_in_all_quadrants(native, fmu, mode):
    rng = np.random.default_rng(7 if mode == "S1" else 8)
    pts = quadrant_points(mode, 120, rng)
    n = Inst(native, mode=mode)
    p = Inst(fmu, mode=mode)
    quadrants = set()
    for w, t in pts:
        a, b = n.step(w, t), p.step(w, t)
        assert_same(a, b, (mode, w, t))
        quadrants.add((w > 0, t > 0))
    assert len(quadrants) == 4
    n.close()
    p.close()


@pytest.mark.parametrize("mode", ["S1", "S2"])
def test_output_inertia_agrees_with_the_python_fmu(native, fmu, mode):
    """J_out reflected to the driving side as the bench's motor integrator needs it: the load
    includes J_out's inertial torque, J_load/J_load_dec are the secants over +-alpha_ref of
    the driving torque, reused while the operating point stays within 1e-3; both FMUs alike,
    along a run-up, a steady stretch (reuse), a reversal of the load and a deceleration."""
    params = dict(mode=mode, J_out=0.2, alpha_ref=120.0)
    n, p = Inst(native, **params), Inst(fmu, **params)
    w, seen_reuse = 0.0, 0
    for k in range(400):
        alpha = 150.0 if k < 100 else (0.0 if k < 200 else -90.0)
        w += alpha * 1e-3
        tau = -2.0 if k < 300 else 1.5
        n.set(alpha_in=alpha)
        p.set(alpha_in=alpha)
        a, b = n.step(w, tau), p.step(w, tau)
        assert_same(a, b, (mode, k))
        if k > 0 and alpha == 0.0 and a["J_load"] == last:
            seen_reuse += 1
        last = a["J_load"]
        ratio = float(kinematics.shaft_speeds(mode, 1.0, 15)[mode[1]])
        assert a["J_load"] > 0 and a["J_load_dec"] > 0
        assert a["torque_out"] == pytest.approx(-(tau - 0.2 * ratio * alpha), rel=1e-12)
    assert seen_reuse > 50
    n.close()
    p.close()


@pytest.mark.parametrize("mode", ["S1", "S2"])
def test_agrees_at_self_locking_points(native, fmu, mode):
    """Back-driving into S: the load drives (tau_out w_out > 0), power flows from 1 or 2 into
    S; at light load eta0 <= i0 and the drive locks."""
    n = Inst(native, mode=mode)
    p = Inst(fmu, mode=mode)
    ratio = float(kinematics.shaft_speeds(mode, 1.0, 15)[mode[1]])
    locked = unlocked = 0
    for w in (-300.0, -40.0, 3.0, 120.0, 330.0):
        for T in (0.03, 0.06, 0.1, 0.15, 0.25, 0.5, 2.0, 8.0, 25.0):
            t = math.copysign(T, w * ratio)          # load drives
            a, b = n.step(w, t), p.step(w, t)
            assert_same(a, b, (mode, w, t))
            # a load too light to overcome the drag at the shafts leaves the input driving:
            # power then enters at both shafts and nothing comes out (eta 0, not locked)
            both_in = a["tau_in"] * w > 0 and t * a["w_out"] > 0
            assert a["eta"] == 0.0 if (a["locked"] or both_in) else a["eta"] > 0
            locked += a["locked"]
            unlocked += not a["locked"]
    assert locked >= 8 and unlocked >= 8      # both sides of the locking limit exercised
    n.close()
    p.close()


@pytest.mark.slow
@pytest.mark.parametrize("mode", kinematics.MODES)
def test_agrees_with_python_fmu_every_mode(native, fmu, mode):
    rng = np.random.default_rng(11)
    n = Inst(native, mode=mode)
    p = Inst(fmu, mode=mode)
    for w, t in quadrant_points(mode, 200, rng):
        assert_same(n.step(w, t), p.step(w, t), (mode, w, t))
    n.close()
    p.close()


EXTRA = dict(drag_torque=0.12, stribeck_torque=0.3, stribeck_speed=25.0, input_inertia=2e-4,
             ripple_1x=0.05, ripple_1x_phase=0.4, ripple_roller=0.03, ripple_roller_phase=-1.1,
             thermal_loss_change=-0.15, thermal_tau=0.05, drag_exponent=0.5,
             stribeck_exponent=1.5, run_in_change=0.2, run_in_distance=40.0,
             ripple_1x_load=0.02, ripple_1x_load_phase=0.7, ripple_roller_load=0.01,
             ripple_roller_load_phase=-0.3,
             # the ripple at 2x the driving shaft, 1x and 2x the driven shaft
             ripple_2x=0.015, ripple_2x_phase=0.25, ripple_2x_load=0.012,
             ripple_2x_load_phase=-0.6, ripple_out_1x=0.04, ripple_out_1x_phase=1.3,
             ripple_out_1x_load=0.018, ripple_out_1x_load_phase=-2.0, ripple_out_2x=0.01,
             ripple_out_2x_phase=-0.4, ripple_out_2x_load=0.007, ripple_out_2x_load_phase=2.2,
             # the standstill friction's sign through a reversal, tanh(w/6 rad/s)
             stribeck_transition=6.0)


@pytest.mark.parametrize("mode", ["S2", "S1"])
def test_agrees_with_python_fmu_with_extra_physics(native, fmu, mode):
    """Drag, Stribeck, inertia, every ripple order (S2: the driven shaft turns against the
    driving one, S1 with it) and warm-up switched on: a run-up and reversal through the four
    quadrants."""
    n = Inst(native, mode=mode, **EXTRA)
    p = Inst(fmu, mode=mode, **EXTRA)
    for k in range(150):
        w = 250.0 * math.sin(0.03 * k) + 5.0
        t = -6.0 * math.cos(0.05 * k) + 0.5
        a, b = n.step(w, t, dt=2e-3), p.step(w, t, dt=2e-3)
        assert_same(a, b, k)
        assert a["P_extra"] != 0.0
    n.close()
    p.close()


@pytest.mark.parametrize("w_r", [0.0, 1.5])
def test_a_slow_speed_reversal_agrees_with_python_fmu(native, fmu, w_r):
    """The standstill friction's sign through a slow reversal (-12 .. +12 rad/s in steps of
    0.4 rad/s, both directions at a back-driving load) with a sharp sign and a transition width
    of 1.5 rad/s (tanh(w/w_r), model_core.friction.reversal_sign): native = Python FMU, and the
    friction torque P_extra/w_in is odd in w and never feeds power (P_extra >= 0)."""
    ex = dict(stribeck_torque=0.3, stribeck_speed=25.0, stribeck_exponent=1.3,
              stribeck_transition=w_r)
    n = Inst(native, mode="S1", **ex)
    p = Inst(fmu, mode="S1", **ex)
    ws = [w for w in np.arange(-12.0, 12.01, 0.4)] + [w for w in np.arange(12.0, -12.01, -0.4)]
    seen = {}
    for k, w in enumerate(ws):
        a, b = n.step(w, -2.0, dt=2e-3), p.step(w, -2.0, dt=2e-3)
        assert_same(a, b, (w_r, w))
        assert a["P_extra"] >= 0.0
        if abs(w) > 1e-9:
            seen.setdefault(round(abs(w), 6), set()).add(round(a["P_extra"] / w, 12))
    for t in seen.values():      # odd: the same |T| in both directions at the same |w|
        assert len({abs(x) for x in t}) == 1
    inside = [a / 0.3 for a in seen.get(0.4, ())]   # tanh(0.4/1.5) = 0.26 of the level
    want = math.tanh(0.4 / w_r) if w_r else 1.0
    assert inside and all(abs(abs(x) - want * math.exp(-(0.4 / 25.0) ** 1.3)) < 1e-9
                          for x in inside)
    n.close()
    p.close()


@pytest.mark.parametrize("w_c", [0.0, 0.3])
def test_the_losses_through_standstill_agree_with_python_fmu(native, fmu, w_c):
    """The whole loss through standstill (extra.loss_transition, tanh(|w_in|/w_c),
    model_core.friction.loss_transition) along a slow reversal (-3 .. +3 rad/s in steps of
    0.1 rad/s, both directions, at a back-driving load, with an output inertia so that the
    secants J_load and tau_in_static are scaled too): native = Python FMU; the loss torque
    (tau_in minus the lossless -tau_out w_out/w_in) is the model's times tanh(|w|/w_c), so the
    partial losses still add up to P_loss and no loss feeds power (P_loss >= 0)."""
    n = Inst(native, mode="S1", loss_transition=w_c, J_out=0.01)
    p = Inst(fmu, mode="S1", loss_transition=w_c, J_out=0.01)
    ref_n = Inst(native, mode="S1", J_out=0.01)
    ws = [w for w in np.arange(-3.0, 3.01, 0.1)] + [w for w in np.arange(3.0, -3.01, -0.1)]
    ratio = float(kinematics.shaft_speeds("S1", 1.0, DriveDesign().z1)["1"])
    for k, w in enumerate(ws):
        a, b, r = (x.step(w, -2.0, dt=2e-3) for x in (n, p, ref_n))
        assert_same(a, b, (w_c, w))
        assert a["P_loss"] >= -1e-12
        pl = sum(a[f] for f in ("PL1", "PL2", "PL3", "PL5", "PL6", "PL_support", "PL_seal",
                                "PL_churn", "PL_mesh"))
        assert pl == pytest.approx(a["P_loss"], rel=1e-9, abs=1e-12)
        tau = a["torque_out"]       # minus the load on the driven shaft
        lossless = tau * ratio
        share = math.tanh(abs(w) / w_c) if w_c else 1.0
        assert a["tau_in"] - lossless == pytest.approx(share * (r["tau_in"] - lossless),
                                                       rel=1e-9, abs=1e-12)
    for x in (n, p, ref_n):
        x.close()


# -- one formula, two languages ----------------------------------------------------------------
class CExtra(ctypes.Structure):
    _fields_ = [(e[0], ctypes.c_double) for e in nb.EXTRA]


class CSolution(ctypes.Structure):
    _fields_ = [("speeds", ctypes.c_double * 3), ("torques", ctypes.c_double * 3),
                ("losses", ctypes.c_double * 9), ("eta", ctypes.c_double),
                ("eta0", ctypes.c_double), ("locked", ctypes.c_int),
                ("forward", ctypes.c_int), ("out_of_range", ctypes.c_int)]


@pytest.fixture(scope="module")
def model_lib(native_dir, tmp_path_factory):
    """cd_model.c and the generated map, compiled with their functions visible."""
    src = os.path.join(native_dir, "sources")
    out = tmp_path_factory.mktemp("cdlib") / "libcdmodel.so"
    subprocess.run([GCC, "-std=c99", "-O2", "-fPIC", "-shared", "-ffp-contract=off",
                    f"-I{src}", "-o", str(out), f"{src}/cd_model.c", f"{src}/cd_map_data.c",
                    "-lm"], check=True, capture_output=True)
    lib = ctypes.CDLL(str(out))
    lib.cd_steady_torque.restype = ctypes.c_double
    lib.cd_steady_torque.argtypes = [ctypes.POINTER(CExtra), ctypes.c_double]
    lib.cd_dynamic_torque.restype = ctypes.c_double
    lib.cd_dynamic_torque.argtypes = [ctypes.POINTER(CExtra)] + [ctypes.c_double] * 5
    lib.cd_solve.argtypes = [ctypes.c_void_p, ctypes.c_int, ctypes.c_double, ctypes.c_double,
                             ctypes.POINTER(CSolution)]
    lib.cd_mode_index.argtypes = [ctypes.c_char_p]
    return lib


def test_c_steady_and_dynamic_torque_equal_python(model_lib):
    ex = ExtraPhysics(**EXTRA)
    cx = CExtra(**EXTRA)
    for w in (-400.0, -30.0, -1e-3, 0.0, 2e-6, 7.5, 25.0, 310.0):
        assert model_lib.cd_steady_torque(ctypes.byref(cx), w) == pytest.approx(
            float(ex.steady_torque(w)), rel=1e-13, abs=1e-300)
    rng = np.random.default_rng(3)
    for alpha, theta, order, elapsed, loss in rng.normal(0, 30, (20, 5)):
        order, elapsed = abs(order), abs(elapsed)
        assert model_lib.cd_dynamic_torque(ctypes.byref(cx), alpha, theta, order, elapsed,
                                           loss) == pytest.approx(
            float(ex.dynamic_torque(alpha, theta, order, elapsed, loss)), rel=1e-12, abs=1e-12)


def test_c_shaft_order_ripple_equals_python(model_lib):
    """cd_shaft_order_ripple_torque against ExtraPhysics.shaft_order_ripple_torque (2x, output
    1x and 2x, constant and load-scaled), both signs of the driven shaft's ratio."""
    ex = ExtraPhysics(**EXTRA)
    cx = CExtra(**EXTRA)
    f = model_lib.cd_shaft_order_ripple_torque
    f.restype = ctypes.c_double
    f.argtypes = [ctypes.POINTER(CExtra)] + [ctypes.c_double] * 3
    rng = np.random.default_rng(4)
    for theta, tau in rng.normal(0, 40, (20, 2)):
        for r in (1 / 15, -1 / 14, 15.0 / 14.0):
            assert f(ctypes.byref(cx), theta, r, tau) == pytest.approx(
                ex.shaft_order_ripple_torque(theta, r, tau), rel=1e-12, abs=1e-12)


def test_c_run_in_equals_python(model_lib):
    """cd_run_in_torque of cd_load_loss_torque against ExtraPhysics.run_in_torque of
    lossmap.load_loss_torque (the run-in on the gear's load-dependent losses PL1..PL6 over the
    driving speed), both signs of the speed and at a standstill (no loss torque there)."""
    from model_core.lossmap import load_loss_torque
    ex = ExtraPhysics(**EXTRA)
    cx = CExtra(**EXTRA)
    run, load = model_lib.cd_run_in_torque, model_lib.cd_load_loss_torque
    run.restype = load.restype = ctypes.c_double
    run.argtypes = [ctypes.POINTER(CExtra)] + [ctypes.c_double] * 2
    load.argtypes = [ctypes.c_double] * 2
    rng = np.random.default_rng(5)
    for P, w, d in zip(rng.uniform(0, 50, 20), rng.normal(0, 200, 20), rng.uniform(0, 200, 20)):
        T = load(P, w)
        assert T == pytest.approx(load_loss_torque(P, w), rel=1e-15) and T * w >= 0
        assert run(ctypes.byref(cx), d, T) == pytest.approx(ex.run_in_torque(d, T), rel=1e-13)
    assert load(3.0, 0.0) == load_loss_torque(3.0, 0.0) == 0.0


def test_c_map_solve_equals_model_core(model_lib):
    """cd_solve against ModeMap.solve, every mode, in and beyond the map, both directions."""
    cmap = ctypes.c_void_p.in_dll(model_lib, "CD_MAP")       # address of the struct
    addr = ctypes.addressof(cmap)
    d = DriveDesign()
    rng = np.random.default_rng(5)
    for m, mode in enumerate(kinematics.MODES):
        mm = ModeMap(d, mode, 30.0, 350.0)
        pts = [(0.0, 3.0), (5.0, 0.0), (1e-5, 2.0), (400.0, -35.0), (-0.2, 1e-5)]
        pts += quadrant_points(mode, 40, rng)
        for w, t in pts:
            s = CSolution()
            model_lib.cd_solve(addr, m, w, t, ctypes.byref(s))
            speeds, torques, losses, eta, eta0, locked, forward = mm.solve(w, t)
            np.testing.assert_allclose(list(s.speeds), speeds, rtol=1e-15)
            np.testing.assert_allclose(list(s.torques), torques, rtol=RTOL, atol=ATOL)
            np.testing.assert_allclose(list(s.losses), losses, rtol=RTOL, atol=ATOL)
            assert (s.eta, s.eta0, bool(s.locked), bool(s.forward)) == pytest.approx(
                (eta, eta0, locked, forward), rel=RTOL, abs=ATOL)
    for text, idx in ((b"S1", 3), (b" s2 ", 5), (b"1s", 2), (b"S3", -1), (b"", -1),
                      (b"S12", -1)):
        assert model_lib.cd_mode_index(text) == idx


# -- FMI semantics ---------------------------------------------------------------------------
def _trajectory(k):
    return 200.0 * math.sin(0.02 * k) + 30.0, -4.0 + 3.0 * math.sin(0.07 * k)


def test_state_get_set_and_serialize_reproduce_the_run(native):
    inst = Inst(native, mode="S1", **EXTRA)
    first = [inst.step(*_trajectory(k)) for k in range(40)]
    state = inst.fmu.getFMUstate()
    blob = inst.fmu.serializeFMUstate(state)
    t_saved = inst.t
    rest = [inst.step(*_trajectory(k)) for k in range(40, 80)]
    assert first[-1] != rest[0]
    inst.fmu.setFMUstate(state)
    inst.t = t_saved
    again = [inst.step(*_trajectory(k)) for k in range(40, 80)]
    assert again == rest                                   # bit for bit
    inst.fmu.freeFMUstate(state)
    # serialised, into a fresh instance
    other = Inst(native, name="other")
    st2 = other.fmu.deSerializeFMUstate(blob)
    other.fmu.setFMUstate(st2)
    other.t = t_saved
    assert [other.step(*_trajectory(k)) for k in range(40, 80)] == rest
    other.fmu.freeFMUstate(st2)
    # a damaged blob is refused with a message
    bad = bytes(b ^ 0xFF for b in blob)
    with pytest.raises(FMICallException):
        other.fmu.deSerializeFMUstate(bad)
    assert any("not a state" in m for _, m in other.messages)
    inst.close()
    other.close()


@pytest.mark.parametrize("extra", [{}, {"drag_torque": 0.2, "stribeck_torque": 0.1}])
def test_initialization_mode_outputs_equal_the_first_step(native, extra):
    for mode, w, t in (("S1", 300.0, -10.0), ("S2", -120.0, 4.0), ("S1", 250.0, 0.6)):
        inst = Inst(native, start=False)
        inst.fmu.setupExperiment(startTime=0.0)
        inst.fmu.enterInitializationMode()
        # the grease held at its temperature (use_T_oil_input, T_oil_in at its start): the heat
        # balance would warm it by P h / C in the step
        inst.set(mode=mode, w_in=w, tau_out=t, use_T_oil_input=True, **extra)
        init = inst.outputs()
        assert init["w_out"] != 0.0 and init["tau_in"] != 0.0
        inst.fmu.exitInitializationMode()
        assert inst.outputs() == init
        assert inst.step(w, t) == init
        inst.close()


def test_two_designs_in_one_process_do_not_interfere(native, tmp_path):
    """Two FMUs of different designs (mu_boundary) loaded together, interleaved."""
    toml = tmp_path / "rough.toml"
    # mu_boundary acts in the paper profile (the physical one uses the Stribeck pin law)
    rough_design = DriveDesign(profile="paper").replace(friction=Friction(mu_boundary=0.13))
    toml.write_text(design_to_toml(rough_design))
    dest = tmp_path / "rough"
    r = subprocess.run([sys.executable, "-m", "cyclo_fmu.cli", "build", "--design", str(toml),
                        "--dest", str(dest), "CycloidDriveNative"], capture_output=True,
                       text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    rough = str(dest / "CycloidDriveNative.fmu")
    assert read_model_description(rough).guid != read_model_description(native).guid
    pts = [(300.0, -10.0)] + quadrant_points("S1", 24, np.random.default_rng(9))
    alone = {}
    for path in (native, rough):
        i = Inst(path)
        alone[path] = [i.step(w, t) for w, t in pts]
        i.close()
    a, b = Inst(native, name="a"), Inst(rough, name="b")
    for k, (w, t) in enumerate(pts):
        assert b.step(w, t) == alone[rough][k]
        assert a.step(w, t) == alone[native][k]
    assert alone[native][0]["eta"] > alone[rough][0]["eta"] + 0.01   # rougher pins lose more
    # and each agrees with the core's map of its own design
    mm = ModeMap(rough_design, "S1", 30.0, 350.0)
    w, t = pts[0]
    assert alone[rough][0]["tau_in"] == pytest.approx(mm.solve(w, t)[1][2], rel=RTOL)
    a.close()
    b.close()


#: a calibrated design (design [calibration]): both FMUs built with it by the build command
CALIBRATED_TOML = """
[model]
profile = "physical"
[calibration]
mesh_loss_k = 0.04
idle_loss_scale = 0.3
load_loss_scale = 1.12
source = "test: made-up values"
"""


@pytest.fixture(scope="module")
def calibrated_fmus(tmp_path_factory, fmu):
    """CycloidDrive.fmu and CycloidDriveNative.fmu built by ``cyclo-fmu build --design`` with
    a calibrated design (after the session's default FMUs: pythonfmu cannot build a Python FMU
    in a process that has loaded one of the same bundle)."""
    tmp = tmp_path_factory.mktemp("calibrated")
    toml = tmp / "calibrated.toml"
    toml.write_text(CALIBRATED_TOML)
    dest = tmp / "fmus"
    r = subprocess.run([sys.executable, "-m", "cyclo_fmu.cli", "build", "--design", str(toml),
                        "--dest", str(dest), "CycloidDrive", "CycloidDriveNative"],
                       capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stderr
    return str(dest / "CycloidDriveNative.fmu"), str(dest / "CycloidDrive.fmu")


@pytest.mark.parametrize("mode", ["S1", "S2", "1S"])
def test_calibrated_design_python_and_native_fmus_agree(calibrated_fmus, mode):
    """The calibration reaches both FMUs (the native one through its map, the Python one
    through the design it ships), they agree in all four quadrants, the mesh loss is booked as
    PL_mesh, and the partial losses add up to P_loss."""
    native, python = calibrated_fmus
    from model_core.design import design_from_toml
    d = design_from_toml(CALIBRATED_TOML)
    # the grease held at the operating temperature: the map of one temperature
    n, p = (Inst(x, mode=mode, use_T_oil_input=True) for x in (native, python))
    mm = ModeMap(d, mode, 30.0, 350.0)
    seen_mesh = 0
    for w, t in quadrant_points(mode, 80, np.random.default_rng(12)):
        a, b = n.step(w, t), p.step(w, t)
        assert_same(a, b, (mode, w, t))
        # the native FMU interpolates the calibrated design's map
        assert a["tau_in"] == pytest.approx(mm.solve(w, t)[1][{"1": 0, "2": 1, "S": 2}[mode[0]]],
                                            rel=RTOL, abs=ATOL)
        parts = sum(a[k] for k in ("PL1", "PL2", "PL3", "PL5", "PL6", "PL_support", "PL_seal",
                                   "PL_churn", "PL_mesh"))
        assert parts == pytest.approx(a["P_loss"], rel=1e-9, abs=1e-9)
        seen_mesh += a["PL_mesh"] > 0
    assert seen_mesh > 40
    n.close()
    p.close()
    md = read_model_description(native)
    consts = {v.name: v.start for v in md.modelVariables}
    assert float(consts["mesh_loss_k"]) == 0.04 and float(consts["idle_loss_scale"]) == 0.3
    assert float(consts["load_loss_scale"]) == 1.12
    assert consts["calibration_source"] == "test: made-up values"
    assert "load_loss_scale = 1.12" in md.description
    assert "CALIBRATED" in md.description


def test_build_design_changes_every_reducer_fmu(calibrated_fmus, native, fmu):
    """``cyclo-fmu build --design`` builds the Python FMU with the design too (it used to stay
    on the default design): at the same operating point each FMU built with the calibrated
    design differs from its default build, by what the core gives for the two designs."""
    from model_core.design import design_from_toml
    from model_core import operating_point
    cal_native, cal_python = calibrated_fmus
    w, t = 250.0, -6.0
    outs = {}
    for key, path in (("native", native), ("python", fmu), ("native_cal", cal_native),
                      ("python_cal", cal_python)):
        i = Inst(path, mode="S1")
        outs[key] = i.step(w, t)
        i.close()
    for kind in ("native", "python"):
        a, b = outs[kind], outs[kind + "_cal"]
        assert b["PL_mesh"] > 0 and a["PL_mesh"] == 0
        assert b["tau_in"] > a["tau_in"] * 1.05           # the mesh loss k = 0.04
        core = {d: float(operating_point(dd, "S1", w, T_out=t).torques["S"])
                for d, dd in (("default", DriveDesign()),
                              ("cal", design_from_toml(CALIBRATED_TOML)))}
        assert a["tau_in"] == pytest.approx(core["default"], rel=2e-3)
        assert b["tau_in"] == pytest.approx(core["cal"], rel=2e-3)
    # the Python FMU's parameters start at the design's values
    md = read_model_description(cal_python)
    start = {v.name: v.start for v in md.modelVariables}
    assert float(start["mesh_loss_k"]) == 0.04 and float(start["idle_loss_scale"]) == 0.3
    assert float(start["load_loss_scale"]) == 1.12
    # the existing variables keep their value references; the new parameters come last, in
    # the order they were added (cycloid_drive.LATE_DESIGN_PARAMETERS)
    vr = {v.name: v.valueReference for v in md.modelVariables}
    assert vr["loss_transition"] == max(vr.values())
    assert (vr["nu_100"] < vr["load_loss_scale"] < vr["thermal_loss_per_10K"]
            < vr["thermal_T_ref"] < vr["ripple_2x"] < vr["ripple_out_1x"] < vr["ripple_out_2x"]
            < vr["ripple_out_2x_load_phase"] < vr["stribeck_transition"]
            < vr["thermal_T_scale"] < vr["loss_transition"])


def test_bad_input_gives_fmi2error_with_a_message(native):
    inst = Inst(native, mode="S1")
    inst.step(100.0, -2.0)
    with pytest.raises(FMICallException) as exc:
        inst.set(w_in=float("nan"))
    assert exc.value.status == 3                          # fmi2Error, not fmi2Fatal
    assert any(s == 3 and "w_in" in m and "finite" in m for s, m in inst.messages)
    with pytest.raises(FMICallException):
        inst.set(tau_out=float("inf"))
    # the instance goes on with the last good inputs
    ok = inst.step(100.0, -2.0)
    assert ok["w_out"] == pytest.approx(100.0 / 15)
    with pytest.raises(FMICallException):               # fixed after initialization
        inst.set(mode="S2")
    inst.close()

    fresh = Inst(native, start=False)
    fresh.fmu.setupExperiment(startTime=0.0)
    fresh.fmu.enterInitializationMode()
    for name, value, words in (("mode", "X7", "mode = 'X7'"), ("mode", "%s%n", "mode"),
                               ("mode_number", 9, "mode_number = 9"),
                               ("drag_torque", -0.5, "drag_torque = -0.5"),
                               ("stribeck_speed", 0.0, "stribeck_speed = 0"),
                               ("thermal_tau", float("nan"), "thermal_tau"),
                               ("ripple_out_1x_load", -0.01, "ripple_out_1x_load = -0.01"),
                               ("ripple_2x_phase", float("inf"), "ripple_2x_phase"),
                               ("stribeck_transition", -1.0, "stribeck_transition = -1"),
                               ("thermal_T_scale", 0.5, "thermal_T_scale = 0.5"),
                               ("thermal_T_scale", -20.0, "thermal_T_scale = -20"),
                               ("loss_transition", -0.1, "loss_transition = -0.1"),
                               ("loss_transition", float("nan"), "loss_transition")):
        fresh.messages.clear()
        with pytest.raises(FMICallException) as exc:
            fresh.set(**{name: value})
        assert exc.value.status == 3, name
        assert any(s == 3 and words in m for s, m in fresh.messages), (name, fresh.messages)
    fresh.set(mode="2s")
    fresh.fmu.exitInitializationMode()
    assert fresh.fmu.getString([fresh.vr["mode"]]) == [b"2S"]
    # a constant of the design cannot be set
    with pytest.raises(FMICallException):
        fresh.fmu.setReal([fresh.vr["mu_boundary"]], [0.2])
    fresh.close()


def test_beyond_the_map_warns_once(native):
    inst = Inst(native, mode="S1")
    inst.step(100.0, -2.0)
    inst.step(400.0, -2.0)
    inst.step(100.0, -45.0)
    warnings = [m for s, m in inst.messages if s == 1]
    assert len(warnings) == 1 and "350" in warnings[0]
    inst.close()


@pytest.mark.skipif(shutil.which("cmake") is None, reason="no cmake")
def test_shipped_sources_build_with_fmpys_cmake_build(native, tmp_path):
    """What a host on another platform does: compile sources/ (buildDescription.xml) with
    fmpy's own CMake build, here for linux64, and get the same numbers."""
    from fmpy.build import build_platform_binary
    d = tmp_path / "rebuilt"
    zipfile.ZipFile(native).extractall(d)
    shutil.rmtree(d / "binaries")
    (tmp_path / "cmake").mkdir()
    build_platform_binary(str(d.resolve()), build_dir=str(tmp_path / "cmake"))
    assert (d / "binaries" / "linux64" / "CycloidDriveNative.so").is_file()
    pts = quadrant_points("S2", 16, np.random.default_rng(4))
    ref, new = Inst(native, mode="S2"), Inst(native, unzip=str(d), mode="S2")
    for w, t in pts:
        assert_same(new.step(w, t), ref.step(w, t), (w, t))
    ref.close()
    new.close()
