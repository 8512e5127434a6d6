"""The C allocator's settings while an FMU solves its loss map at initialization.

Solving a ``ModeMap`` creates some 70 MB of short-lived numpy temporaries of 0.1-1.4 MB each.
glibc's malloc serves a block above its mmap threshold (128 kB in a new process) with fresh
pages from the kernel and returns them when the block is freed, and it gives the top of its heap
back once more than its trim threshold is free there; every reuse then costs the page faults of
fresh memory again. In a new process, as a host has when it instantiates the FMU, that was about
17 500 minor page faults and 30 ms of a 90 ms map (measured: ``benchmarks/bench_core.py``).
glibc raises both thresholds itself once a process has freed a large mapped block (the dynamic
threshold, up to 32 MB on 64-bit systems): a process that has served large arrays before builds
the same map without those faults.

``map_solving_heap`` sets what that dynamic rule would reach, for the duration of the solve:
the mmap threshold to :data:`MMAP_THRESHOLD` (4 MiB, above the map's largest temporary) and the
trim threshold to :data:`TRIM_THRESHOLD_SOLVING` (64 MiB), so the temporaries are recycled on
the heap. Afterwards the trim threshold is set to twice the mmap threshold (glibc's own rule) and
``malloc_trim(0)`` gives the freed heap back, so the host keeps no memory it did not have.
A side effect on the host: glibc stops adapting its thresholds once they are set explicitly, so
the mmap threshold stays at 4 MiB for the rest of the process (blocks below it come from the
heap). Elsewhere than on glibc (macOS, Windows, musl) nothing is changed. The environment
variable ``CYCLO_FMU_KEEP_MALLOC`` (any non-empty value) leaves the allocator alone.
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
#: bytes of free heap top kept during the solve (the temporaries alive at once stay below it)
TRIM_THRESHOLD_SOLVING = 64 << 20
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


@contextlib.contextmanager
def map_solving_heap():
    """Context in which glibc recycles large temporaries on its heap (see the module)."""
    libc = _glibc()
    if libc is None:
        yield
        return
    libc.mallopt(_M_MMAP_THRESHOLD, MMAP_THRESHOLD)
    libc.mallopt(_M_TRIM_THRESHOLD, TRIM_THRESHOLD_SOLVING)
    try:
        yield
    finally:
        libc.mallopt(_M_TRIM_THRESHOLD, TRIM_THRESHOLD_AFTER)
        libc.malloc_trim(0)
