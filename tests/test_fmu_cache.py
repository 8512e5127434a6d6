"""The FMU cache of ``cyclo-fmu bench``: an entry is reused only for the same key and only
while its digest matches; a changed design is another entry; writes leave no partial file."""
import zipfile
from pathlib import Path

import pytest

from cyclo_fmu import fmu_cache
from model_core import DriveDesign


def fake_build(calls):
    """A stand-in builder: a small valid zip named like the FMU, counting its calls."""
    def build(name, dest, design):
        calls.append((name, design))
        out = Path(dest) / f"{name}.fmu"
        with zipfile.ZipFile(out, "w") as z:
            z.writestr("modelDescription.xml", f"<m name='{name}' n='{len(calls)}'/>")
        return out
    return build


@pytest.fixture
def cache(tmp_path, monkeypatch):
    monkeypatch.setenv("CYCLOFMU_CACHE", str(tmp_path / "cache"))
    return tmp_path / "cache"


def test_second_request_reuses_the_entry(cache):
    calls = []
    a = fmu_cache.cached_fmu("FeltBrake", build=fake_build(calls))
    b = fmu_cache.cached_fmu("FeltBrake", build=fake_build(calls))
    assert a == b and len(calls) == 1
    assert a.parent.parent == cache
    # nothing half-written left behind
    assert sorted(p.name for p in a.parent.iterdir()) == ["FeltBrake.fmu", "FeltBrake.fmu.sha256"]


def test_a_corrupted_entry_is_rebuilt_not_loaded(cache):
    calls = []
    a = fmu_cache.cached_fmu("FeltBrake", build=fake_build(calls))
    a.write_bytes(a.read_bytes()[:-5])           # truncated
    b = fmu_cache.cached_fmu("FeltBrake", build=fake_build(calls))
    assert len(calls) == 2 and zipfile.is_zipfile(b)
    a.with_name(a.name + ".sha256").unlink()      # an entry without its digest: not trusted
    fmu_cache.cached_fmu("FeltBrake", build=fake_build(calls))
    assert len(calls) == 3


def test_the_design_keys_the_native_fmu_only():
    d1, d2 = DriveDesign(), DriveDesign(profile="paper")
    assert fmu_cache.fmu_key("CycloidDriveNative", d1) != fmu_cache.fmu_key("CycloidDriveNative", d2)
    assert fmu_cache.fmu_key("CycloidDriveNative", d1) == fmu_cache.fmu_key("CycloidDriveNative",
                                                                             DriveDesign())
    assert fmu_cache.fmu_key("FeltBrake") != fmu_cache.fmu_key("InductionMotor")


def test_a_source_change_changes_every_key(monkeypatch):
    before = fmu_cache.fmu_key("FeltBrake")
    monkeypatch.setitem(fmu_cache._SOURCE_DIGEST, "d", "another source tree")
    assert fmu_cache.fmu_key("FeltBrake") != before


def test_fmus_into_copies_the_cached_files(cache, tmp_path):
    calls = []
    out = fmu_cache.fmus_into(tmp_path / "fmus", ["FeltBrake", "InductionMotor"],
                              build=fake_build(calls))
    assert sorted(p.name for p in out.iterdir()) == ["FeltBrake.fmu", "InductionMotor.fmu"]
    fmu_cache.fmus_into(tmp_path / "again", ["FeltBrake", "InductionMotor"],
                        build=fake_build(calls))
    assert len(calls) == 2
    assert (tmp_path / "again" / "FeltBrake.fmu").read_bytes() == \
        (out / "FeltBrake.fmu").read_bytes()


def test_the_cached_bench_loop_is_rebuilt_when_its_file_changed(tmp_path):
    """bench._compile_loop loads the cached C loop only while its digest matches the one
    recorded at its build: a replaced library is rebuilt, not loaded (each load in its own
    process, as a library once loaded stays mapped)."""
    import os
    import subprocess
    import sys
    env = dict(os.environ, XDG_CACHE_HOME=str(tmp_path))
    env.pop("CYCLOFMU_PYTHON_LOOP", None)
    code = "from cyclo_fmu import bench; assert bench._compile_loop() is not None"

    def load():
        r = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True,
                           text=True, timeout=300)
        assert r.returncode == 0, r.stderr
    load()
    (lib,) = (tmp_path / "cyclo-fmu").glob("bench_loop_*.so")
    built = lib.read_bytes()
    lib.write_bytes(b"\x7fELF not the library we built")
    load()
    assert lib.read_bytes() == built
