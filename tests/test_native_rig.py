"""The native bench components (motor, brake, transducers in C): the same numbers as their
Python slaves on the bench scenarios (the same arithmetic in the same order: equal to 1e-9,
in fact to the last bit), and an FMI front that answers misuse with fmi2Error, never a crash."""
import ctypes

import numpy as np
import pytest

from cyclo_fmu.bench import Scenario, Sensors, bench_parameters, run_fmus, scenario
from cyclo_fmu.fmu_build import RIG_NATIVE, build_any

#: native against Python on the same scenario (relative to max(1, |value|))
TWIN_TOL = 1e-9


@pytest.fixture(scope="module")
def both(fmu_dir, tmp_path_factory):
    """A folder with the Python set (the session's) and one with the native set."""
    d = tmp_path_factory.mktemp("native_set")
    for name in RIG_NATIVE + ("CycloidDriveNative",):
        build_any(name, d)
    return fmu_dir, d


def assert_twins(a, b):
    assert a.dtype.names == b.dtype.names
    for f in a.dtype.names:
        scale = np.maximum(1.0, np.abs(a[f]))
        worst = float(np.max(np.abs(a[f] - b[f]) / scale))
        assert worst <= TWIN_TOL, (f, worst)
        # and the same signs of zero (a recording writes -0 and 0 differently)
        zero = (a[f] == 0) & (b[f] == 0)
        assert np.array_equal(np.signbit(a[f][zero]), np.signbit(b[f][zero])), f


@pytest.mark.parametrize("name", ["loadstep", "reversal", pytest.param("paper",
                                                                    marks=pytest.mark.slow)])
def test_native_set_equals_python_set_on_the_bench_scenarios(both, name):
    py_dir, native_dir = both
    sc = scenario(name)
    step = 1e-3
    stop = sc.stop_time
    py = run_fmus(py_dir, bench_parameters(sc, Sensors(), fmus="python"), stop, step,
                  fmus="python")
    na = run_fmus(native_dir, bench_parameters(sc, Sensors(), fmus="native"), stop, step,
                  fmus="native")
    assert_twins(py, na)
    # the scenario did something: the motor turned, the readings carry noise
    assert np.ptp(na["motor.w"]) > 50 and np.std(np.diff(na["t_in.y"])) > 1e-3


def test_string_schedules_and_a_coupled_drum_are_twins_too(both):
    """The String forms of the schedules and the brake's drum on its coupling (J_out > 0), which
    the bench's defaults do not use."""
    py_dir, native_dir = both
    sc = Scenario("drum", f_first=30, f_last=30, f_count=1, T_first=2, T_last=2, T_count=1,
                  hold=1.0, duration=1.0)
    out = []
    for d, fmus in ((py_dir, "python"), (native_dir, "native")):
        p = bench_parameters(sc, Sensors(ideal=False), fmus=fmus)
        p.update({"motor.frequency_schedule": "0 20; 0.3, 35;0.7 25",
                  "brake.torque_schedule": "0 1; 0.5 3", "brake.J_out": 2e-3,
                  "drive.J_out": 0.0})
        out.append(run_fmus(d, p, sc.stop_time, 1e-3, fmus=fmus))
    assert_twins(*out)
    assert np.ptp(out[1]["brake.tau_out"]) > 1.0


@pytest.fixture(scope="module")
def transducers(fmu_dir, tmp_path_factory):
    """The Python torque transducer (the session's) and its native twin."""
    d = tmp_path_factory.mktemp("native_transducer")
    return str(fmu_dir / "TorqueTransducer.fmu"), str(build_any("TorqueTransducerNative", d))


def test_transducer_zero_drifts_with_its_temperature_input_in_both(transducers):
    """The zero's drift per 10 K of the temperature input (model_core.rig.zero_drift_per_10K):
    along a temperature trajectory (a warm-up and a cooling, 20-80 degC) the reading is
    (1 + g) x + offset + c (T - T_ref)/10 K at every step (closed form; no bandwidth, noise or
    quantisation), beside the zero's drift in time, in the Python FMU and the native one alike
    (to the last bit: the same arithmetic in the same order)."""
    from fmu_helpers import Inst
    c, T_ref, g, off, d0, tau = 0.015, 300.0, 0.01, 0.002, 0.004, 0.05
    h = 1e-3
    t = h * np.arange(1, 201)
    T = 293.15 + 60.0 * np.sin(np.pi * t / t[-1])            # K, up to 80 degC and back
    x = 1.5 + 0.5 * np.cos(7.0 * t)
    got = []
    for path in transducers:
        i = Inst(path, bandwidth=0.0, gain_error=g, offset=off, zero_per_10K=c,
                 zero_T_ref=T_ref, zero_drift=d0, zero_drift_tau=tau, x=x[0], temperature=T_ref)
        y0 = i.get("y")[0]
        ys = []
        for xk, Tk in zip(x, T):
            i.step(x=xk, temperature=Tk, dt=h)
            ys.append(i.get("y")[0])
        i.close()
        assert y0 == pytest.approx((1 + g) * x[0] + off, abs=1e-15)   # T = T_ref at the start
        got.append(np.array(ys))
    closed = (1 + g) * x + off + d0 * (1 - np.exp(-t / tau)) + c * (T - T_ref) / 10.0
    assert np.max(np.abs(got[0] - closed)) < 1e-12
    assert np.array_equal(got[0], got[1])
    assert np.ptp(c * (T - T_ref) / 10.0) > 0.08                     # the drift was there


@pytest.mark.parametrize("which", [0, 1])
def test_transducer_refuses_bad_temperature_values(transducers, which):
    """A reference outside 173.15-473.15 K or a zero drift that is not finite is refused at
    initialisation, a temperature input outside that range (0 K from a master that starts its
    connections at 0, degC given as K) at the step that reads it: fmi2Error and a message
    naming the variable. With zero_per_10K = 0 the input is not read (the default bench under
    fmpy's SSP master, which starts it at 0, runs)."""
    from fmpy.fmi1 import FMICallException
    from fmu_helpers import Inst
    path = transducers[which]
    for bad, name in ((dict(zero_T_ref=500.0, zero_per_10K=0.01), "zero_T_ref"),
                      (dict(zero_per_10K=float("nan")), "zero_per_10K")):
        i = Inst(path, start=False)
        with pytest.raises(FMICallException):
            i.start(**bad)
        assert any(name in m for _, m in i.messages), (bad, i.messages)
        i.close()
    i = Inst(path, zero_per_10K=0.01, temperature=310.0)
    i.step(x=1.0, temperature=330.0)
    for T in (0.0, float("nan"), 40.0):
        with pytest.raises(FMICallException):
            i.step(x=1.0, temperature=T)
        # (the native front refuses a NaN already at fmi2SetReal, naming it)
        assert i.messages[-1][1].startswith("temperature = "), i.messages
        i.close()
        i = Inst(path, zero_per_10K=0.01, temperature=310.0)
    i.close()
    i = Inst(path, temperature=0.0)                   # not read: no drift per 10 K
    i.step(x=1.0, temperature=0.0)
    assert i.get("y")[0] == pytest.approx(1.0, abs=0.1)
    i.close()


# -- the FMI front ----------------------------------------------------------------------------
class Host:
    """A minimal C host over ctypes: the FMU's functions with a logger that records messages."""

    def __init__(self, fmu_path, tmp_path):
        from fmpy import extract, read_model_description
        self.md = read_model_description(str(fmu_path))
        self.dir = extract(str(fmu_path), str(tmp_path / "x"))
        name = self.md.coSimulation.modelIdentifier
        self.lib = ctypes.CDLL(f"{self.dir}/binaries/linux64/{name}.so")
        self.vars = {v.name: v for v in self.md.modelVariables}
        self.messages = []
        LOGGER = ctypes.CFUNCTYPE(None, ctypes.c_void_p, ctypes.c_char_p, ctypes.c_int,
                                  ctypes.c_char_p, ctypes.c_char_p)
        self._logger = LOGGER(lambda env, inst, status, cat, msg:
                              self.messages.append(msg.decode()))

        class Callbacks(ctypes.Structure):
            _fields_ = [("logger", LOGGER), ("allocateMemory", ctypes.c_void_p),
                        ("freeMemory", ctypes.c_void_p), ("stepFinished", ctypes.c_void_p),
                        ("componentEnvironment", ctypes.c_void_p)]
        self.callbacks = Callbacks(self._logger, None, None, None, None)
        self.lib.fmi2Instantiate.restype = ctypes.c_void_p
        self.lib.fmi2Instantiate.argtypes = [ctypes.c_char_p, ctypes.c_int, ctypes.c_char_p,
                                             ctypes.c_char_p, ctypes.c_void_p, ctypes.c_int,
                                             ctypes.c_int]
        for fn in ("fmi2SetupExperiment", "fmi2EnterInitializationMode",
                   "fmi2ExitInitializationMode", "fmi2DoStep", "fmi2SetReal", "fmi2GetReal",
                   "fmi2SetString", "fmi2GetFMUstate", "fmi2SetFMUstate", "fmi2FreeFMUstate",
                   "fmi2SerializedFMUstateSize", "fmi2SerializeFMUstate",
                   "fmi2DeSerializeFMUstate", "fmi2Terminate"):
            getattr(self.lib, fn).restype = ctypes.c_int
        self.lib.fmi2FreeInstance.argtypes = [ctypes.c_void_p]

    def instantiate(self, guid=None, kind=1):
        g = (guid or self.md.guid).encode()
        return self.lib.fmi2Instantiate(b"x", kind, g, b"file:///", ctypes.byref(self.callbacks),
                                        0, 1)

    def vr(self, name):
        return (ctypes.c_uint * 1)(self.vars[name].valueReference)

    def set_real(self, c, name, value):
        return self.lib.fmi2SetReal(ctypes.c_void_p(c), self.vr(name), ctypes.c_size_t(1),
                                    (ctypes.c_double * 1)(value))

    def get_real(self, c, name):
        out = (ctypes.c_double * 1)()
        assert self.lib.fmi2GetReal(ctypes.c_void_p(c), self.vr(name), ctypes.c_size_t(1),
                                    out) == 0
        return out[0]

    def set_string(self, c, name, text: bytes):
        return self.lib.fmi2SetString(ctypes.c_void_p(c), self.vr(name), ctypes.c_size_t(1),
                                      (ctypes.c_char_p * 1)(text))

    def start(self, c):
        assert self.lib.fmi2SetupExperiment(ctypes.c_void_p(c), 0, ctypes.c_double(0), ctypes.c_double(0), 0,
                                            ctypes.c_double(0)) == 0
        assert self.lib.fmi2EnterInitializationMode(ctypes.c_void_p(c)) == 0

    def step(self, c, t, h):
        return self.lib.fmi2DoStep(ctypes.c_void_p(c), ctypes.c_double(t), ctypes.c_double(h), 1)


ERROR = 3


@pytest.fixture(scope="module")
def brake(tmp_path_factory):
    d = tmp_path_factory.mktemp("brake")
    return Host(build_any("FeltBrakeNative", d), d)


def test_misuse_answers_fmi2error(brake):
    h = brake
    assert h.instantiate(guid="{wrong}") is None
    assert h.instantiate(kind=0) is None                       # Model Exchange
    assert any("GUID" in m for m in h.messages)
    c = h.instantiate()
    assert c
    assert h.step(c, 0.0, 1e-3) == ERROR                       # before initialization
    h.start(c)
    assert h.set_real(c, "w_reg", -1.0) == ERROR               # below its declared min
    assert h.set_real(c, "w", float("nan")) == ERROR
    assert h.lib.fmi2SetReal(ctypes.c_void_p(c), None, ctypes.c_size_t(1), None) == ERROR
    assert h.lib.fmi2DoStep(None, ctypes.c_double(0), ctypes.c_double(1e-3), 1) == ERROR
    assert h.lib.fmi2ExitInitializationMode(ctypes.c_void_p(c)) == 0
    assert h.set_real(c, "T_first", 2.0) == ERROR              # a parameter after init
    assert any("fixed parameter" in m for m in h.messages)
    assert h.step(c, 0.0, float("-inf")) == ERROR
    assert h.step(c, 0.0, 1e-3) == 0
    h.lib.fmi2FreeInstance(ctypes.c_void_p(c))


def test_format_directives_in_a_string_are_text_not_a_format(brake):
    """torque_schedule = "0:%s%s%s%s": refused at initialization with fmi2Error, the host alive
    and the message holding no expansion of the directives."""
    h = brake
    c = h.instantiate()
    h.start(c)
    h.messages.clear()
    assert h.set_string(c, "torque_schedule", b"0:%s%s%s%s%n%x") == 0      # text is text
    assert h.lib.fmi2ExitInitializationMode(ctypes.c_void_p(c)) == ERROR
    assert h.messages and all("%" not in m for m in h.messages)
    assert "torque_schedule" in h.messages[-1]
    h.lib.fmi2FreeInstance(ctypes.c_void_p(c))


def test_state_round_trip_and_a_corrupted_state_is_refused(brake):
    h = brake
    c = h.instantiate()
    h.start(c)
    h.set_real(c, "J_out", 2e-3)                                 # a drum: dynamic state
    assert h.lib.fmi2ExitInitializationMode(ctypes.c_void_p(c)) == 0
    h.set_real(c, "w", 10.0)
    for k in range(50):
        assert h.step(c, k * 1e-3, 1e-3) == 0
    state = ctypes.c_void_p()
    assert h.lib.fmi2GetFMUstate(ctypes.c_void_p(c), ctypes.byref(state)) == 0
    size = ctypes.c_size_t()
    assert h.lib.fmi2SerializedFMUstateSize(ctypes.c_void_p(c), state, ctypes.byref(size)) == 0
    buf = (ctypes.c_char * size.value)()
    assert h.lib.fmi2SerializeFMUstate(ctypes.c_void_p(c), state, buf, size) == 0
    ahead = []
    for k in range(50, 80):
        h.step(c, k * 1e-3, 1e-3)
        ahead.append(h.get_real(c, "tau_out"))
    # restore from the serialised copy: the same continuation, bit for bit
    copy = ctypes.c_void_p()
    assert h.lib.fmi2DeSerializeFMUstate(ctypes.c_void_p(c), buf, size, ctypes.byref(copy)) == 0
    assert h.lib.fmi2SetFMUstate(ctypes.c_void_p(c), copy) == 0
    again = []
    for k in range(50, 80):
        h.step(c, k * 1e-3, 1e-3)
        again.append(h.get_real(c, "tau_out"))
    assert again == ahead and np.ptp(ahead) > 0
    # a state with a NaN drum speed, or another FMU's GUID, is refused
    raw = bytearray(buf.raw)
    bad = (ctypes.c_char * size.value).from_buffer_copy(bytes(raw[:8]) + b"\xff" * 8 + bytes(raw[16:]))
    other = ctypes.c_void_p()
    assert h.lib.fmi2DeSerializeFMUstate(ctypes.c_void_p(c), bad, size,
                                         ctypes.byref(other)) == ERROR
    tail = bytes(raw[48:])
    nan = np.frombuffer(tail[:len(tail) // 8 * 8], dtype=np.float64).copy()
    finite = np.flatnonzero(np.isfinite(nan) & (nan != 0))
    nan[finite[-1]] = np.nan
    broken = bytes(raw[:48]) + nan.tobytes() + tail[len(tail) // 8 * 8:]
    bad2 = (ctypes.c_char * size.value).from_buffer_copy(broken)
    assert h.lib.fmi2DeSerializeFMUstate(ctypes.c_void_p(c), bad2, size,
                                         ctypes.byref(other)) == ERROR
    for s in (state, copy):
        h.lib.fmi2FreeFMUstate(ctypes.c_void_p(c), ctypes.byref(s))
    h.lib.fmi2FreeInstance(ctypes.c_void_p(c))


def test_native_fmus_carry_their_sources_and_pass_fmpys_validation(both):
    import zipfile

    from fmpy.validation import validate_fmu
    _, d = both
    for name in RIG_NATIVE:
        path = d / f"{name}.fmu"
        assert validate_fmu(str(path)) == [], name
        names = zipfile.ZipFile(path).namelist()
        for f in ("sources/buildDescription.xml", "sources/rig_fmi2.c", "sources/rig_vars.h",
                  f"binaries/linux64/{name}.so"):
            assert f in names, (name, f)


def test_the_native_ssp_runs_in_fmpy_and_libcosim_alike(both, tmp_path):
    """TestBench.ssp with the native set: fmpy's SSP master and libcosim (a second importer,
    FMI Library) give the same physics."""
    pytest.importorskip("libcosimpy")
    from test_bench import libcosim_last_values

    from cyclo_fmu.bench import build_ssp, run_ssp
    _, d = both
    sc = Scenario("short", mode="S2", f_first=30, f_last=30, f_count=1, T_first=5, T_last=5,
                  T_count=1, hold=1.5, duration=1.5)
    ssp = build_ssp(tmp_path / "TestBench.ssp", d, sc, Sensors(ideal=True), fmus="native")
    fm = run_ssp(ssp, 1.5)
    names = (("drive", "tau_in"), ("drive", "eta"), ("motor", "w"), ("brake", "tau_out"))
    for (comp, var), value in zip(names, libcosim_last_values(ssp, 1.5, names)):
        # fmpy's row k holds the values after step k+1; libcosim stopped after 1500 steps (as
        # test_bench: the reducer's grease warms by a step's heat between rows)
        assert value == pytest.approx(fm[f"{comp}.{var}"][1499], rel=1e-9, abs=1e-12), (comp,
                                                                                        var)


def test_the_native_reducer_in_a_folder_is_checked_against_the_design(both):
    """A bench of another design than the native reducer was built for is refused, naming
    the value that differs (its map is compiled in)."""
    from cyclo_fmu.bench import check_native_design
    from model_core import DriveDesign
    _, d = both
    check_native_design(d, DriveDesign())
    check_native_design(d, None)
    with pytest.raises(ValueError, match="profile"):
        check_native_design(d, DriveDesign(profile="paper"))


@pytest.mark.slow
def test_a_design_of_its_own_gives_the_same_bench_in_both_sets(fmu_dir, tmp_path):
    """The paper profile: the Python reducer takes the design as parameters, the native one is
    built for it (its map compiled in); the two benches are twins."""
    from cyclo_fmu.bench import run_bench
    from cyclo_fmu.native import build_native_fmu
    from model_core import DriveDesign
    design = DriveDesign(profile="paper")
    for name in RIG_NATIVE:
        build_any(name, tmp_path)
    build_native_fmu(design, tmp_path)
    sc = scenario("runup", "S2")
    py = run_bench(sc, fmu_dir, design=design, fmus="python")
    na = run_bench(sc, tmp_path, design=design, fmus="native")
    assert_twins(py.result, na.result)
    with pytest.raises(ValueError, match="another design"):
        run_bench(sc, tmp_path, fmus="native")            # the default design is not this one
