"""Argument parsers of ``mpsfem plot`` and ``mpsfem sweep`` and their dispatch.

Kept free of heavy imports (numpy, h5py, matplotlib load only when a tool runs), because
:mod:`mpsfem.cli` builds these parsers for every command.
"""

from __future__ import annotations

import argparse
import textwrap
from pathlib import Path

from mpsfem.tools import REFERENCE_FORMAT

PLOT_DESCRIPTION = textwrap.fill(
    "One PNG per series: probes (probe-<name>.png, one axis per component), structure members "
    "(structure-<member>.png: the node with the largest displacement, and the largest |u| over "
    "the nodes) and coupling windows (coupling.png).",
    78,
)
PLOT_EPILOG = (
    textwrap.fill(f"Reference CSV: {REFERENCE_FORMAT}. Example:", 78)
    + "\n  # tip deflection, measured\n  time,uy\n  0.00,0.0\n  0.05,-1.8e-3\n"
    + textwrap.fill(
        "Header names that are component names (ux, uy, fx, ...) select those components; "
        "otherwise the value columns go to the components in order. See docs/tools.md.",
        78,
    )
)


def add_plot_parser(sub) -> argparse.ArgumentParser:
    p = sub.add_parser(
        "plot",
        help="PNG plots of the probe, structure and coupling histories of a results file",
        description=PLOT_DESCRIPTION,
        formatter_class=argparse.RawDescriptionHelpFormatter,
        epilog=PLOT_EPILOG,
    )
    p.add_argument("results", type=Path, help="results file (.h5)")
    p.add_argument(
        "--probe",
        dest="names",
        action="extend",
        nargs="+",
        metavar="NAME",
        help="series to plot (default: all): a probe name, structure/<member>, coupling or "
        "coupling/<series>",
    )
    p.add_argument(
        "--reference",
        action="append",
        default=[],
        metavar="[NAME[:COMPONENT]=]FILE",
        help="reference CSV drawn over series NAME (its component COMPONENT); NAME may be left "
        "out when one series is plotted (repeatable)",
    )
    p.add_argument("--out", type=Path, help="folder for the PNGs (default: <results stem>_plots)")
    return p


def add_sweep_parser(sub) -> argparse.ArgumentParser:
    p = sub.add_parser(
        "sweep",
        help="run a scenario over a grid of parameter values (resumable) and summarise peaks",
        description="Runs the Cartesian product of the --grid values, each case as a child "
        "'mpsfem structure' (scenario without [fluid]) or 'mpsfem run' process in "
        "OUT/<case>/ (results.h5, run.log, case.json). Every case is validated before the "
        "first starts; cases whose results file is finished (same scenario, same options) are "
        "not run again. Writes OUT/summary.csv and OUT/peak-*.png. Exit status 1 if any "
        "case failed. See docs/tools.md.",
    )
    p.add_argument("scenario", type=Path, help="scenario TOML file")
    p.add_argument(
        "--grid",
        action="append",
        default=[],
        required=True,
        metavar="KEY=V1,V2,...",
        help="a scenario key and its values, TOML literals or bare words as for --set "
        "(--grid structure.members.0.thickness=0.01,0.02 --grid "
        "'structure.loads.0.force=[0.0,-100.0],[0.0,-200.0]'); repeat for more keys",
    )
    p.add_argument(
        "--jobs",
        type=int,
        help="cases run at once (default: min(cases to run, cpu_count // 2 or 1)); each child "
        "gets NUMBA_NUM_THREADS = max(1, cpu_count // jobs)",
    )
    p.add_argument("--out", type=Path, help="folder of the sweep (default: <scenario stem>_sweep)")
    p.add_argument(
        "--peak",
        dest="peaks",
        action="extend",
        nargs="+",
        metavar="PROBE[:COMPONENT]",
        help="probe whose peak max|value| (and its time) goes into summary.csv and the plots; "
        "without COMPONENT, the magnitude over the components",
    )
    p.add_argument(
        "--end-time", type=float, help="simulated end time of every case, s (run.end_time)"
    )
    p.add_argument(
        "--set",
        dest="overrides",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="override a scenario value in every case (TOML literal or bare word, as for "
        "mpsfem run)",
    )
    return p


def add_tool_parsers(sub) -> None:
    """Register ``plot`` and ``sweep`` on the sub-parser collection of :mod:`mpsfem.cli`."""
    add_plot_parser(sub)
    add_sweep_parser(sub)


def run_tool(args: argparse.Namespace) -> int:
    """Run ``mpsfem plot`` or ``mpsfem sweep``; returns the exit status."""
    if args.command == "plot":
        from mpsfem.tools.plot import cli_main
    else:
        from mpsfem.tools.sweep import cli_main
    return cli_main(args)
