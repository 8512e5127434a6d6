import pytest

from model_core import DriveDesign


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
