# Copyright 2026 formation_control developers
#
# Licensed under the Apache License, Version 2.0 (the "License");
# you may not use this file except in compliance with the License.
# You may obtain a copy of the License at
#
#     http://www.apache.org/licenses/LICENSE-2.0
#
# Unless required by applicable law or agreed to in writing, software
# distributed under the License is distributed on an "AS IS" BASIS,
# WITHOUT WARRANTIES OR CONDITIONS OF ANY KIND, either express or implied.
# See the License for the specific language governing permissions and
# limitations under the License.

"""
Keep the memory of freed arrays in the process, for a large fleet's temporaries.

A control period of 1e5 vehicles makes and frees hundreds of temporaries of 0.8-5 MB. glibc's
malloc serves those past its mmap threshold with fresh pages and returns the free top of its
heap to the system past its trim threshold, so each period faults the same pages in again,
zeroed by the kernel (docs/benchmarks.md, section 10, measures what that costs).
:func:`keep_freed_memory` raises both thresholds (``mallopt``), so the freed pages are reused;
the peak resident set is what the largest moment of the run needs, as before. Elsewhere than
glibc it does nothing.
"""
from __future__ import annotations

import ctypes
import ctypes.util

M_TRIM_THRESHOLD = -1
M_MMAP_THRESHOLD = -3
MMAP_THRESHOLD = 1 << 25                         # the largest glibc takes (32 MiB, 64-bit)
TRIM_THRESHOLD = 1 << 28                         # free heap kept before returning it (bytes)
_kept = False


def keep_freed_memory() -> bool:
    """Raise malloc's mmap and trim thresholds once per process; return whether it could."""
    global _kept
    if not _kept:
        try:
            libc = ctypes.CDLL(ctypes.util.find_library('c') or 'libc.so.6')
            mallopt = libc.mallopt
        except (OSError, AttributeError):
            return False
        _kept = bool(mallopt(M_MMAP_THRESHOLD, MMAP_THRESHOLD)
                     and mallopt(M_TRIM_THRESHOLD, TRIM_THRESHOLD))
    return _kept
