"""Build the project's FMUs with pythonfmu (FMI 2.0 co-simulation, no external tool).

The slaves and the physics core are bundled under a versioned package name
(``cyclofmu_<version>_slaves`` with ``_bundled_core`` inside) and each slave script under a
versioned module name, so that neither collides with a host's imports nor with another of our
FMUs of a different version in the same process. numpy and scipy are not bundled: the FMU uses
the host interpreter's environment (see README, limits).
"""
from __future__ import annotations

import argparse
import shutil
import sys
import tempfile
from pathlib import Path

from . import __version__

HERE = Path(__file__).resolve().parent
BUNDLE = "cyclofmu_" + __version__.replace(".", "_") + "_slaves"

#: model name -> module in cyclo_fmu/slaves
SLAVES = {"CycloidDrive": "cycloid_drive", "InductionMotor": "motor", "FeltBrake": "brake",
          "Transducer": "transducer"}
#: FMUs in C (cyclo_fmu.native), built with the machine's C compiler
NATIVE = ("CycloidDriveNative",)
#: everything ``build`` writes by default
ALL_FMUS = tuple(SLAVES) + NATIVE


#: The pythonfmu entry script. pythonfmu 0.7 empties this module's namespace when a host
#: unloads the FMU library (fmpy's freeInstance), but the module stays cached in sys.modules,
#: so a second load in the same process found no class ("module has no attribute"). The
#: module's class survives that, so it fetches the slave class again on demand.
SCRIPT_TEMPLATE = '''"""pythonfmu entry point of {name} (cyclo-fmu {version})."""
import importlib
import sys
import types

from {bundle}.{module} import {name} as _Slave


class {name}(_Slave):
    pass


class _ReloadableModule(types.ModuleType):
    def __getattr__(self, attr):
        if attr == "{name}":
            return importlib.import_module("{bundle}.{module}").{name}
        raise AttributeError(attr)


sys.modules[__name__].__class__ = _ReloadableModule
'''


def build_fmu(name: str = "CycloidDrive", dest="dist") -> Path:
    """Build ``dest/<name>.fmu`` and return its path."""
    from pythonfmu.builder import FmuBuilder

    if name not in SLAVES:
        raise ValueError(f"unknown FMU {name!r}; known: {', '.join(SLAVES)}")
    dest = Path(dest)
    dest.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(prefix="cyclofmu_build_") as tmp:
        stage = Path(tmp)
        pkg = stage / BUNDLE
        ignore = shutil.ignore_patterns("__pycache__", "*.pyc")
        shutil.copytree(HERE / "slaves", pkg, ignore=ignore)
        shutil.copytree(HERE.parent / "model_core", pkg / "_bundled_core", ignore=ignore)
        script = stage / f"{BUNDLE}_{name}.py"
        script.write_text(SCRIPT_TEMPLATE.format(name=name, version=__version__, bundle=BUNDLE,
                                                 module=SLAVES[name]))
        sys.path.insert(0, str(stage))
        try:
            out = FmuBuilder.build_FMU(script, dest=dest, project_files=[pkg],
                                       needsExecutionTool="false")
        finally:
            sys.path.remove(str(stage))
            for mod in [m for m in sys.modules if m == BUNDLE or m.startswith(BUNDLE + ".")
                        or m == script.stem]:
                del sys.modules[mod]
    return Path(out)


def build_any(name: str, dest="dist", design=None) -> Path:
    """Build one FMU by name: a Python FMU (SLAVES) or the native one (for ``design``, default
    the paper's test drive; the Python FMUs take the design as parameters instead)."""
    if name in NATIVE:
        from .native import build_native_fmu
        return build_native_fmu(design, dest)
    return build_fmu(name, dest)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog="build_fmu", description="Build the cyclo-fmu FMUs.")
    p.add_argument("--dest", default="dist", help="output folder (default: dist)")
    p.add_argument("--design", help="design file (TOML) for CycloidDriveNative")
    p.add_argument("names", nargs="*", default=list(ALL_FMUS), help="FMUs to build")
    args = p.parse_args(argv)
    design = None
    if args.design:
        from model_core import design_from_toml
        design = design_from_toml(Path(args.design))
    for name in args.names:
        if name not in ALL_FMUS:
            p.error(f"unknown FMU {name!r}; known: {', '.join(ALL_FMUS)}")
        print(build_any(name, args.dest, design))
    return 0
