"""FMI-grade semantics of the Python FMUs (issue 7, item 2): Initialization-Mode outputs,
truthful InitialUnknowns, metadata, the real import error, truthful warnings, P_loss >= 0 with
the stored power reported apart, and a failed initialization that leaves the host alive."""
from __future__ import annotations

import subprocess
import sys
import zipfile
from pathlib import Path
from xml.etree import ElementTree as ET

import pytest
from fmpy import read_model_description
from fmpy.validation import validate_fmu

from cyclo_fmu.fmu_build import BUNDLE, SLAVES, build_fmu

sys.path.insert(0, str(Path(__file__).parent))
from test_native_fmu import Inst  # noqa: E402


@pytest.fixture(scope="module")
def fmus(tmp_path_factory):
    dest = tmp_path_factory.mktemp("grade")
    return {n: str(build_fmu(n, dest)) for n in SLAVES}


def xml_of(path):
    with zipfile.ZipFile(path) as z:
        return ET.fromstring(z.read("modelDescription.xml"))


def test_validate_clean(fmus):
    for name, path in fmus.items():
        assert validate_fmu(path) == [], name


def test_metadata(fmus):
    for name, path in fmus.items():
        root = xml_of(path)
        for attr in ("version", "license", "copyright"):
            assert root.get(attr), (name, attr)
        de = root.find("DefaultExperiment")
        assert de is not None and float(de.get("stepSize")) > 0, name
        for sv in root.find("ModelVariables"):
            real = sv.find("Real")
            if real is not None:
                assert real.get("quantity") and real.get("unit"), (name, sv.get("name"))
    md = read_model_description(fmus["CycloidDrive"])
    v = {x.name: x for x in md.modelVariables}
    assert v["w_in"].displayUnit == "r/min" and v["eta"].displayUnit == "%"
    assert v["e"].displayUnit == "mm"
    assert float(v["mu_boundary"].min) == 0.0 and float(v["mu_boundary"].max) == 1.0
    units = {u.name: u for u in md.unitDefinitions}
    rpm = next(d for d in units["rad/s"].displayUnits if d.name == "r/min")
    assert float(rpm.factor) == pytest.approx(30 / 3.141592653589793, rel=1e-15)
    mv = {x.name: x for x in read_model_description(fmus["InductionMotor"]).modelVariables}
    assert float(mv["breakdown_ratio"].min) == 1.0 and int(mv["pole_pairs"].min) == 1


def test_initial_unknowns_name_parameters(fmus):
    md = read_model_description(fmus["CycloidDrive"])
    init = {u.variable.name: {d.name for d in (u.dependencies or [])}
            for u in md.initialUnknowns}
    outs = {u.variable.name: {d.name for d in (u.dependencies or [])} for u in md.outputs}
    assert {"mode", "mode_number", "mu_boundary", "w_in", "tau_out"} <= init["tau_in"]
    assert "input_inertia" not in init["tau_in"]          # no step yet, no acceleration
    assert outs["tau_in"] == {"w_in", "tau_out", "alpha_in", "T_oil_in"}   # Step Mode: inputs
    init_m = {u.variable.name: {d.name for d in (u.dependencies or [])}
              for u in read_model_description(fmus["InductionMotor"]).initialUnknowns}
    assert "w_start" in init_m["w"] and "J" not in init_m["w"]


@pytest.mark.parametrize("extra", [{}, {"drag_torque": 0.1, "stribeck_torque": 0.2}])
def test_drive_outputs_in_initialization_mode(fmus, extra):
    """After setReal(w_in, tau_out) in Initialization Mode the outputs are the ones of the first
    step at the same inputs (quasi-static reducer), not the start values."""
    a = Inst(fmus["CycloidDrive"], start=False)
    a.fmu.setupExperiment(startTime=0.0)
    a.fmu.enterInitializationMode()
    # the grease held at its temperature: the heat balance would warm it by P h / C in the step
    a.set(w_in=300.0, tau_out=-10.0, use_T_oil_input=True, **extra)
    names = ["w_out", "tau_in", "tau_housing", "P_loss", "eta", "P_extra"]
    init = a.fmu.getReal([a.vr[n] for n in names])
    assert init[1] > 0.0 and 0.5 < init[4] < 1.0
    a.fmu.exitInitializationMode()
    a.fmu.doStep(0.0, 1e-3)
    first = a.fmu.getReal([a.vr[n] for n in names])
    a.close()
    assert init == pytest.approx(first, rel=1e-12, abs=1e-12)


def test_other_slaves_in_initialization_mode(fmus):
    b = Inst(fmus["FeltBrake"], start=False)
    b.fmu.setupExperiment(startTime=0.0)
    b.fmu.enterInitializationMode()
    b.set(T_first=3.0, w=10.0)
    assert b.fmu.getReal([b.vr["T_brake"]])[0] == pytest.approx(3.0 * __import__("math").tanh(20))
    b.fmu.exitInitializationMode()
    b.close()
    m = Inst(fmus["InductionMotor"], start=False)
    m.fmu.setupExperiment(startTime=0.0)
    m.fmu.enterInitializationMode()
    m.set(w_start=200.0)
    assert m.fmu.getReal([m.vr["w"]])[0] == 200.0
    pp = m.fmu.getInteger([m.vr["pole_pairs"]])[0]
    assert m.fmu.getReal([m.vr["frequency"]])[0] == pytest.approx(200.0 * pp / (2 * 3.141592653589793))
    m.fmu.exitInitializationMode()
    m.close()
    t = Inst(fmus["Transducer"], start=False)
    t.fmu.setupExperiment(startTime=0.0)
    t.fmu.enterInitializationMode()
    t.set(x=2.0, scale=3.0)
    assert t.fmu.getReal([t.vr["y"]])[0] == 6.0
    t.fmu.exitInitializationMode()
    t.close()


def test_no_range_warning_at_start_up(fmus):
    """Below the map's speed grid (start-up) the edge is the physics' own limit: no warning
    that asks to raise map_speed_max; beyond the maxima there is one."""
    a = Inst(fmus["CycloidDrive"], start=True)
    a.fmu.setDebugLogging(True, [])
    for k in range(5):
        a.step(0.05 * k, -1.0)
    assert not any("map" in m for s, m in a.messages), a.messages
    a.step(400.0, -1.0)
    assert any("map_speed_max" in m for s, m in a.messages)
    a.close()


@pytest.mark.parametrize("case", ["nan_input", "bad_parameter"])
def test_error_not_fatal(fmus, case):
    """NaN input and an invalid parameter: fmi2Error (3), not fmi2Fatal (4), with the reason in
    the log even with debug logging off (as the native FMU)."""
    a = Inst(fmus["CycloidDrive"], start=False)
    a.fmu.setupExperiment(startTime=0.0)
    a.fmu.enterInitializationMode()
    if case == "bad_parameter":
        a.set(mu_boundary=5.0)
        with pytest.raises(Exception) as exc:
            a.fmu.exitInitializationMode()
        want = "mu_boundary = 5.0"
    else:
        a.fmu.exitInitializationMode()
        a.set(w_in=float("nan"))
        with pytest.raises(Exception) as exc:
            a.fmu.doStep(0.0, 1e-3)
        want = "w_in = nan"
    assert exc.value.status == 3
    assert any(s == 3 and want in m for s, m in a.messages), a.messages
    a.fmu.freeInstance()
    b = Inst(fmus["Transducer"])                    # other instances unaffected
    b.set(x=1.0)
    b.fmu.doStep(0.0, 1e-3)
    b.close()


def test_p_loss_is_a_loss_with_inertia(fmus):
    """With input_inertia a run-up stores kinetic energy: P_stored carries it, P_loss >= 0 and
    tau_in w_in + tau_out w_out = P_loss + P_stored."""
    a = Inst(fmus["CycloidDrive"], input_inertia=0.05, ripple_1x=0.2)
    dt = 1e-3
    seen_stored = 0.0
    for k in range(1, 400):
        w = 300.0 * min(1.0, k / 100) * (1 if k < 250 else -0.5)
        o = a.step(w, -2.0, dt)
        p_stored = a.fmu.getReal([a.vr["P_stored"]])[0]
        seen_stored = max(seen_stored, abs(p_stored))
        assert o["P_loss"] >= 0.0, (k, o["P_loss"])
        bal = o["tau_in"] * w + (-2.0) * o["w_out"]
        assert bal == pytest.approx(o["P_loss"] + p_stored, rel=1e-9, abs=1e-9)
    assert seen_stored > 100.0     # J alpha w = 0.05 * 3000 * 300 W at the run-up's end
    a.close()


FAILED_INIT = """
import ast, gc, inspect, sys
sys.path.insert(0, {tests!r})
from test_native_fmu import Inst
for k in range(8):          # pythonfmu's exception path corrupted the interpreter: repeat it
    a = Inst({path!r}, start=False)
    a.fmu.setupExperiment(startTime=0.0)
    a.fmu.enterInitializationMode()
    a.set(mu_boundary=5.0)
    try:
        a.fmu.exitInitializationMode()
        print("NO ERROR")
    except Exception as exc:
        print("STATUS", exc)
    print("LOG", a.messages)
    a.fmu.freeInstance()
    gc.collect()
    for mod in list(sys.modules.values())[:40]:     # work for the interpreter afterwards
        try:
            ast.parse(inspect.getsource(mod))
        except Exception:
            pass
print("EXITING")
"""


def test_failed_initialization_host_survives(fmus, tmp_path):
    script = tmp_path / "host.py"
    script.write_text(FAILED_INIT.format(tests=str(Path(__file__).parent),
                                         path=fmus["CycloidDrive"]))
    r = subprocess.run([sys.executable, str(script)], capture_output=True, text=True,
                       timeout=120)
    assert r.returncode == 0, r.stderr[-2000:]
    assert "EXITING" in r.stdout and "STATUS" in r.stdout
    assert "mu_boundary" in r.stdout       # the log names the parameter and its value


def test_real_import_error(fmus, tmp_path):
    """A host Python without numpy: the import error names numpy, not model_core."""
    with zipfile.ZipFile(fmus["CycloidDrive"]) as z:
        z.extractall(tmp_path)
    code = ("import sys; sys.modules['numpy'] = None; sys.path.insert(0, %r); import %s"
            % (str(tmp_path / "resources"), BUNDLE + "_CycloidDrive"))
    r = subprocess.run([sys.executable, "-S", "-c", code], capture_output=True, text=True,
                       env={"PATH": "/usr/bin:/bin"}, timeout=60, cwd=tmp_path)
    assert r.returncode != 0
    assert "numpy" in r.stderr.splitlines()[-1], r.stderr[-500:]
    assert "model_core" not in r.stderr.splitlines()[-1]


C_HOST = r"""
#include <dlfcn.h>
#include <stdio.h>
#include <stdlib.h>
#include "fmi2Functions.h"
static void logger(fmi2ComponentEnvironment e, fmi2String n, fmi2Status s, fmi2String c,
                   fmi2String m, ...)
{ (void)e; fprintf(stderr, "[%s %d %s] %s\n", n, (int)s, c, m); }
#define LOAD(f) f##TYPE *f = (f##TYPE *)dlsym(lib, #f); if (!f) { printf("no %s\n", #f); return 3; }
int main(int argc, char **argv) {
    fmi2CallbackFunctions cb = {logger, calloc, free, NULL, NULL};
    fmi2ValueReference in[2], out[2];
    fmi2Real u[2] = {300.0, -10.0}, y[2], t = 0.0;
    fmi2Component c; void *lib; int k;
    if (argc != 8) return 2;
    in[0] = atoi(argv[4]); in[1] = atoi(argv[5]); out[0] = atoi(argv[6]); out[1] = atoi(argv[7]);
    lib = dlopen(argv[1], RTLD_NOW | RTLD_LOCAL);
    if (!lib) { printf("dlopen: %s\n", dlerror()); return 3; }
    LOAD(fmi2Instantiate) LOAD(fmi2SetupExperiment) LOAD(fmi2EnterInitializationMode)
    LOAD(fmi2ExitInitializationMode) LOAD(fmi2SetReal) LOAD(fmi2GetReal) LOAD(fmi2DoStep)
    LOAD(fmi2Terminate) LOAD(fmi2FreeInstance)
    c = fmi2Instantiate("host", fmi2CoSimulation, argv[2], argv[3], &cb, fmi2False, fmi2False);
    if (!c) { printf("instantiate failed\n"); return 4; }
    if (fmi2SetupExperiment(c, fmi2False, 0.0, 0.0, fmi2False, 0.0) > fmi2Warning) return 5;
    if (fmi2EnterInitializationMode(c) > fmi2Warning) return 5;
    if (fmi2SetReal(c, in, 2, u) > fmi2Warning) return 5;
    if (fmi2ExitInitializationMode(c) > fmi2Warning) return 5;
    for (k = 0; k < 3; k++, t += 1e-3) if (fmi2DoStep(c, t, 1e-3, fmi2True) > fmi2Warning) return 6;
    if (fmi2GetReal(c, out, 2, y) > fmi2Warning) return 7;
    printf("%.17g %.17g\n", y[0], y[1]);
    fmi2Terminate(c); fmi2FreeInstance(c);
    return 0;
}
"""


def test_python_fmu_in_a_c_host(fmus, tmp_path):
    """README recipe: a C host (no Python) runs CycloidDrive.fmu with libpython preloaded and
    the interpreter's home and packages named; without them it refuses with a message."""
    import shutil
    import sysconfig

    from fmpy import extract

    from cyclo_fmu.native.build import fmi_header_dir
    gcc = shutil.which("gcc")
    libpy = Path(sysconfig.get_config_var("LIBDIR")) / (sysconfig.get_config_var("INSTSONAME")
                                                        or "")
    if not gcc or not sysconfig.get_config_var("Py_ENABLE_SHARED") or not libpy.is_file():
        pytest.skip("needs gcc and a shared-library Python")
    src = tmp_path / "host.c"
    src.write_text(C_HOST)
    exe = tmp_path / "host"
    subprocess.run([gcc, "-std=c99", "-o", str(exe), str(src), f"-I{fmi_header_dir()}", "-ldl"],
                   check=True, capture_output=True)
    d = Path(extract(fmus["CycloidDrive"]))
    md = read_model_description(fmus["CycloidDrive"])
    vr = {v.name: str(v.valueReference) for v in md.modelVariables}
    argv = [str(exe), str(d / "binaries" / "linux64" / "CycloidDrive.so"), md.guid,
            (d / "resources").as_uri(), vr["w_in"], vr["tau_out"], vr["tau_in"], vr["eta"]]
    r = subprocess.run(argv, env={}, capture_output=True, text=True, timeout=60)
    assert r.returncode == 4 and "_Py_NoneStruct" in r.stderr and "LD_PRELOAD" in r.stderr
    site = next(p for p in sys.path if p.endswith("site-packages"))
    env = {"LD_PRELOAD": str(libpy), "PYTHONHOME": sys.base_prefix, "PYTHONPATH": site}
    r = subprocess.run(argv, env=env, capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, (r.stdout, r.stderr[-1000:])
    tau_in, eta = map(float, r.stdout.split())
    a = Inst(fmus["CycloidDrive"], w_in=300.0, tau_out=-10.0)   # as the host: the same three
    for _ in range(3):                                          # steps from the same start
        o = a.step(300.0, -10.0)
    a.close()
    assert tau_in == pytest.approx(o["tau_in"], rel=1e-12) and eta == pytest.approx(o["eta"])
