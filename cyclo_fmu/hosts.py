"""Running the project's FMUs in hosts that are not Python (OMSimulator, fmusim, fmuCheck).

A pythonfmu FMU's linux64 binary does not link libpython: in a C or C++ host the dynamic
loader refuses it (``undefined symbol: _Py_NoneStruct``) unless the host process has a
shared libpython loaded, and the embedded interpreter then needs the interpreter's home (its
standard library) and the environment's site-packages (numpy, scipy). ``python_fmu_environment``
gives exactly these three variables for the Python running this code:

    LD_PRELOAD=<LIBDIR>/<INSTSONAME>   PYTHONHOME=<sys.base_prefix>   PYTHONPATH=<site-packages>

The native FMUs (``CycloidDriveNative`` and the native bench set) need none of it.
"""
from __future__ import annotations

import os
import site
import sys
import sysconfig
from pathlib import Path

#: environment variable naming the folder of the host tools (see tests/test_hosts.py)
HOSTS_ENV = "CYCLOFMU_FMI_HOSTS"


def libpython() -> Path:
    """The shared libpython of this interpreter; FileNotFoundError for a static build."""
    libdir, soname = sysconfig.get_config_var("LIBDIR"), sysconfig.get_config_var("INSTSONAME")
    path = Path(libdir or "") / (soname or "")
    if not soname or not path.is_file() or ".so" not in path.name:
        raise FileNotFoundError(
            f"this Python ({sys.executable}) has no shared libpython ({path}): a pythonfmu FMU "
            "cannot run in a non-Python host with it; use the native FMUs or a Python built "
            "with --enable-shared")
    return path


def python_fmu_environment(base=None) -> dict:
    """``base`` (default ``os.environ``) plus LD_PRELOAD, PYTHONHOME and PYTHONPATH for running
    a pythonfmu FMU in a non-Python host with this interpreter and its environment."""
    env = dict(os.environ if base is None else base)
    pre = str(libpython())
    env["LD_PRELOAD"] = pre if not env.get("LD_PRELOAD") else pre + ":" + env["LD_PRELOAD"]
    env["PYTHONHOME"] = sys.base_prefix
    paths = [p for p in site.getsitepackages() if Path(p).is_dir()]
    env["PYTHONPATH"] = os.pathsep.join(paths + ([env["PYTHONPATH"]] if env.get("PYTHONPATH")
                                                 else []))
    return env


def hosts_dir(project_root=None) -> Path:
    """Where the host tools are: ``$CYCLOFMU_FMI_HOSTS``, else ``../shared/tools/fmi-hosts``
    beside the project's root (as on the CI machine)."""
    env = os.environ.get(HOSTS_ENV)
    if env:
        return Path(env)
    root = Path(project_root) if project_root else Path(__file__).resolve().parents[1]
    return root.parent / "shared" / "tools" / "fmi-hosts"
