"""A cache of built FMUs, so that ``cyclo-fmu bench`` does not rebuild the same FMUs on every run.

An entry is keyed by a SHA-256 of everything the FMU is made of: the package version, the
sources it is built from (``cyclo_fmu/slaves``, ``model_core``, the C sources in
``cyclo_fmu/native`` and the build scripts), the installed pythonfmu and fmpy (their binaries
and headers go into the FMUs), the platform, and, for an FMU that carries a design
(``CycloidDriveNative``), the design. A change to any of them gives another key; nothing is
ever looked up by name alone.

Writes are atomic: an FMU is built in a private folder inside the cache and moved into place
with ``os.replace``, followed by a sidecar ``<name>.fmu.sha256`` holding the file's digest.
A reader uses an entry only when the sidecar exists and matches the file (so a half-written,
truncated or edited entry is rebuilt, never loaded). Location: ``$CYCLOFMU_CACHE`` or
``$XDG_CACHE_HOME/cyclo-fmu/fmus`` (default ``~/.cache/cyclo-fmu/fmus``); deleting the folder
is always safe.
"""
from __future__ import annotations

import hashlib
import os
import shutil
import sys
import tempfile
from pathlib import Path

from . import __version__

HERE = Path(__file__).resolve().parent
#: what the FMUs are built from (relative to the project's root), hashed into every key
SOURCE_DIRS = ("cyclo_fmu/slaves", "model_core", "cyclo_fmu/native")
SOURCE_FILES = ("cyclo_fmu/fmu_build.py", "cyclo_fmu/__init__.py")
SOURCE_SUFFIXES = (".py", ".c", ".h", ".toml", ".json", ".csv", ".txt")


def cache_root() -> Path:
    env = os.environ.get("CYCLOFMU_CACHE")
    if env:
        return Path(env)
    base = os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache"
    return Path(base) / "cyclo-fmu" / "fmus"


_SOURCE_DIGEST = {}


def source_digest() -> str:
    """SHA-256 over the version, the sources and the build tools (computed once a process)."""
    if "d" in _SOURCE_DIGEST:
        return _SOURCE_DIGEST["d"]
    root = HERE.parent
    h = hashlib.sha256()
    h.update(f"cyclo-fmu {__version__}\0{sys.platform}\0{os.uname().machine}\0".encode())
    for mod in ("pythonfmu", "fmpy"):
        try:
            from importlib.metadata import version
            h.update(f"{mod} {version(mod)}\0".encode())
        except Exception:   # noqa: BLE001 - not installed: part of the key as such
            h.update(f"{mod} -\0".encode())
    files = [root / f for f in SOURCE_FILES]
    for d in SOURCE_DIRS:
        files += [p for p in (root / d).rglob("*")
                  if p.is_file() and p.suffix in SOURCE_SUFFIXES and "__pycache__" not in p.parts]
    for p in sorted(files):
        h.update(p.relative_to(root).as_posix().encode() + b"\0")
        h.update(p.read_bytes())
        h.update(b"\0")
    _SOURCE_DIGEST["d"] = h.hexdigest()
    return _SOURCE_DIGEST["d"]


def fmu_key(name: str, design=None) -> str:
    """The cache key of FMU ``name`` (built for ``design`` when it carries one)."""
    h = hashlib.sha256(source_digest().encode())
    h.update(name.encode() + b"\0")
    if design is not None:
        from model_core.design import design_to_toml
        h.update(design_to_toml(design).encode())
    # the C compiler the shim and the native FMU are built with
    h.update((os.environ.get("CC") or "").encode())
    if os.environ.get("CYCLOFMU_NO_SHIM"):
        h.update(b"no-shim")
    from .native.cross import cache_tag      # with or without binaries/win64
    h.update(cache_tag().encode())
    return h.hexdigest()[:32]


def _file_digest(path: Path) -> str:
    h = hashlib.sha256()
    with path.open("rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def _valid(fmu: Path) -> bool:
    side = fmu.with_name(fmu.name + ".sha256")
    try:
        return side.read_text().strip() == _file_digest(fmu)
    except OSError:
        return False


def cached_fmu(name: str, design=None, build=None) -> Path:
    """The path of FMU ``name`` in the cache, built first if no valid entry exists.

    ``design``: for the reducers (``fmu_build.DESIGNED_FMUS``); the motor, brake and
    transducers do not depend on it, so theirs is None. ``build(name, dest, design) -> Path`` builds it (default
    ``fmu_build.build_any``)."""
    from .fmu_build import DESIGNED_FMUS, build_any
    if name not in DESIGNED_FMUS:
        design = None
    build = build or build_any
    entry = cache_root() / fmu_key(name, design)
    fmu = entry / f"{name}.fmu"
    if fmu.is_file() and _valid(fmu):
        return fmu
    entry.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(prefix=f".build-{name}-", dir=entry) as tmp:
        built = Path(build(name, tmp, design))
        digest = _file_digest(built)
        os.replace(built, fmu)
        side = Path(tmp) / "sha256"
        side.write_text(digest + "\n")
        os.replace(side, fmu.with_name(fmu.name + ".sha256"))
    if not _valid(fmu):    # another process replaced it in between: build once more, here
        raise RuntimeError(f"{fmu}: the cache entry changed while it was written; run again")
    return fmu


def fmus_into(dest, names, design=None, build=None) -> Path:
    """Copy the cached FMUs ``names`` into ``dest`` (built when not cached); returns ``dest``."""
    dest = Path(dest)
    dest.mkdir(parents=True, exist_ok=True)
    for name in names:
        src = cached_fmu(name, design, build)
        tmp = dest / f".{name}.fmu.partial-{os.getpid()}"
        shutil.copyfile(src, tmp)
        os.replace(tmp, dest / f"{name}.fmu")
    return dest
