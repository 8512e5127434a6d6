"""Build the project's FMUs with pythonfmu (FMI 2.0 co-simulation, no external tool).

The slaves and the physics core are bundled under a versioned package name
(``cyclofmu_<version>_slaves`` with ``_bundled_core`` inside) and each slave script under a
versioned module name, so that neither collides with a host's imports nor with another of our
FMUs of a different version in the same process. numpy and scipy are not bundled: the FMU uses
the host interpreter's environment (see README, limits).
"""
from __future__ import annotations

import argparse
import os
import shutil
import sys
import tempfile
from pathlib import Path

from . import __version__

HERE = Path(__file__).resolve().parent
BUNDLE = "cyclofmu_" + __version__.replace(".", "_") + "_slaves"

#: model name -> module in cyclo_fmu/slaves
SLAVES = {"CycloidDrive": "cycloid_drive", "InductionMotor": "motor", "FeltBrake": "brake",
          "Transducer": "transducer", "TorqueTransducer": "transducer",
          "SpeedTransducer": "transducer"}
#: FMUs in C (cyclo_fmu.native), built with the machine's C compiler: the reducer (its design
#: compiled in) and the bench components (cyclo_fmu.native.rig_build: the twins of the slaves)
DESIGN_FMUS = ("CycloidDriveNative", "CycloidDriveNative3")    # FMI 2.0, FMI 3.0
RIG_NATIVE = ("InductionMotorNative", "FeltBrakeNative", "TransducerNative",
              "TorqueTransducerNative", "SpeedTransducerNative")
#: the bench components as FMI 3.0 co-simulation FMUs (the same C code behind an FMI 3 adapter)
RIG_NATIVE3 = ("InductionMotorNative3", "FeltBrakeNative3", "TorqueTransducerNative3",
               "SpeedTransducerNative3")
NATIVE = DESIGN_FMUS + RIG_NATIVE + RIG_NATIVE3
#: the FMUs built for a reducer design: the native reducers and the Python reducer (which
#: ships the design as its start values and the fields without a parameter)
DESIGNED_FMUS = DESIGN_FMUS + ("CycloidDrive",)
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

# The slave class itself, imported: pythonfmu runs this script again at every
# fmi2Instantiate and keeps a reference to each class it finds there (its findClass never
# releases the list of the class's bases), so a class defined here would leak one class object
# (about 8 kB) per instance; an imported one is the same object every time.
from {bundle}.{module} import {name}


class _ReloadableModule(types.ModuleType):
    def __getattr__(self, attr):
        if attr == "{name}":
            return importlib.import_module("{bundle}.{module}").{name}
        raise AttributeError(attr)


sys.modules[__name__].__class__ = _ReloadableModule
'''


def build_fmu(name: str = "CycloidDrive", dest="dist", design=None) -> Path:
    """Build ``dest/<name>.fmu`` and return its path. ``design`` (CycloidDrive only; default
    the paper's test drive): the design built in, shipped as ``design.toml`` in the FMU's
    resources (its values are the design parameters' start values, and it supplies the
    fields the FMU has no parameter for) with its loss maps solved here."""
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
        if name == "CycloidDrive":   # the design's maps, solved once here
            from .slaves.cycloid_drive import DESIGN_FILE, write_shipped_maps
            if design is not None:
                from model_core.design import design_to_toml
                (pkg / DESIGN_FILE).write_text(design_to_toml(design), encoding="utf-8")
            write_shipped_maps(pkg / "_maps", design=design)
        front = front_platforms()
        if front:   # the slaves report failures to the C front (slaves.base.STATUS_FRONT)
            (pkg / "_status_front").write_text("".join(
                f"{plat}\n" for plat in front))
        script = stage / f"{BUNDLE}_{name}.py"
        script.write_text(SCRIPT_TEMPLATE.format(name=name, version=__version__, bundle=BUNDLE,
                                                 module=SLAVES[name]))
        sys.path.insert(0, str(stage))
        try:
            # the slaves save and restore their whole state (UnitSlave._get_fmu_state)
            out = FmuBuilder.build_FMU(script, dest=dest, project_files=[pkg],
                                       needsExecutionTool="false", canGetAndSetFMUstate="true",
                                       canSerializeFMUstate="true")
        finally:
            sys.path.remove(str(stage))
            for mod in [m for m in sys.modules if m == BUNDLE or m.startswith(BUNDLE + ".")
                        or m == script.stem]:
                del sys.modules[mod]
    out = Path(out)
    if front:
        _install_status_shim(out, name, front)
    return out


def front_platforms() -> tuple:
    """The platforms whose binary in a Python FMU will be our C front (fmi2_status_shim.c):
    linux64 with a C compiler, win64 too with a cross compiler (mingw-w64 or Zig)
    (cyclo_fmu.native.cross); none with ``$CYCLOFMU_NO_SHIM``. Written into the FMU's
    ``_status_front``, one a line, which the slaves read (slaves.base.STATUS_FRONT)."""
    if os.environ.get("CYCLOFMU_NO_SHIM") or not _have_compiler():
        return ()
    from .native.cross import win64_compiler
    return ("linux64", "win64") if win64_compiler() else ("linux64",)


def _have_compiler() -> bool:
    from .native.build import find_compiler
    try:
        find_compiler()
        return True
    except Exception:   # noqa: BLE001
        print("note: no C compiler: the Python FMUs keep pythonfmu's binary, which answers "
              "errors with fmi2Fatal", file=sys.stderr)
        return False


#: the front library in C that turns pythonfmu's fmi2Fatal into fmi2Error (see its header)
SHIM_SOURCE = HERE / "native" / "fmi2_status_shim.c"


def shim_cflags():
    """The front's compiler flags: C99, optimised, hardened like every native binary."""
    from .native.build import HARDEN
    return ("-std=c99", "-O2", "-shared", "-Wall", *HARDEN)


def shim_header(model_description: str) -> str:
    """The C header the front is compiled with: the FMU's GUID and its parameters per type
    (value references and names), so that the front refuses another GUID and a parameter set
    after initialization (fmi2_status_shim.c)."""
    from xml.etree import ElementTree as ET

    from .native.build import _c_string
    root = ET.fromstring(model_description)
    lines = ["/* generated by cyclo_fmu/fmu_build.py: this FMU's GUID and parameters */",
             f"static const char SHIM_GUID[] = {_c_string(root.get('guid'))};"]
    for kind in ("Real", "Integer", "Boolean", "String"):
        params = [(int(sv.get("valueReference")), sv.get("name"))
                  for sv in root.iter("ScalarVariable")
                  if sv.get("causality") == "parameter" and sv.find(kind) is not None]
        vrs = ", ".join(f"{vr}u" for vr, _ in params) or "0u"
        names = ", ".join(_c_string(n) for _, n in params) or "0"
        lines += [f"#define SHIM_N_PARAM_{kind} {len(params)}",
                  f"static const fmi2ValueReference SHIM_PARAM_{kind}[] = {{{vrs}}};",
                  f"static const char *const SHIM_PARAM_{kind}_NAME[] = {{{names}}};"]
    return "\n".join(lines) + "\n"


def _install_status_shim(fmu: Path, name: str, platforms=("linux64",)) -> None:
    """Put the status front (compiled here) in place of pythonfmu's binary of each platform
    in ``platforms``, which goes next to it as ``<name>.pythonfmu.so`` (linux64) or
    ``<name>.pythonfmu.dll`` (win64, cross-compiled with mingw-w64 or Zig: cyclo_fmu.native.cross).
    Without a C compiler the FMU keeps pythonfmu's binary (and its fmi2Fatal), with a note on
    stderr; without the cross compiler its win64 binary stays pythonfmu's."""
    import re
    import subprocess
    import zipfile

    from .native.build import find_compiler, fmi_header_dir

    with zipfile.ZipFile(fmu) as z:
        md = z.read("modelDescription.xml").decode()
    vr = re.search(r'name="_failed" valueReference="(\d+)"', md)
    if vr is None:
        raise RuntimeError(f"{fmu.name}: no variable _failed for the status front")
    with tempfile.TemporaryDirectory(prefix="cyclofmu_shim_") as tmp:
        header = Path(tmp) / "shim_vars.h"
        header.write_text(shim_header(md))
        common = [f"-I{fmi_header_dir()}", f"-DFAILED_VR={vr.group(1)}",
                  f'-DSHIM_VARS="{header}"']
        swap = {}     # path in the FMU -> (new path of pythonfmu's binary, the front)
        if "linux64" in platforms:
            lib = Path(tmp) / "shim.so"
            r = subprocess.run([find_compiler(), *shim_cflags(), *common, "-o", str(lib),
                                str(SHIM_SOURCE), "-ldl", "-lpthread"],
                               capture_output=True, text=True)
            if r.returncode != 0:
                raise RuntimeError(f"compiling {SHIM_SOURCE.name} failed: "
                                   f"{r.stderr.strip()[:300]}")
            swap[f"binaries/linux64/{name}.so"] = (f"binaries/linux64/{name}.pythonfmu.so", lib)
        if "win64" in platforms:
            from .native.cross import compile_win64_front
            dll = Path(tmp) / "shim.dll"
            compile_win64_front(SHIM_SOURCE, common, dll)
            swap[f"binaries/win64/{name}.dll"] = (f"binaries/win64/{name}.pythonfmu.dll", dll)
        tmp_fmu = Path(tmp) / fmu.name
        with zipfile.ZipFile(fmu) as zin, zipfile.ZipFile(tmp_fmu, "w",
                                                         zipfile.ZIP_DEFLATED) as zout:
            for item in zin.infolist():
                data = zin.read(item.filename)
                if item.filename in swap:
                    inner, front = swap[item.filename]
                    zout.writestr(inner, data)
                    zout.write(front, item.filename)
                else:
                    zout.writestr(item, data)
        shutil.move(str(tmp_fmu), fmu)


def build_any(name: str, dest="dist", design=None) -> Path:
    """Build one FMU by name: a Python FMU (SLAVES) or the native one (for ``design``, default
    the paper's test drive); the Python reducer takes the design too (its start values and
    the fields without a parameter). The motor, brake and transducer FMUs do not depend on it."""
    if name == "CycloidDriveNative3":
        from .native.fmi3_build import build_fmi3_reducer
        return build_fmi3_reducer(design, dest)
    if name in DESIGN_FMUS:
        from .native import build_native_fmu
        return build_native_fmu(design, dest)
    if name in RIG_NATIVE:
        from .native.rig_build import build_rig_fmu
        return build_rig_fmu(name, dest)
    if name in RIG_NATIVE3:
        from .native.fmi3_build import build_fmi3_component
        return build_fmi3_component(name, dest)
    return build_fmu(name, dest, design if name == "CycloidDrive" else None)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog="build_fmu", description="Build the cyclo-fmu FMUs.")
    p.add_argument("--dest", default="dist", help="output folder (default: dist)")
    p.add_argument("--design", help="design file (TOML) or preset name for the reducer FMUs "
                   "(CycloidDrive, CycloidDriveNative, CycloidDriveNative3)")
    p.add_argument("names", nargs="*", default=list(ALL_FMUS), help="FMUs to build")
    args = p.parse_args(argv)
    design = None
    if args.design:
        from model_core.presets import load_design
        design = load_design(args.design)
    for name in args.names:
        if name not in ALL_FMUS:
            p.error(f"unknown FMU {name!r}; known: {', '.join(ALL_FMUS)}")
        print(build_any(name, args.dest, design))
    return 0
