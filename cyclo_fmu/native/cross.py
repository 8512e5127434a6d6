"""Windows x86-64 binaries of the native FMUs, cross-compiled with mingw-w64 or Zig.

Every native FMU ships its C sources, so a host on any platform can compile it; with a cross
compiler the build also puts ``binaries/win64/<model>.dll`` into the FMU. The cross compiler,
in this order:

1. Debian's mingw-w64, ``x86_64-w64-mingw32-gcc`` (``apt-get install mingw-w64``); the DLL
   needs ``KERNEL32.dll`` and ``msvcrt.dll`` (in every Windows);
2. Zig's C compiler from the PyPI wheel ``ziglang`` (a dependency of cyclo-fmu, so a plain
   ``pip install`` has it), ``python -m ziglang cc -target x86_64-windows-gnu``; the DLL
   needs ``KERNEL32.dll`` and the Universal C Runtime (``api-ms-win-crt-*.dll``: part of
   Windows 10 and later, an update on Windows 7 SP1 and 8.1, KB2999226);
3. none: the build goes on with a note on stderr (once per process) and the FMU holds
   linux64 only; a missing cross compiler is never an error.

``$CYCLOFMU_WIN64_CC`` chooses: ``auto`` (the order above, the default), ``mingw``, ``zig``
or ``none`` (no win64 binaries); a chosen compiler that is not there is an error.
``$CYCLOFMU_MINGW`` names another mingw-w64 compiler; ``CYCLOFMU_MINGW=none`` switches the
win64 build off, as before Zig was an option.
"""
from __future__ import annotations

import importlib.util
import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

MINGW = "x86_64-w64-mingw32-gcc"
#: the command of Zig's C compiler for Windows x86-64 (the GNU ABI: mingw-w64's headers and
#: import libraries, shipped in the ziglang wheel)
ZIG_CC = (sys.executable, "-m", "ziglang", "cc", "-target", "x86_64-windows-gnu")
#: as the linux64 flags (cyclo_fmu.native.build.CFLAGS): no fused multiply-add, so the DLL
#: rounds as the linux64 binary and the Python model do; stack protector and fortified string
#: functions. Both linkers mark the DLL DYNAMIC_BASE, HIGH_ENTROPY_VA and NX_COMPAT by default.
COMMON_FLAGS = ("-std=c99", "-O2", "-ffp-contract=off", "-Wall", "-Wl,--no-undefined",
                "-fstack-protector-strong", "-D_FORTIFY_SOURCE=2")
#: mingw-w64: libgcc and libssp linked in (-static), so the DLL needs only Windows' msvcrt
WIN64_FLAGS = ("-shared", "-static", *COMMON_FLAGS)
#: Zig: no -static (with -shared it makes Zig write a static library instead of a DLL; Zig
#: links its compiler runtime and stack protector in anyway); -s: no PDB file beside the DLL
ZIG_FLAGS = ("-shared", "-s", *COMMON_FLAGS)
#: ``$CYCLOFMU_WIN64_CC`` values
CHOICES = ("auto", "mingw", "zig", "none")
_NOTED = {}


def _zig_available() -> bool:
    return importlib.util.find_spec("ziglang") is not None


def _mingw() -> str | None:
    name = os.environ.get("CYCLOFMU_MINGW", MINGW)
    return None if name.lower() == "none" else shutil.which(name)


def win64_toolchain():
    """``("mingw", path)``, ``("zig", ziglang's version)`` or None: the cross compiler this
    build uses (see the module's text for the order and ``$CYCLOFMU_WIN64_CC``)."""
    from model_core.errors import CycloidInputError
    choice = os.environ.get("CYCLOFMU_WIN64_CC", "auto").strip().lower() or "auto"
    if choice not in CHOICES:
        raise CycloidInputError("CYCLOFMU_WIN64_CC", choice, f"must be one of {CHOICES}")
    if choice == "none" or os.environ.get("CYCLOFMU_MINGW", "").lower() == "none":
        return None
    if choice in ("auto", "mingw"):
        cc = _mingw()
        if cc:
            return ("mingw", cc)
        if choice == "mingw":
            raise CycloidInputError("CYCLOFMU_WIN64_CC", choice, "no mingw-w64 cross compiler "
                                    f"({os.environ.get('CYCLOFMU_MINGW', MINGW)}) on PATH")
    if _zig_available():
        from importlib.metadata import version
        return ("zig", f"ziglang {version('ziglang')}")
    if choice == "zig":
        raise CycloidInputError("CYCLOFMU_WIN64_CC", choice, "the Python package ziglang is "
                                "not installed (pip install ziglang)")
    return None


def available_toolchains() -> tuple:
    """The cross compilers on this machine that ``$CYCLOFMU_WIN64_CC`` can choose."""
    return tuple(k for k, ok in (("mingw", _mingw() is not None), ("zig", _zig_available()))
                 if ok)


def win64_compiler():
    """What cross-compiles win64 (mingw-w64's path or ``ziglang <version>``), or None."""
    tc = win64_toolchain()
    return None if tc is None else tc[1]


def _command(flags_mingw=WIN64_FLAGS, flags_zig=ZIG_FLAGS):
    tc = win64_toolchain()
    if tc is None:
        return None
    return [tc[1], *flags_mingw] if tc[0] == "mingw" else [*ZIG_CC, *flags_zig]


def _run(cmd, out: Path):
    """Run the compiler in a scratch folder (Zig's linker writes an import library into the
    working folder) and put its output at ``out``."""
    out.parent.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(prefix="cyclofmu_win64_") as tmp:
        target = Path(tmp) / out.name
        r = subprocess.run([*cmd, "-o", str(target)], capture_output=True, text=True, cwd=tmp)
        if r.returncode == 0:
            shutil.copyfile(target, out)
    return r


def compile_win64(src: Path, sources, out: Path) -> bool:
    """Compile ``sources`` (names in ``src``) into the DLL ``out``; False (with a note) when
    there is no cross compiler. A failing cross compiler raises, like the linux64 build."""
    cmd = _command()
    if cmd is None:
        if not _NOTED:
            _NOTED["done"] = True
            print(f"note: no win64 cross compiler (mingw-w64's {MINGW}, or the Python package "
                  "ziglang): the native FMUs hold binaries/linux64 and their sources, no "
                  "binaries/win64 (pip install ziglang, or apt-get install mingw-w64, to add "
                  "them)", file=sys.stderr)
        return False
    r = _run([*cmd, f"-I{src}", *[str(src / f) for f in sources]], out)
    if r.returncode != 0:
        from model_core.errors import CycloidInputError
        first = next((ln for ln in r.stderr.splitlines() if "error" in ln), r.stderr.strip())
        raise CycloidInputError("win64 cross compiler", win64_compiler(),
                                f"failed on {out.name}: {first[:300]}")
    return True


def compile_win64_front(source: Path, flags, out: Path) -> None:
    """Cross-compile the Python FMUs' C front (fmi2_status_shim.c) into the DLL ``out`` with
    the model's ``flags`` (-I, -D); the caller checked that the cross compiler is there."""
    r = _run([*_command(), *flags, str(source)], out)
    if r.returncode != 0:
        raise RuntimeError(f"cross-compiling {source.name} for win64 failed: "
                           f"{r.stderr.strip()[:300]}")


def compile_win64_exe(source: Path, flags, out: Path) -> None:
    """A Windows program (the tests' host, hostile/host_win64.c) from one C file."""
    exe_mingw = ("-std=c99", "-O2", "-Wall", "-static")
    exe_zig = ("-std=c99", "-O2", "-Wall", "-s")
    r = _run([*_command(exe_mingw, exe_zig), *flags, str(source)], out)
    if r.returncode != 0:
        raise RuntimeError(f"cross-compiling {source.name} for win64 failed: "
                           f"{r.stderr.strip()[:300]}")


def cache_tag() -> str:
    """What the cross compiler adds to an FMU cache key (with or without win64)."""
    return win64_compiler() or "no-win64"
