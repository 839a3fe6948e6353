"""Free disk space checked before the large writes of a run (snapshots, checkpoints).

HDF5 does not recover from ENOSPC: a full disk in the middle of a write printed "Can't decrement
id ref count (... No space left on device)" and the process then died of a segmentation fault,
leaving the results file's status at "running" and no checkpoint. A write that would not fit is
refused beforehand instead, as :class:`DiskFullError`, so the run stops through its ordinary
failure path (message, status, the previous checkpoint kept intact).
"""

from __future__ import annotations

import errno
import shutil
from pathlib import Path

#: kept free beyond a large write's own size (a snapshot, a checkpoint): room left for the
#: small writes that end a run (buffered samples, status, HDF5 metadata, the sidecar)
MARGIN_BYTES = 2**20
#: kept free beyond a small write (a flush of buffered samples): HDF5 metadata
SMALL_MARGIN_BYTES = 2**16


class DiskFullError(OSError):
    """Not enough free space for a write; names the write, what it needs and what is free."""

    def __init__(self, message: str) -> None:
        super().__init__(errno.ENOSPC, message)
        self.message = message

    def __str__(self) -> str:
        return self.message


def free_bytes(path: str | Path) -> int:
    """Free bytes on the file system that holds ``path`` (its folder if it does not exist)."""
    p = Path(path)
    folder = p if p.is_dir() else p.parent
    return int(shutil.disk_usage(folder).free)


def require(path: str | Path, nbytes: int, what: str, margin: int = MARGIN_BYTES) -> None:
    """Refuse (:class:`DiskFullError`) a write of about ``nbytes`` next to ``path`` that would
    leave less than ``margin`` bytes free."""
    free = free_bytes(path)
    need = int(nbytes) + margin
    if free < need:
        raise DiskFullError(
            f"no space left for {what} in {Path(path).parent}: it needs about "
            f"{need / 2**20:.2f} MiB (with a {margin / 2**20:.2f} MiB reserve), "
            f"{free / 2**20:.2f} MiB are free; free some space or write elsewhere (--out)"
        )
