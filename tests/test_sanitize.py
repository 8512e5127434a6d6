"""The native binaries under AddressSanitizer + UndefinedBehaviorSanitizer, driven by hostile
calls (cyclo_fmu/native/sanitize.py; docs/explanation/fmu-safety.md). The quick run (few
iterations, about 15 s) is in the default suite; the full one is marked slow."""
import os
import subprocess
import sys

import pytest

from cyclo_fmu.native import sanitize

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def _run(*args):
    r = subprocess.run([sys.executable, "-m", "cyclo_fmu.native.sanitize", *args],
                       capture_output=True, text=True, timeout=3000,
                       env=dict(os.environ, PYTHONPATH=ROOT))
    if r.returncode == sanitize.SKIP:
        pytest.skip(r.stdout.strip())
    return r


@pytest.mark.parametrize("part", ["native", "front", "loop"])
def test_sanitized_quick_run_is_clean(part):
    r = _run("--quick", "--only", part)
    assert r.returncode == 0, r.stdout[-4000:] + r.stderr[-2000:]
    assert f"== {part}: clean" in r.stdout


@pytest.mark.slow
def test_sanitized_full_run_is_clean():
    r = _run()
    assert r.returncode == 0, r.stdout[-6000:] + r.stderr[-2000:]
    assert r.stdout.count(": clean") == 3


@pytest.mark.slow
@pytest.mark.parametrize("part", ["tsan-native", "tsan-front"])
def test_thread_sanitizer_finds_no_race(part):
    """8 threads creating, stepping, saving and freeing instances at once (native FMU; the
    Python FMUs' C front) under ThreadSanitizer: no data race report (any is fatal)."""
    r = _run("--only", part)
    assert r.returncode == 0, r.stdout[-6000:] + r.stderr[-2000:]
    assert f"== {part}: clean" in r.stdout

