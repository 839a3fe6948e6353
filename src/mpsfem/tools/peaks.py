"""Peaks of probe histories for ``mpsfem sweep``: ``--peak PROBE[:COMPONENT]``.

The peak of a probe is the largest absolute value over the run, ``max_t |v(t)|``, and the time at
which it first occurs. ``v`` is the named component, or for a probe of several components given
without one, the magnitude ``sqrt(sum_c v_c^2)`` (e.g. the displacement magnitude). NaN samples
(a dry pressure gauge) are skipped; a series with no finite sample has peak NaN.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from mpsfem.tools import ToolError
from mpsfem.tools.results_series import Series, open_results, read_series

#: probe kinds each runner records (structure-only: standalone.py; fluid-only: simulation.py)
RECORDED_KINDS = {
    "structure": ("displacement", "energy"),
    "fluid": ("pressure", "wave_gauge", "front", "force", "energy"),
    "coupled": ("pressure", "wave_gauge", "front", "force", "energy", "displacement"),
}


@dataclass(frozen=True)
class PeakSpec:
    """``--peak PROBE[:COMPONENT]``."""

    probe: str
    component: str | None = None

    @property
    def label(self) -> str:
        return f"{self.probe}:{self.component}" if self.component else self.probe


def parse_peak_arg(arg: str) -> PeakSpec:
    probe, _, component = arg.partition(":")
    if not probe or (":" in arg and not component):
        raise ToolError(f"--peak {arg!r}: expected PROBE or PROBE:COMPONENT (e.g. tip:uy)")
    return PeakSpec(probe.strip(), component.strip() or None)


@dataclass(frozen=True)
class Peak:
    """``value`` = max |v| (unit of the probe), ``time`` (s) where it first occurs."""

    value: float
    time: float
    unit: str = ""


def peak_of(series: Series, component: str | None = None) -> Peak:
    """Peak of ``series`` (its component ``component``, or the magnitude over its components)."""
    if component is not None:
        v = np.abs(series.component(component))
        unit = series.units[series.components.index(component)]
    elif series.values.shape[1] == 1:
        v = np.abs(series.values[:, 0])
        unit = series.units[0]
    else:
        v = np.sqrt(np.sum(series.values**2, axis=1))  # |v|, magnitude over components
        unit = series.units[0]
    finite = np.isfinite(v)
    if not finite.any():
        return Peak(float("nan"), float("nan"), unit)
    k = int(np.argmax(np.where(finite, v, -np.inf)))
    return Peak(float(v[k]), float(series.time[k]), unit)


def read_peaks(results: str | Path, specs: list[PeakSpec]) -> dict[str, Peak]:
    """Peaks of ``specs`` (keyed by label) from the results file ``results``."""
    out = {}
    with open_results(results) as h5:
        for spec in specs:
            if "probes" not in h5 or spec.probe not in h5["probes"]:
                have = ", ".join(sorted(h5["probes"])) if "probes" in h5 else "none"
                raise ToolError(f"{results}: no probe {spec.probe!r} (probes: {have})")
            out[spec.label] = peak_of(read_series(h5, spec.probe), spec.component)
    return out


def expected_components(probe, scenario) -> tuple[str, ...]:
    """Component names the runs will record for scenario probe ``probe`` (results contract)."""
    from mpsfem.fluid_mps.probes import PROBE_UNITS  # the table the run loops use

    if scenario.fluid is not None:
        dim = scenario.fluid.dim
    else:
        dim = 3 if any(m.type == "plate" for m in scenario.structure.members) else 2
    if probe.kind == "energy" and probe.target != "fluid":
        return ("kinetic", "strain")  # member energy (standalone.py, simulation.py)
    _, comps = PROBE_UNITS[probe.kind]
    if probe.kind in ("force", "displacement"):
        comps = comps[:dim]
    return tuple(comps) or ("value",)


def check_peak_specs(specs: list[PeakSpec], scenario, runner: str) -> list[str]:
    """Problems with ``specs`` for ``scenario`` run by ``runner`` (a key of RECORDED_KINDS),
    one line each; empty when every peak will be found in the results."""
    probes = {p.name: p for p in scenario.probes}
    problems = []
    for spec in specs:
        p = probes.get(spec.probe)
        if p is None:
            have = ", ".join(probes) if probes else "none"
            problems.append(
                f"--peak {spec.label}: the scenario has no probe {spec.probe!r} ({have})"
            )
            continue
        if p.kind not in RECORDED_KINDS[runner] or (
            runner == "structure" and p.kind == "energy" and p.target == "fluid"
        ):
            problems.append(
                f"--peak {spec.label}: probe {p.name!r} of kind {p.kind!r} is not recorded by a "
                f"{runner} run (it records {', '.join(RECORDED_KINDS[runner])})"
            )
            continue
        comps = expected_components(p, scenario)
        if spec.component is not None and spec.component not in comps:
            problems.append(
                f"--peak {spec.label}: probe {p.name!r} has components {', '.join(comps)}"
            )
    return problems
