import os
import tempfile

import pytest
from hypothesis import HealthCheck, settings
from hypothesis.configuration import set_hypothesis_home_dir

from model_core import DriveDesign

# Hypothesis derandomised: a CI failure replays with the same examples, and no example
# database (.hypothesis/) is written into the repository. ``HYPOTHESIS_PROFILE=dev`` explores
# random examples locally.
settings.register_profile("ci", derandomize=True, database=None, deadline=None,
                          print_blob=True, suppress_health_check=[HealthCheck.too_slow])
settings.register_profile("dev", derandomize=False, database=None, deadline=None)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "ci"))
# Hypothesis also caches the constants it collects from the code under .hypothesis/: a
# temporary folder instead, removed at the end of the session
_HYPOTHESIS_HOME = tempfile.mkdtemp(prefix="cyclo-fmu-hypothesis-")
set_hypothesis_home_dir(_HYPOTHESIS_HOME)


@pytest.fixture(scope="session", autouse=True)
def _session_temp(tmp_path_factory):
    """Temporary files of the whole session (extracted FMUs of module fixtures, dask's scratch
    space, subprocesses' temporaries) go under pytest's own temporary folder, which is removed
    after a passing run (tmp_path_retention_policy = "failed"), not into /tmp or the repo."""
    d = tmp_path_factory.mktemp("session_tmp")
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(tempfile, "tempdir", str(d))
        mp.setenv("TMPDIR", str(d))
        try:
            import dask
            cfg = dask.config.set({"temporary-directory": str(d)})
        except ImportError:
            cfg = None
        yield d
        if cfg is not None:
            cfg.__exit__(None, None, None)


@pytest.fixture(autouse=True)
def _test_temp(tmp_path_factory, monkeypatch):
    """Each test's temporaries (fmpy.extract, tempfile, subprocesses via TMPDIR) go into a
    folder of its own beside its tmp_path (so that tests comparing tmp_path's tree see only
    their outputs), removed when the test ends."""
    import shutil
    d = tmp_path_factory.mktemp("tmp")
    monkeypatch.setattr(tempfile, "tempdir", str(d))
    monkeypatch.setenv("TMPDIR", str(d))
    yield d
    shutil.rmtree(d, ignore_errors=True)


@pytest.fixture(scope="session")
def design():
    """The paper's test drive (Table 3) with the documented assumptions, computed as the paper
    did (profile "paper": its theory's numbers)."""
    return DriveDesign(profile="paper")


@pytest.fixture(scope="session")
def physical():
    """The paper's test drive in the physical profile (the default)."""
    return DriveDesign(profile="physical")


@pytest.fixture(scope="session")
def fmu_dir(tmp_path_factory):
    """All the project's FMUs, built once per test session (build_fmu)."""
    from cyclo_fmu.fmu_build import SLAVES, build_fmu
    d = tmp_path_factory.mktemp("fmus")
    for name in SLAVES:
        build_fmu(name, d)
    return d


@pytest.fixture(scope="session")
def fmu(fmu_dir):
    """The reducer FMU."""
    return str(fmu_dir / "CycloidDrive.fmu")


# pythonfmu's native library (loaded and unloaded many times by the FMU tests) has been seen,
# rarely, to abort in its static destructors at interpreter exit ("corrupted double-linked
# list") after every test had passed. End the test process with pytest's own exit status once
# the report is written, skipping those native destructors.
_EXIT = {}


def pytest_sessionfinish(session, exitstatus):
    import shutil
    shutil.rmtree(_HYPOTHESIS_HOME, ignore_errors=True)
    _EXIT["status"] = int(exitstatus)


def pytest_unconfigure(config):
    import atexit
    import os
    import sys

    if "status" in _EXIT:
        def leave():
            sys.stdout.flush()
            sys.stderr.flush()
            os._exit(_EXIT["status"])
        atexit.register(leave)
