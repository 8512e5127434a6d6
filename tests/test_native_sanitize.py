"""The native bench components under AddressSanitizer and UndefinedBehaviorSanitizer, driven by
a hostile C host (tests/native/rig_hostile.c): NULLs, format directives, extreme values on every
value reference, corrupted states, calls out of order, threads. Any memory or undefined-
behaviour fault aborts the harness; a wrong status fails it."""
import os
import shutil
import subprocess
import zipfile
from pathlib import Path

import pytest

from cyclo_fmu.fmu_build import build_any
from fmpy import read_model_description

HARNESS = Path(__file__).resolve().parent / "native" / "rig_hostile.c"


def _sanitizer_compiler():
    cc = shutil.which("gcc")
    if cc is None:
        pytest.skip("no gcc")
    probe = subprocess.run([cc, "-fsanitize=address,undefined", "-x", "c", "-", "-o",
                            os.devnull], input="int main(void){return 0;}", text=True,
                           capture_output=True)
    if probe.returncode != 0:
        pytest.skip(f"gcc cannot build with ASan/UBSan here: {probe.stderr.strip()[:200]}")
    return cc


@pytest.mark.parametrize("name", ["InductionMotorNative", "FeltBrakeNative",
                                  "SpeedTransducerNative"])
def test_hostile_host_under_asan_and_ubsan(name, tmp_path):
    cc = _sanitizer_compiler()
    fmu = build_any(name, tmp_path)
    with zipfile.ZipFile(fmu) as z:
        z.extractall(tmp_path / "x")
    src = tmp_path / "x" / "sources"
    sources = [str(src / f) for f in ("rig_fmi2.c", "rig_common.c")]
    sources += [str(p) for p in src.glob("rig_*.c") if p.name not in ("rig_fmi2.c",
                                                                        "rig_common.c")]
    exe = tmp_path / "hostile"
    r = subprocess.run([cc, "-std=c99", "-D_DEFAULT_SOURCE", "-g", "-O1", "-ffp-contract=off",
                        "-fsanitize=address,undefined", "-fno-sanitize-recover=all",
                        "-fno-omit-frame-pointer", "-pthread", f"-I{src}", "-o", str(exe),
                        str(HARNESS), *sources, "-lm"], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    guid = read_model_description(str(fmu)).guid
    run = subprocess.run([str(exe), guid], capture_output=True, text=True, timeout=600,
                         env=dict(os.environ, ASAN_OPTIONS="detect_leaks=1:abort_on_error=0",
                                  UBSAN_OPTIONS="print_stacktrace=1"))
    assert run.returncode == 0, (run.stdout + run.stderr)[-4000:]
    assert "all checks passed" in run.stdout
