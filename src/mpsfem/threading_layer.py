"""Make numba's TBB threading layer usable from the pip-installed ``tbb`` wheel.

numba picks its threading layer in the order tbb, omp, workqueue. The ``tbb`` wheel puts
``libtbb.so.12`` into ``<prefix>/lib``, which the dynamic loader does not search, so numba falls
back to OpenMP. Under CPU contention (a coupled run's two processes on two cores, other jobs)
the OpenMP layer's spinning worker threads made a two-thread step 6-16 times slower than a
one-thread step in our measurements, while the TBB layer stayed at the one-thread speed
(benchmarks/results/dam_break.md). Loading the library once with RTLD_GLOBAL before numba
starts its threads lets numba's ``tbbpool`` extension resolve it.
"""

from __future__ import annotations

import ctypes
import sys
from importlib import metadata
from pathlib import Path

_LIB = "libtbb.so.12"


def _candidates() -> list[Path]:
    found = [Path(sys.prefix) / "lib" / _LIB]
    try:
        files = metadata.files("tbb") or []
    except metadata.PackageNotFoundError:
        files = []
    found += [Path(f.locate()) for f in files if f.name == _LIB]
    return found


def preload_tbb() -> str | None:
    """Load the tbb wheel's ``libtbb.so.12`` globally (Linux); returns its path, or None when
    there is none (numba then uses OpenMP or its workqueue)."""
    if not sys.platform.startswith("linux"):
        return None
    for path in _candidates():
        if path.is_file():
            try:
                ctypes.CDLL(str(path), mode=ctypes.RTLD_GLOBAL)
            except OSError:
                continue
            return str(path)
    return None
