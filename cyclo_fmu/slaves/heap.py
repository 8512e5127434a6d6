"""The C allocator's settings for the loss model's large temporary arrays.

Solving a map creates tens of MB of short-lived numpy temporaries of 0.1-1.4 MB each.
glibc's malloc serves a block above its mmap threshold (128 kB in a new process) with fresh
pages from the kernel and returns them when the block is freed, and it gives the top of its heap
back once more than its trim threshold is free there; every reuse then costs the page faults of
fresh memory again. glibc raises both thresholds itself once a process has freed a large mapped
block (the dynamic threshold, up to 32 MB on 64-bit systems), so the cost depends on what the
process did before: measured (``benchmarks/bench_core.py``) a 50 x 50 efficiency map of the
paper profile took 80 ms early in a process and 40 ms with the settings below; the FMU's map
in a new process had 17 500 minor page faults and 30 ms of 90.

The settings are what that dynamic rule would reach: the mmap threshold :data:`MMAP_THRESHOLD`
(4 MiB, above the largest temporary of the maps) and the trim threshold :data:`TRIM_THRESHOLD`
(64 MiB), so the temporaries are recycled on the heap.

- ``keep_temporaries_on_heap`` sets them for the whole process: for processes of our own (the
  ``cyclo-fmu`` command; the sweep's dask workers get them as environment variables,
  ``cyclo_fmu.sweep.cluster.worker_environ``).
- ``map_solving_heap`` sets them while an FMU solves its map inside a host's process;
  afterwards the trim threshold is twice the mmap threshold (glibc's own rule) and
  ``malloc_trim(0)`` gives the freed heap back, so the host keeps no memory it did not have.
  A host that chose its own thresholds (``MALLOC_MMAP_THRESHOLD_``, ``MALLOC_TRIM_THRESHOLD_``
  or ``GLIBC_TUNABLES=glibc.malloc.mmap_threshold=...:glibc.malloc.trim_threshold=...`` in its
  environment, which is where glibc reads them) gets its own values back instead
  (:func:`host_thresholds`). A side effect on a host that chose none: glibc stops adapting its
  thresholds once they are set explicitly, so the mmap threshold stays at 4 MiB for the rest
  of the process.

A program using ``model_core`` directly gets the same with the environment variables
``MALLOC_MMAP_THRESHOLD_=4194304 MALLOC_TRIM_THRESHOLD_=67108864`` or by calling
``keep_temporaries_on_heap()``. Elsewhere than on glibc (macOS, Windows, musl) nothing is
changed; the environment variable ``CYCLO_FMU_KEEP_MALLOC`` (any non-empty value) leaves the
allocator alone.
"""
from __future__ import annotations

import contextlib
import ctypes
import os

#: glibc's mallopt parameters (malloc.h)
_M_TRIM_THRESHOLD, _M_MMAP_THRESHOLD = -1, -3
#: bytes, blocks at least this large are mapped from the kernel (above the map's largest
#: temporary, 1.4 MB for the default grid; glibc's dynamic rule would raise it that far itself)
MMAP_THRESHOLD = 4 << 20
#: bytes of free heap top kept (the temporaries alive at once stay below it)
TRIM_THRESHOLD = 64 << 20
#: bytes, afterwards: twice the mmap threshold, glibc's dynamic rule
TRIM_THRESHOLD_AFTER = 2 * MMAP_THRESHOLD


def _glibc():
    """glibc's handle, or None (another C library, or the settings switched off)."""
    if os.environ.get("CYCLO_FMU_KEEP_MALLOC"):
        return None
    try:
        version = os.confstr("CS_GNU_LIBC_VERSION")   # "glibc 2.36"; not on musl, macOS
    except (AttributeError, ValueError, OSError):
        return None
    if not version or not version.startswith("glibc"):
        return None
    try:
        # (by its soname: ctypes.util.find_library runs ldconfig, 6 ms)
        libc = ctypes.CDLL("libc.so.6")
    except OSError:
        return None
    if not (hasattr(libc, "mallopt") and hasattr(libc, "malloc_trim")):
        return None
    return libc


def host_thresholds(environ=None):
    """The mmap and trim thresholds (bytes) the process's environment gave glibc at start-up,
    each None where it gave none: ``MALLOC_MMAP_THRESHOLD_`` / ``MALLOC_TRIM_THRESHOLD_``, or
    the tunables ``glibc.malloc.mmap_threshold`` / ``glibc.malloc.trim_threshold`` in
    ``GLIBC_TUNABLES`` (which take precedence, as in glibc). A value glibc would not parse as a
    whole decimal or 0x hexadecimal number counts as not given (glibc ignores it too)."""
    env = os.environ if environ is None else environ

    def number(text):
        text = (text or "").strip()
        try:
            return int(text, 16) if text.lower().startswith("0x") else int(text, 10)
        except ValueError:
            return None
    mmap = number(env.get("MALLOC_MMAP_THRESHOLD_"))
    trim = number(env.get("MALLOC_TRIM_THRESHOLD_"))
    for item in env.get("GLIBC_TUNABLES", "").split(":"):
        name, _, value = item.partition("=")
        v = number(value)
        if v is None:
            continue
        if name == "glibc.malloc.mmap_threshold":
            mmap = v
        elif name == "glibc.malloc.trim_threshold":
            trim = v
    return mmap, trim


def keep_temporaries_on_heap() -> bool:
    """Set :data:`MMAP_THRESHOLD` and :data:`TRIM_THRESHOLD` for the whole process (see the
    module); False where nothing was changed (not glibc, or ``CYCLO_FMU_KEEP_MALLOC``)."""
    libc = _glibc()
    if libc is None:
        return False
    _keep(libc)
    return True


def _keep(libc):
    libc.mallopt(_M_MMAP_THRESHOLD, MMAP_THRESHOLD)
    libc.mallopt(_M_TRIM_THRESHOLD, TRIM_THRESHOLD)


@contextlib.contextmanager
def map_solving_heap():
    """Context in which glibc recycles large temporaries on its heap (see the module)."""
    libc = _glibc()
    if libc is None:
        yield
        return
    host_mmap, host_trim = host_thresholds()
    _keep(libc)
    try:
        yield
    finally:
        if host_mmap is not None:
            libc.mallopt(_M_MMAP_THRESHOLD, host_mmap)
        libc.mallopt(_M_TRIM_THRESHOLD, TRIM_THRESHOLD_AFTER if host_trim is None else host_trim)
        libc.malloc_trim(0)
