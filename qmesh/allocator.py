"""The command line's allocator: NumPy's freed arrays kept for reuse instead of given back.

glibc serves each allocation above its mmap threshold (128 KiB, rising to at most 32 MiB) with
fresh pages from the kernel and gives them back on free. NumPy's passes over a million
triangles allocate and free arrays of tens of MB again and again, and every fresh page is
faulted in and zeroed by the kernel: about a second of system time of the eight a
million-vertex `qmesh mesh` takes (`/usr/bin/time`). The command line owns its process, so it
keeps freed memory in the heap for the next array (the peak resident memory stays what the
largest stage needs); the library never changes its caller's allocator.
"""

from __future__ import annotations

import ctypes
import os
import platform

MMAP_THRESHOLD = 1 << 30     # arrays up to 1 GiB come from the heap
TRIM_THRESHOLD = 2**31 - 1   # free memory at the heap's top kept (C int's largest)
TOP_PAD = 1 << 28            # the heap grows by 256 MiB more than asked (untouched: not resident)
_M_TRIM_THRESHOLD, _M_TOP_PAD, _M_MMAP_THRESHOLD = -1, -2, -3   # glibc's <malloc.h>


def keep_freed_memory() -> bool:
    """Tune glibc's malloc as above; False (nothing changed) off glibc or when the user set
    glibc's malloc options in the environment (theirs are kept)."""
    if platform.libc_ver()[0] != "glibc" or any(
            k.startswith("MALLOC_") or k == "GLIBC_TUNABLES" for k in os.environ):
        return False
    try:
        mallopt = ctypes.CDLL(None).mallopt
    except (OSError, AttributeError):
        return False
    mallopt.argtypes, mallopt.restype = (ctypes.c_int, ctypes.c_int), ctypes.c_int
    return all(mallopt(option, value) == 1 for option, value in (
        (_M_MMAP_THRESHOLD, MMAP_THRESHOLD), (_M_TRIM_THRESHOLD, TRIM_THRESHOLD),
        (_M_TOP_PAD, TOP_PAD)))
