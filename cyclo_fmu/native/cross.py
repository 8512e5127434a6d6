"""Windows x86-64 binaries of the native FMUs, cross-compiled with mingw-w64 when it is there.

Every native FMU ships its C sources, so a host on any platform can compile it; with the
cross compiler ``x86_64-w64-mingw32-gcc`` (Debian: ``apt-get install mingw-w64``) the build
also puts ``binaries/win64/<model>.dll`` into the FMU. Without it the build goes on with a
note on stderr (once per process) and the FMU holds linux64 only: a missing cross compiler is
never an error. ``$CYCLOFMU_MINGW`` names another cross compiler; ``CYCLOFMU_MINGW=none``
switches the win64 build off.
"""
from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

MINGW = "x86_64-w64-mingw32-gcc"
#: as the linux64 flags (cyclo_fmu.native.build.CFLAGS): no fused multiply-add, so the DLL
#: rounds as the linux64 binary and the Python model do; libgcc and libssp linked in (-static), so the DLL needs
#: only the Windows C runtime; stack protector and fortified string functions
WIN64_FLAGS = ("-std=c99", "-O2", "-shared", "-ffp-contract=off", "-static", "-Wall",
               "-Wl,--no-undefined", "-fstack-protector-strong", "-D_FORTIFY_SOURCE=2")
_NOTED = {}


def win64_compiler():
    """The cross compiler's path, or None."""
    name = os.environ.get("CYCLOFMU_MINGW", MINGW)
    if name.lower() == "none":
        return None
    return shutil.which(name)


def compile_win64(src: Path, sources, out: Path) -> bool:
    """Compile ``sources`` (names in ``src``) into the DLL ``out``; False (with a note) when
    there is no cross compiler. A failing cross compiler raises, like the linux64 build."""
    cc = win64_compiler()
    if cc is None:
        if not _NOTED:
            _NOTED["done"] = True
            print(f"note: no mingw-w64 cross compiler ({MINGW}): the native FMUs hold "
                  "binaries/linux64 and their sources, no binaries/win64 (apt-get install "
                  "mingw-w64 to add them)", file=sys.stderr)
        return False
    out.parent.mkdir(parents=True, exist_ok=True)
    cmd = [cc, *WIN64_FLAGS, f"-I{src}", "-o", str(out), *[str(src / f) for f in sources]]
    r = subprocess.run(cmd, capture_output=True, text=True)
    if r.returncode != 0:
        from model_core.errors import CycloidInputError
        first = next((ln for ln in r.stderr.splitlines() if "error" in ln), r.stderr.strip())
        raise CycloidInputError("win64 cross compiler", cc, f"failed on {out.name}: "
                                f"{first[:300]}")
    return True


def compile_win64_front(source: Path, flags, out: Path) -> None:
    """Cross-compile the Python FMUs' C front (fmi2_status_shim.c) into the DLL ``out`` with
    the model's ``flags`` (-I, -D); the caller checked that the cross compiler is there."""
    cc = win64_compiler()
    r = subprocess.run([cc, *WIN64_FLAGS, *flags, "-o", str(out), str(source)],
                       capture_output=True, text=True)
    if r.returncode != 0:
        raise RuntimeError(f"cross-compiling {source.name} for win64 failed: "
                           f"{r.stderr.strip()[:300]}")


def cache_tag() -> str:
    """What the cross compiler adds to an FMU cache key (with or without win64)."""
    return win64_compiler() or "no-win64"
