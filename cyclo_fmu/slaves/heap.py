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
(32 MiB, glibc's own ceiling of that rule: above the largest temporary of the maps and above a
sample-level array of a recording up to 4 million samples) and the trim threshold
:data:`TRIM_THRESHOLD` (64 MiB), so the temporaries are recycled on the heap.

``keep_temporaries_on_heap`` sets them for the whole process: for processes of our own (the
``cyclo-fmu`` command; the sweep's dask workers get them as environment variables,
``cyclo_fmu.sweep.cluster.worker_environ``).
An FMU never calls them: it lives in someone else's process and must not change the host's
allocator (docs/explanation/fmu-safety.md; the map of an FMU solves with glibc's defaults,
``benchmarks/bench_fmu_heap.py`` measures what that costs).

A program using ``model_core`` directly gets the same with the environment variables
``MALLOC_MMAP_THRESHOLD_=33554432 MALLOC_TRIM_THRESHOLD_=67108864`` or by calling
``keep_temporaries_on_heap()``. Elsewhere than on glibc (macOS, Windows, musl) nothing is
changed; the environment variable ``CYCLO_FMU_KEEP_MALLOC`` (any non-empty value) leaves the
allocator alone.
"""
from __future__ import annotations

import ctypes
import os

#: glibc's mallopt parameters (malloc.h)
_M_TRIM_THRESHOLD, _M_MMAP_THRESHOLD = -1, -3
#: bytes, blocks at least this large are mapped from the kernel: 32 MiB, the ceiling glibc's
#: dynamic rule raises it to itself on 64-bit systems (DEFAULT_MMAP_THRESHOLD_MAX). Above the
#: map's largest temporary (1.4 MB for the default grid) and above the diagnosis's
#: sample-level arrays (4.8 MB at 600 000 samples: with 4 MiB every one of its hundreds of
#: such temporaries was mapped and faulted in afresh, 1.0 s of system time of a 4.4 s
#: diagnosis; 0.5 s with 32 MiB, benchmarks/bench_diagnosis.py)
MMAP_THRESHOLD = 32 << 20
#: bytes of free heap top kept (the temporaries alive at once stay below it)
TRIM_THRESHOLD = 64 << 20


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


def release_free_heap() -> bool:
    """Give the heap's free pages back to the kernel (glibc's ``malloc_trim``: whole free pages
    anywhere in the heap, not only at its top), between the stages of a long computation whose
    temporaries :func:`keep_temporaries_on_heap` keeps: the next stage's peak then starts from
    what is alive, not from the last stage's. A few ms; False where nothing was done (not
    glibc, or ``CYCLO_FMU_KEEP_MALLOC``)."""
    libc = _glibc()
    if libc is None:
        return False
    libc.malloc_trim(0)
    return True

