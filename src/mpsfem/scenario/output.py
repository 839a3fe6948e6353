"""Schema of ``[output]`` and ``[run]``: what is written when, and how long a run lasts."""

from __future__ import annotations

from pydantic import Field

from mpsfem.scenario.base import Section


class OutputSection(Section):
    """Results file content and checkpoint cadence."""

    probe_interval: float = Field(
        1e-3, ge=0.0, description="default probe sampling interval, s (0 = every step)"
    )
    snapshot_interval: float = Field(
        0.05, ge=0.0, description="particle snapshot interval, s (0 = no snapshots)"
    )
    checkpoint_interval: float = Field(
        0.5, ge=0.0, description="checkpoint interval, s of simulated time (0 = only at the end)"
    )
    flush_interval: float = Field(
        5.0, gt=0.0, description="wall-clock seconds between flushes of the results file"
    )
    xdmf: bool = Field(True, description="write an XDMF sidecar so ParaView opens the snapshots")


class RunSection(Section):
    """Run control."""

    end_time: float = Field(gt=0.0, description="simulated end time, s")
    threads: int | None = Field(
        None,
        ge=1,
        description="numba threads (default: all cores); results are bit-identical "
        "for the same thread count",
    )
    progress: bool = Field(True, description="progress bar when the output is a terminal")
    memory_limit_gib: float | None = Field(
        None,
        gt=0.0,
        description="largest estimated memory of the scene, GiB; a larger scene is refused "
        "before any compute, naming the keys that set its size (default: the environment "
        "variable MPSFEM_MEMORY_LIMIT_GIB, else half of the machine's physical memory)",
    )
