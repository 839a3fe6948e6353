"""What ``mpsfem sweep`` writes at the end: ``summary.csv`` and peak-versus-parameter PNGs.

``summary.csv``, one row per case in grid order: ``case`` (folder name), one column per grid key
(the value; strings bare, other values as TOML literals), ``status`` (``finished`` or
``failed``), ``reused`` (``yes`` when an earlier sweep ran it), ``wall_time_s`` (child process
start to exit, s), ``run_wall_time_s`` (the run's own wall time from the results file, s), then
per ``--peak`` ``peak[<probe>[:<component>]]`` (max |value|, unit of the probe) and
``t_peak[...]`` (s), and ``error`` (last line of a failed child's output). Missing numbers are
empty.

``peak-<probe>[-<component>]-vs-<key>.png`` for every peak and grid key: the peak against that
key's values, one line per combination of the other keys' values (categorical axis for
non-numeric values, logarithmic when positive values span two decades or more).
"""

from __future__ import annotations

import csv
import math
import re
from pathlib import Path

from mpsfem.tools import ToolError
from mpsfem.tools.grid import short_keys
from mpsfem.tools.peaks import read_peaks

SUMMARY_NAME = "summary.csv"
_UNSAFE = re.compile(r"[^A-Za-z0-9._-]")


def attach_peaks(plan, outcomes) -> list[str]:
    """Read the peaks of every finished case into its outcome; returns the problems found."""
    problems = []
    if not plan.peaks:
        return problems
    from mpsfem.tools.sweep import RESULTS_NAME

    for o in outcomes:
        if o.status != "finished":
            continue
        try:
            o.peaks = read_peaks(plan.case_dir(o.case) / RESULTS_NAME, plan.peaks)
        except ToolError as exc:
            problems.append(f"case {o.case.name}: {exc}")
    return problems


def _num(x: float) -> str:
    return "" if x is None or not math.isfinite(x) else repr(float(x))


def _param_text(value, literal: str) -> str:
    return value if isinstance(value, str) else literal


def write_summary(plan, outcomes) -> Path:
    """Write ``summary.csv`` (columns in the module docstring) into ``plan.out_dir``."""
    path = plan.out_dir / SUMMARY_NAME
    keys = [a.key for a in plan.axes]
    head = ["case", *keys, "status", "reused", "wall_time_s", "run_wall_time_s"]
    for spec in plan.peaks:
        head += [f"peak[{spec.label}]", f"t_peak[{spec.label}]"]
    head.append("error")
    with open(path, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(head)
        for o in outcomes:
            row = [o.case.name]
            row += [
                _param_text(v, lit)
                for (_, v), lit in zip(o.case.params, o.case.literals, strict=True)
            ]
            row += [o.status, "yes" if o.reused else "no", _num(o.wall_time), _num(o.run_wall_time)]
            for spec in plan.peaks:
                pk = o.peaks.get(spec.label)
                row += [_num(pk.value), _num(pk.time)] if pk else ["", ""]
            row.append(o.error)
            w.writerow(row)
    return path


def plot_peaks(plan, outcomes) -> list[Path]:
    """One PNG per (peak, grid key) with at least one finite peak; returns their paths."""
    if not plan.peaks:
        return []
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    short = short_keys([a.key for a in plan.axes])
    paths = []
    for spec in plan.peaks:
        found = [o.peaks[spec.label] for o in outcomes if spec.label in o.peaks]
        if not any(math.isfinite(p.value) for p in found):
            continue
        unit = found[0].unit
        for i, axis in enumerate(plan.axes):
            fig = Figure(figsize=(6.4, 4.4), layout="constrained")
            FigureCanvasAgg(fig)
            ax = fig.subplots()
            groups: dict[tuple, list] = {}
            for o in outcomes:
                rest = tuple(lit for j, lit in enumerate(o.case.literals) if j != i)
                groups.setdefault(rest, []).append(o)
            for rest, members in groups.items():
                pts = []
                for o in members:
                    j = axis.literals.index(o.case.literals[i])
                    x = axis.values[j] if axis.numeric else j
                    pk = o.peaks.get(spec.label)
                    pts.append((x, pk.value if pk else math.nan))
                pts.sort()
                if not any(math.isfinite(y) for _, y in pts):
                    continue  # every case of this line failed
                label = ", ".join(
                    f"{short[a.key]}={lit}"
                    for a, lit in zip(
                        [a for j, a in enumerate(plan.axes) if j != i], rest, strict=True
                    )
                )
                ax.plot([p[0] for p in pts], [p[1] for p in pts], "o-", label=label or None)
            if axis.numeric:
                xs = [float(v) for v in axis.values]
                if min(xs) > 0 and max(xs) / min(xs) >= 100:
                    ax.set_xscale("log")
            else:
                ax.set_xticks(range(len(axis.literals)), axis.literals)
            ax.set_xlabel(axis.key)
            ax.set_ylabel(f"peak |{spec.label}|" + (f" ({unit})" if unit else ""))
            ax.grid(True, alpha=0.3)
            if len(groups) > 1:
                ax.legend(fontsize="small")
            ax.set_title(f"{plan.scenario.name}: peak of {spec.label} against {short[axis.key]}")
            name = f"peak-{_UNSAFE.sub('_', spec.label.replace(':', '-'))}-vs-"
            path = plan.out_dir / f"{name}{_UNSAFE.sub('_', short[axis.key])}.png"
            fig.savefig(path, dpi=110)
            paths.append(path)
    return paths
