"""Every native binary of the project built with AddressSanitizer and UndefinedBehaviorSanitizer
(gcc ``-fsanitize=address,undefined``) and driven by hostile calls: a script CI can call.

    python -m cyclo_fmu.native.sanitize            # everything (about a minute)
    python -m cyclo_fmu.native.sanitize --quick    # fewer iterations (the default test suite)

Three runs, each a separate process that aborts at the first memory error or undefined
behaviour (``-fno-sanitize-recover=all``, ``halt_on_error``):

- ``native``: ``CycloidDriveNative``'s sources (the default design's map) linked into
  ``hostile/host_native.c``: NULL arguments, printf directives in strings, inputs at and past
  every edge of the map (one ulp around ``w_low`` included), every field of a serialised state
  overwritten and random bit flips, allocateMemory without freeMemory, 8 threads creating,
  stepping, saving and freeing instances at once.
- ``front``: the pythonfmu status front (``fmi2_status_shim.c``) as a shared library in a
  FeltBrake FMU, loaded by Python with the sanitizer runtime preloaded: NULL arguments, a
  String parameter full of printf directives (logging off and on), 8 threads creating and
  freeing instances at once.
- ``loop``: the bench loop (``bench_loop.c``) with ``hostile/host_loop.c``: a valid run and
  every count, offset and index one past its buffer (refused before any call).

Two more runs, opt-in (``--tsan``, or ``--only tsan-native`` / ``--only tsan-front``), build
the same code with ThreadSanitizer (gcc ``-fsanitize=thread``, libtsan) and run only the
threads: 8 threads creating, stepping, saving/restoring and freeing native instances at once
(``tsan-native``), and 8 Python threads doing the same through the front with libtsan preloaded
into Python (``tsan-front``; pythonfmu's own binary and the interpreter are not instrumented,
their locks are seen through libtsan's interceptors). Any data race report is fatal.

Exit status 0 when every run is clean; each run's last lines are printed. Needs gcc with
libasan/libubsan (Debian: gcc); without them it says so and exits 77 (the "skip" of automake);
likewise for libtsan when a ThreadSanitizer run is asked for.
"""
from __future__ import annotations

import argparse
import os
import shutil
import subprocess
import sys
import tempfile
import textwrap
import zipfile
from pathlib import Path

HERE = Path(__file__).resolve().parent
HOSTILE = HERE / "hostile"
#: the sanitizer flags: both sanitizers, every report fatal, frames for readable reports
SAN_FLAGS = ("-fsanitize=address,undefined", "-fno-sanitize-recover=all",
             "-fno-omit-frame-pointer", "-g", "-O1")
#: the runtime options: stop at the first report; leak checking off for the Python run
#: (the interpreter keeps its objects to the end by design)
ASAN_OPTIONS = "halt_on_error=1:abort_on_error=0:exitcode=86:detect_leaks={leaks}"
UBSAN_OPTIONS = "halt_on_error=1:print_stacktrace=1:exitcode=87"
SKIP = 77
#: ThreadSanitizer: one report is fatal (exit 66)
TSAN_FLAGS = ("-fsanitize=thread", "-fno-omit-frame-pointer", "-g", "-O1")
TSAN_OPTIONS = "halt_on_error=1:exitcode=66:second_deadlock_stack=1"


def sanitizers_available(cc: str, flags=SAN_FLAGS) -> str | None:
    """None if ``cc`` builds and runs a program with the sanitizers of ``flags`` (default
    ASan + UBSan) here, else why not."""
    with tempfile.TemporaryDirectory(prefix="cyclofmu_san_") as tmp:
        src = Path(tmp) / "t.c"
        src.write_text("int main(void) { return 0; }\n")
        try:
            r = subprocess.run([cc, *flags, str(src), "-o", str(Path(tmp) / "t")],
                               capture_output=True, text=True, timeout=120)
        except (OSError, subprocess.TimeoutExpired) as exc:
            return f"{cc} cannot be run ({exc})"
        if r.returncode != 0:
            return f"{cc} {flags[0]} fails: {r.stderr.strip()[:200]}"
        r = subprocess.run([str(Path(tmp) / "t")], capture_output=True, text=True)
        if r.returncode != 0:
            return f"a sanitized program does not run here: {r.stderr.strip()[:200]}"
    return None


def _runtime(cc: str, name: str) -> str:
    path = subprocess.run([cc, f"-print-file-name={name}"], capture_output=True,
                          text=True).stdout.strip()
    return path if os.path.isabs(path) and os.path.exists(path) else ""


def _env(leaks: bool, extra=None):
    env = dict(os.environ)
    env["ASAN_OPTIONS"] = ASAN_OPTIONS.format(leaks=int(leaks))
    env["UBSAN_OPTIONS"] = UBSAN_OPTIONS
    env["TSAN_OPTIONS"] = TSAN_OPTIONS
    env.update(extra or {})
    return env


def _compile(cc, args, what):
    r = subprocess.run([cc, *args], capture_output=True, text=True)
    if r.returncode != 0:
        raise RuntimeError(f"compiling {what} failed: {r.stderr.strip()[:500]}")


def run_native(cc: str, work: Path, iterations: int, flags=SAN_FLAGS,
               only_threads=False) -> subprocess.CompletedProcess:
    """The native FMU's sources with host_native.c, sanitized (``flags``); ``only_threads``:
    the 8 threads only (the ThreadSanitizer run)."""
    from model_core import DriveDesign

    from . import build as nb
    design = DriveDesign()
    src = work / "native"
    src.mkdir()
    lt, lw, modes = nb.export_map(design)
    # one node over the grease temperature (the design's own) is enough to drive the code
    nodes = [(design.operating_temperature, modes)]
    data = nb.generate_data_c(design, lt, lw, nodes, nb.design_constants(design),
                              "{sanitize}", nb.MAP_TORQUE_MAX, nb.MAP_SPEED_MAX)
    (src / nb.GENERATED).write_text(data)
    for f in nb.C_SOURCES + nb.C_HEADERS:
        shutil.copyfile(HERE / f, src / f)
    exe = work / "host_native"
    _compile(cc, ["-std=gnu99", *flags, "-ffp-contract=off", f"-I{src}",
                  f"-I{nb.fmi_header_dir()}", "-o", str(exe), str(HOSTILE / "host_native.c"),
                  *[str(src / f) for f in nb.C_SOURCES + (nb.GENERATED,)], "-lm", "-lpthread"],
             "the native FMU with host_native.c")
    return subprocess.run([str(exe), str(iterations), *(["threads"] if only_threads else [])],
                          capture_output=True, text=True, env=_env(leaks=True), timeout=1800)


def run_loop(cc: str, work: Path) -> subprocess.CompletedProcess:
    exe = work / "host_loop"
    _compile(cc, ["-std=gnu99", *SAN_FLAGS, "-o", str(exe), str(HOSTILE / "host_loop.c"),
                  str(HERE / "bench_loop.c")], "the bench loop with host_loop.c")
    return subprocess.run([str(exe)], capture_output=True, text=True, env=_env(leaks=True),
                          timeout=600)


#: the Python side of the front's run (the FMU's directory and the number of iterations)
FRONT_HOST = r'''
import ctypes, json, os, sys, threading
from fmpy import read_model_description
d, n = sys.argv[1], int(sys.argv[2])
only_threads = len(sys.argv) > 3 and sys.argv[3] == "threads"
md = read_model_description(os.path.join(d, "modelDescription.xml"))
vr = {v.name: v.valueReference for v in md.modelVariables}
lib = ctypes.CDLL(os.path.join(d, "binaries", "linux64", "FeltBrake.so"))
LOGGER = ctypes.CFUNCTYPE(None, ctypes.c_void_p, ctypes.c_char_p, ctypes.c_int,
                          ctypes.c_char_p, ctypes.c_char_p)
seen = []
@LOGGER
def logger(env, name, status, cat, msg):
    seen.append(msg)
class CB(ctypes.Structure):
    _fields_ = [("logger", LOGGER), ("allocateMemory", ctypes.c_void_p),
                ("freeMemory", ctypes.c_void_p), ("stepFinished", ctypes.c_void_p),
                ("componentEnvironment", ctypes.c_void_p)]
cb = CB(logger, None, None, None, None)
P, D, S, U = ctypes.c_void_p, ctypes.c_double, ctypes.c_size_t, ctypes.c_uint
for name, res, args in (
        ("fmi2Instantiate", P, [ctypes.c_char_p, ctypes.c_int, ctypes.c_char_p, ctypes.c_char_p,
                                P, ctypes.c_int, ctypes.c_int]),
        ("fmi2FreeInstance", None, [P]),
        ("fmi2SetupExperiment", ctypes.c_int, [P, ctypes.c_int, D, D, ctypes.c_int, D]),
        ("fmi2EnterInitializationMode", ctypes.c_int, [P]),
        ("fmi2ExitInitializationMode", ctypes.c_int, [P]),
        ("fmi2Terminate", ctypes.c_int, [P]),
        ("fmi2DoStep", ctypes.c_int, [P, D, D, ctypes.c_int]),
        ("fmi2SetDebugLogging", ctypes.c_int, [P, ctypes.c_int, S, P]),
        ("fmi2GetReal", ctypes.c_int, [P, P, S, P]), ("fmi2SetReal", ctypes.c_int, [P, P, S, P]),
        ("fmi2SetString", ctypes.c_int, [P, P, S, P]),
        ("fmi2GetFMUstate", ctypes.c_int, [P, P]), ("fmi2SetFMUstate", ctypes.c_int, [P, P]),
        ("fmi2FreeFMUstate", ctypes.c_int, [P, P])):
    f = getattr(lib, name)
    f.restype, f.argtypes = res, args
uri = ("file://" + os.path.join(d, "resources")).encode()
guid = md.guid.encode()
problems = []
def check(cond, what):
    if not cond:
        problems.append(what)
def instance(logging=0):
    return lib.fmi2Instantiate(b"b", 1, guid, uri, ctypes.byref(cb), 0, logging)
if not only_threads:         # the ThreadSanitizer run: the threads below only
    # NULLs
    check(lib.fmi2Instantiate(None, 1, guid, uri, ctypes.byref(cb), 0, 0) is None, "NULL name")
    check(lib.fmi2Instantiate(b"b", 1, guid, None, ctypes.byref(cb), 0, 0) is None, "NULL resources")
    check(lib.fmi2Instantiate(b"b", 1, None, uri, ctypes.byref(cb), 0, 0) is None, "NULL GUID")
    check(lib.fmi2Instantiate(b"b", 1, guid, uri, None, 0, 0) is None, "NULL callbacks")
    check(lib.fmi2Instantiate(b"b", 0, guid, uri, ctypes.byref(cb), 0, 0) is None, "ME")
    check(lib.fmi2Instantiate(b"%s%n", 1, b"%s%s%n", uri, ctypes.byref(cb), 0, 1) is None, "GUID")
    for fn in ("fmi2EnterInitializationMode", "fmi2ExitInitializationMode", "fmi2Terminate"):
        check(getattr(lib, fn)(None) == 3, f"NULL component {fn}")
    check(lib.fmi2DoStep(None, 0.0, 1e-3, 1) == 3, "NULL component fmi2DoStep")
    lib.fmi2FreeInstance(None)
    c = instance()
    check(c is not None, "instantiate")
    check(lib.fmi2GetReal(c, None, 3, None) == 3, "NULL arrays get")
    check(lib.fmi2SetReal(c, None, 3, None) == 3, "NULL arrays set")
    check(lib.fmi2SetDebugLogging(c, 1, 2, None) == 3, "NULL categories")
    cats = (ctypes.c_char_p * 2)(b"logAll", None)
    check(lib.fmi2SetDebugLogging(c, 1, 2, cats) == 3, "a NULL category")
    check(lib.fmi2GetFMUstate(c, None) == 3, "NULL state pointer")
    check(lib.fmi2SetFMUstate(c, None) == 3, "NULL state")
    lib.fmi2FreeInstance(c)
    # printf directives in a String parameter, logging off and on
    for logging in (0, 1):
        c = instance(logging)
        lib.fmi2SetDebugLogging(c, logging, 0, None)
        lib.fmi2SetupExperiment(c, 0, 0.0, 0.0, 0, 0.0)
        lib.fmi2EnterInitializationMode(c)
        ref = (ctypes.c_uint * 1)(vr["torque_schedule"])
        val = (ctypes.c_char_p * 1)(b"0:%s%s%s%s%n%n%x%x%p")
        lib.fmi2SetString(c, ref, 1, val)
        check(lib.fmi2ExitInitializationMode(c) == 3, "hostile schedule accepted")
        check(lib.fmi2DoStep(c, 0.0, 1e-3, 1) == 3, "step after failed initialization")
        lib.fmi2FreeInstance(c)
    check(any(b"%%s%%s" in m for m in seen), "the schedule was not logged as text")
    # states: a round trip, a foreign pointer, a short and a corrupted serialised state
    for name, args in (("fmi2SerializedFMUstateSize", [P, P, P]),
                       ("fmi2SerializeFMUstate", [P, P, P, S]),
                       ("fmi2DeSerializeFMUstate", [P, P, S, P])):
        getattr(lib, name).restype, getattr(lib, name).argtypes = ctypes.c_int, args
    c = instance()
    lib.fmi2SetupExperiment(c, 0, 0.0, 0.0, 0, 0.0)
    lib.fmi2EnterInitializationMode(c)
    lib.fmi2ExitInitializationMode(c)
    st, size = ctypes.c_void_p(), ctypes.c_size_t()
    check(lib.fmi2GetFMUstate(c, ctypes.byref(st)) == 0, "get state")
    check(lib.fmi2SerializedFMUstateSize(c, st, ctypes.byref(size)) == 0, "state size")
    blob = (ctypes.c_char * size.value)()
    check(lib.fmi2SerializeFMUstate(c, st, blob, size.value) == 0, "serialize")
    check(lib.fmi2SerializeFMUstate(c, st, blob, 3) == 3, "short buffer")
    back = ctypes.c_void_p()
    check(lib.fmi2DeSerializeFMUstate(c, blob, size.value, ctypes.byref(back)) == 0, "deserialize")
    check(lib.fmi2SetFMUstate(c, back) == 0, "set state")
    foreign = (ctypes.c_char * 64)()
    check(lib.fmi2SetFMUstate(c, foreign) == 3, "a foreign state")
    check(lib.fmi2DeSerializeFMUstate(c, blob, 5, ctypes.byref(back)) == 3, "5 bytes")
    bad = bytearray(blob.raw)
    bad[4] = 99
    check(lib.fmi2DeSerializeFMUstate(c, bytes(bad), size.value, ctypes.byref(back)) == 3, "phase")
    bad = bytearray(blob.raw)
    bad[8:12] = b"]]]]"
    check(lib.fmi2DeSerializeFMUstate(c, bytes(bad), size.value, ctypes.byref(back)) == 3, "json")
    lib.fmi2FreeFMUstate(c, ctypes.byref(st))
    lib.fmi2FreeFMUstate(c, ctypes.byref(back))
    lib.fmi2FreeInstance(c)
# threads creating, stepping and freeing instances at once (the GIL is released in the calls)
def work(k):
    for i in range(n):
        c = instance(i % 2)
        if c is None:
            problems.append("threaded instantiate")
            continue
        lib.fmi2SetupExperiment(c, 0, 0.0, 0.0, 0, 0.0)
        lib.fmi2EnterInitializationMode(c)
        lib.fmi2ExitInitializationMode(c)
        lib.fmi2DoStep(c, 0.0, 1e-3, 1)
        lib.fmi2Terminate(c)
        lib.fmi2FreeInstance(c)
th = [threading.Thread(target=work, args=(k,)) for k in range(8)]
[t.start() for t in th]
[t.join() for t in th]
print("front:", len(problems), "problems", json.dumps(problems), file=sys.stderr, flush=True)
os._exit(1 if problems else 0)      # past pythonfmu's own shutdown (a known use-after-free)
'''


def run_front(cc: str, work: Path, iterations: int, flags=SAN_FLAGS,
              only_threads=False) -> subprocess.CompletedProcess:
    """The pythonfmu front, sanitized (``flags``), in a FeltBrake FMU run by Python with the
    sanitizer runtime preloaded; ``only_threads``: the 8 threads only (ThreadSanitizer)."""
    from ..fmu_build import SHIM_SOURCE, build_fmu, shim_header
    from .build import fmi_header_dir
    fmu = build_fmu("FeltBrake", work / "fmu")
    d = work / "FeltBrake"
    with zipfile.ZipFile(fmu) as z:
        z.extractall(d)
    md = (d / "modelDescription.xml").read_text()
    import re
    failed_vr = re.search(r'name="_failed" valueReference="(\d+)"', md).group(1)
    header = work / "shim_vars.h"
    header.write_text(shim_header(md))
    so = d / "binaries" / "linux64" / "FeltBrake.so"
    if not (d / "binaries" / "linux64" / "FeltBrake.pythonfmu.so").exists():
        raise RuntimeError("the FMU was built without the C front (no compiler?)")
    _compile(cc, ["-std=gnu99", *flags, "-shared", "-fPIC", f"-I{fmi_header_dir()}",
                  f"-DFAILED_VR={failed_vr}", f'-DSHIM_VARS="{header}"', "-o", str(so),
                  str(SHIM_SOURCE), "-ldl", "-lpthread"], "the pythonfmu front")
    runtimes = ("libtsan.so",) if flags == TSAN_FLAGS else ("libasan.so", "libubsan.so")
    preload = ":".join(p for p in (_runtime(cc, r) for r in runtimes) if p)
    extra = {"LD_PRELOAD": preload, "PYTHONPATH": os.pathsep.join(sys.path)}
    if flags == TSAN_FLAGS:
        # pythonfmu's interpreter thread (a std::thread of its own, joined only by its exit
        # handlers, which the script's os._exit skips) is not a race: no thread-leak report
        extra["TSAN_OPTIONS"] = TSAN_OPTIONS + ":report_thread_leaks=0"
    env = _env(leaks=False, extra=extra)
    return subprocess.run([sys.executable, "-c", FRONT_HOST, str(d), str(iterations),
                           *(["threads"] if only_threads else [])],
                          capture_output=True, text=True, env=env, timeout=1800)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog="python -m cyclo_fmu.native.sanitize",
                                description=__doc__.split("\n\n")[0])
    p.add_argument("--quick", action="store_true", help="fewer iterations (a few seconds each)")
    p.add_argument("--only", choices=("native", "front", "loop", "tsan-native", "tsan-front"),
                   action="append", help="run only these (repeatable)")
    p.add_argument("--tsan", action="store_true", help="add the ThreadSanitizer runs "
                   "(tsan-native, tsan-front: 8 threads each; slow)")
    args = p.parse_args(argv)
    from .build import find_compiler
    try:
        cc = find_compiler()
    except Exception as exc:   # noqa: BLE001 - reported as a skip
        print(f"skip: {exc}")
        return SKIP
    runs = args.only or ["native", "front", "loop"] + (["tsan-native", "tsan-front"]
                                                       if args.tsan else [])
    for flags, wanted in ((SAN_FLAGS, any(not r.startswith("tsan") for r in runs)),
                          (TSAN_FLAGS, any(r.startswith("tsan") for r in runs))):
        why = sanitizers_available(cc, flags) if wanted else None
        if why:
            print(f"skip: {why}")
            return SKIP
    iterations = 20 if args.quick else 1000
    failed = []
    with tempfile.TemporaryDirectory(prefix="cyclofmu_sanitize_") as tmp:
        for name in runs:
            work = Path(tmp) / name
            work.mkdir()
            if name == "native":
                r = run_native(cc, work, iterations)
            elif name == "front":
                r = run_front(cc, work, max(2, iterations // 10))
            elif name == "tsan-native":
                r = run_native(cc, work, max(4, iterations // 10), TSAN_FLAGS,
                               only_threads=True)
            elif name == "tsan-front":
                r = run_front(cc, work, max(2, iterations // 20), TSAN_FLAGS,
                              only_threads=True)
            else:
                r = run_loop(cc, work)
            tail = "\n".join(r.stderr.strip().splitlines()[-25:])
            status = "clean" if r.returncode == 0 else f"FAILED (exit {r.returncode})"
            print(f"== {name}: {status}\n{textwrap.indent(tail, '   ')}", flush=True)
            if r.returncode != 0:
                failed.append(name)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
