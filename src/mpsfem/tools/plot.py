"""``mpsfem plot``: PNG plots of the time series of a results file, references overlaid.

One PNG per series (names in :mod:`mpsfem.tools.results_series`): ``probe-<name>.png``,
``structure-<member>.png``, ``coupling.png`` (``coupling-<series>.png`` for one coupling series);
one axis per component, time (s) on the horizontal axis. A reference CSV
(:mod:`mpsfem.tools.reference_csv`) is drawn over the components it matches. Rendering uses
matplotlib's Agg canvas directly (no pyplot state, no display needed).
"""

from __future__ import annotations

import math
import sys
from dataclasses import dataclass
from pathlib import Path

from mpsfem.tools import ToolError
from mpsfem.tools.reference_csv import FORMAT_HELP, ReferenceCurve, read_reference_csv
from mpsfem.tools.results_series import (
    COUPLING,
    STRUCTURE_PREFIX,
    Series,
    list_targets,
    open_results,
    read_series,
)

#: reference curves with at most this many points are drawn as markers, longer ones as lines
MARKER_POINTS = 60


@dataclass
class ReferenceSpec:
    """``--reference [NAME[:COMPONENT]=]FILE``: a curve and the series (component) it belongs to."""

    path: Path
    target: str | None = None
    component: str | None = None


def parse_reference_arg(arg: str) -> ReferenceSpec:
    """``FILE`` or ``NAME=FILE`` or ``NAME:COMPONENT=FILE`` (an existing FILE is taken whole)."""
    if Path(arg).is_file() or "=" not in arg:
        return ReferenceSpec(Path(arg))
    lhs, _, rhs = arg.partition("=")
    target, _, component = lhs.partition(":")
    if not target or not rhs:
        raise ToolError(f"--reference {arg!r}: expected FILE, NAME=FILE or NAME:COMPONENT=FILE")
    return ReferenceSpec(Path(rhs), target, component or None)


def file_name(series_name: str) -> str:
    """PNG file name of a series: ``probe-<name>``, ``structure-<member>``, ``coupling[-<s>]``."""
    if series_name.startswith(STRUCTURE_PREFIX):
        return f"structure-{series_name[len(STRUCTURE_PREFIX) :]}.png"
    if series_name == COUPLING or series_name.startswith(COUPLING + "/"):
        return series_name.replace("/", "-") + ".png"
    return f"probe-{series_name}.png"


def match_reference(series: Series, curve: ReferenceCurve, component: str | None) -> list[tuple]:
    """Pairs (component index of ``series``, value column of ``curve``) to overlay.

    With ``component``: that component, against the column of that name or the only column.
    Without: header names that are component names are matched by name (all must match);
    otherwise columns are matched to components in order.
    """
    k = curve.values.shape[1]
    names = curve.names or []
    where = f"reference {curve.path}"
    if component is not None:
        if component not in series.components:
            raise ToolError(
                f"{where}: {series.name} has no component {component!r}; its components are "
                f"{', '.join(series.components)}"
            )
        ci = series.components.index(component)
        if component in names:
            return [(ci, names.index(component))]
        if k == 1:
            return [(ci, 0)]
        raise ToolError(
            f"{where}: {k} value columns for the one component {series.name}:{component}; give "
            f"one value column or name it {component!r} in the header"
        )
    matched = [n for n in names if n in series.components]
    if matched:
        unmatched = [n for n in names if n not in series.components]
        if unmatched:
            raise ToolError(
                f"{where}: header columns {unmatched} are not components of {series.name} "
                f"({', '.join(series.components)}); name every value column after a component "
                "or none"
            )
        return [(series.components.index(n), j) for j, n in enumerate(names)]
    if k > len(series.components):
        raise ToolError(
            f"{where}: {k} value columns but {series.name} has {len(series.components)} "
            f"component(s) ({', '.join(series.components)}); expected {FORMAT_HELP}"
        )
    return [(j, j) for j in range(k)]


def render_series(
    series: Series,
    path: Path,
    overlays: list[tuple[ReferenceCurve, list[tuple]]] = (),
    source: str = "",
) -> Path:
    """Write the PNG of ``series`` (one axis per component) with reference ``overlays``."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    n = len(series.components)
    ncols = 1 if n <= 4 else 2
    nrows = math.ceil(n / ncols)
    fig = Figure(figsize=(7.0 * ncols, 0.9 + 2.2 * nrows), layout="constrained")
    FigureCanvasAgg(fig)
    axes = fig.subplots(nrows, ncols, sharex=True, squeeze=False).ravel()
    for c, (name, unit) in enumerate(zip(series.components, series.units, strict=True)):
        ax = axes[c]
        ax.plot(series.time, series.values[:, c], lw=1.2, label="simulation")
        for curve, pairs in overlays:
            for ci, col in pairs:
                if ci != c:
                    continue
                style = "o" if len(curve.time) <= MARKER_POINTS else "--"
                ax.plot(curve.time, curve.values[:, col], style, ms=3.5, lw=1.0, label=curve.label)
        ax.set_ylabel(f"{name} ({unit})" if unit else name)
        ax.grid(True, alpha=0.3)
        if any(ci == c for _, pairs in overlays for ci, _ in pairs):
            ax.legend(fontsize="small")
    for ax in axes[n:]:
        ax.set_visible(False)
    for ax in axes[max(0, n - ncols) : n]:
        ax.set_xlabel("time (s)")
    fig.suptitle(f"{series.title}\n{source}" if source else series.title, fontsize="medium")
    fig.savefig(path, dpi=110)
    return path


def plot_results(
    results: str | Path,
    names: list[str] | None = None,
    references: list[ReferenceSpec] = (),
    out_dir: str | Path | None = None,
) -> list[Path]:
    """Write one PNG per series of ``results`` (all of them unless ``names``) into ``out_dir``
    (default ``<results stem>_plots`` beside the file); returns the PNG paths.

    Every name, reference file and reference-to-series match is checked before any PNG is
    written."""
    results = Path(results)
    with open_results(results) as h5:
        wanted = list(dict.fromkeys(names)) if names else list_targets(h5)
        for spec in references:
            if spec.target is not None and spec.target not in wanted:
                wanted.append(spec.target)
        series = {n: read_series(h5, n) for n in wanted}
    if not series:
        raise ToolError(f"{results}: the file holds no probe, structure or coupling series")
    overlays: dict[str, list] = {n: [] for n in series}
    for spec in references:
        target = spec.target
        if target is None:
            if len(series) != 1:
                raise ToolError(
                    f"--reference {spec.path}: {len(series)} series are plotted; say which one "
                    f"it belongs to with --reference NAME[:COMPONENT]={spec.path} (names: "
                    f"{', '.join(series)})"
                )
            target = next(iter(series))
        curve = read_reference_csv(spec.path)
        overlays[target].append((curve, match_reference(series[target], curve, spec.component)))
    out = Path(out_dir) if out_dir is not None else results.with_name(f"{results.stem}_plots")
    out.mkdir(parents=True, exist_ok=True)
    return [
        render_series(s, out / file_name(n), overlays[n], str(results)) for n, s in series.items()
    ]


def cli_main(args) -> int:
    """Entry for ``mpsfem plot`` (argparse namespace of :mod:`mpsfem.tools.commands`)."""
    try:
        specs = [parse_reference_arg(a) for a in args.reference]
        paths = plot_results(args.results, args.names, specs, args.out)
    except ToolError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    for path in paths:
        print(f"wrote {path}")
    return 0
