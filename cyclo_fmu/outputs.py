"""Output paths checked before any work and written so that a failure leaves nothing
half-written: every command of the CLI and every writer of results (diagnosis folders, sweep
tables) goes through these. Errors are ``CycloidInputError`` naming the field and the path."""
from __future__ import annotations

import contextlib
import os
import shutil
import tempfile
from pathlib import Path

from model_core import CycloidInputError


def _nearest_existing(path: Path) -> Path:
    p = path
    while not p.exists() and p != p.parent:
        p = p.parent
    return p


def output_dir(field: str, path, create: bool = True) -> Path:
    """Check an output folder before any work: it may exist (a folder, writable) or be created
    with its missing parents; an ancestor that is a file, or an unwritable one, is an error
    naming ``field`` and the path. Returns the folder (created when ``create``)."""
    p = Path(path)
    if p.exists() and not p.is_dir():
        raise CycloidInputError(field, str(path), "is a file, not a folder")
    base = _nearest_existing(p)
    if not base.is_dir():
        raise CycloidInputError(field, str(path), f"{base} is a file, not a folder")
    if not os.access(base, os.W_OK | os.X_OK):
        raise CycloidInputError(field, str(path), f"{base} is not writable")
    missing = [q for q in [p, *p.parents] if not q.exists()]
    try:   # a real probe: permissions alone do not tell (root, read-only or virtual file systems)
        p.mkdir(parents=True, exist_ok=True)
        with tempfile.TemporaryFile(dir=p):
            pass
    except OSError as exc:
        raise CycloidInputError(field, str(path), f"cannot be written ({exc.strerror})") from None
    finally:
        if not create:
            for q in missing:
                with contextlib.suppress(OSError):
                    q.rmdir()
    return p


def output_file(field: str, path) -> Path:
    """Check an output file before any work: its folder must exist and be writable, and the
    path must not be a folder."""
    p = Path(path)
    if p.is_dir():
        raise CycloidInputError(field, str(path), "is a folder, not a file")
    if p.exists() and not p.is_file():
        # a device, FIFO or socket: the staged write would replace it with a plain file
        raise CycloidInputError(field, str(path), "is not a regular file (a device or a "
                                "pipe?); give a file name")
    parent = p.parent
    if not parent.exists():
        raise CycloidInputError(field, str(path), f"folder {parent} does not exist")
    if not parent.is_dir():
        raise CycloidInputError(field, str(path), f"{parent} is a file, not a folder")
    if not os.access(parent, os.W_OK | os.X_OK) or (p.exists() and not os.access(p, os.W_OK)):
        raise CycloidInputError(field, str(path), "is not writable")
    try:
        with tempfile.TemporaryFile(dir=parent):
            pass
    except OSError as exc:
        raise CycloidInputError(field, str(path), f"cannot be written ({exc.strerror})") from None
    return p


@contextlib.contextmanager
def staged_dir(field: str, path):
    """Yield the output folder (validated, created); if the command fails, remove what it added:
    the folder itself (and parents) when it did not exist, else the new entries."""
    p = Path(path)
    created = [] if p.exists() else [q for q in [p, *p.parents] if not q.exists()]
    before = set(p.iterdir()) if p.exists() and p.is_dir() else set()
    output_dir(field, p, create=True)
    try:
        yield p
    except BaseException:
        if created:
            shutil.rmtree(created[-1], ignore_errors=True)
        else:
            for q in set(p.iterdir()) - before:
                shutil.rmtree(q, ignore_errors=True) if q.is_dir() else q.unlink(missing_ok=True)
        raise


@contextlib.contextmanager
def staged_file(field: str, path):
    """Yield a temporary path next to the output file (validated); moved onto it on success,
    removed on failure."""
    p = output_file(field, path)
    tmp = p.with_name(f".{p.name}.partial-{os.getpid()}{p.suffix}")
    try:
        yield tmp
        if tmp.exists():
            os.replace(tmp, p)
    finally:
        if tmp.exists():
            tmp.unlink()
