"""Rubber gate dam break (Antoci, Gallati & Sibilla 2007; issue 21).

Runs scenarios/elastic_gate_2d.toml (co-rotational rubber gate, implicit IQN-ILS coupling) at the
particle spacings of :data:`SPACINGS`, each case an ``mpsfem run`` subprocess on
NUMBA_NUM_THREADS threads (default 1), every case the scenario plus ``--set`` overrides
(:func:`overrides`). Then it analyses every finished results file and writes

* validation/results/elastic_gate.csv: the tip displacement history (dx, dy, m) of every case on
  the probe times (columns ``t_s``, ``dx_<l0>``, ``dy_<l0>``, ``fx_<l0>``, ``fy_<l0>``);
* validation/results/elastic_gate_cases.csv: one row per case (spacing, particles, windows,
  coupling iterations per window mean / max, unconverged windows, peaks of dx and dy (the gate
  opens towards +x and its tip rises) and their times, wall time);
* docs/figures/elastic_gate_tip.png: tip dx and dy against time, every case.

Resumable (validation/case_runner.py): a finished case is not run again, a killed one resumes
from its checkpoint, a failed one reruns only with ``--retry-failed``.

    python validation/elastic_gate.py [--spacings 0.003,0.002,0.0015] [--end-time 0.4] [--threads 1]
                                      [--analyse-only] [--retry-failed]
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import h5py
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import case_runner  # noqa: E402 - validation/case_runner.py: resumable runs of one case
from results_csv import write_csv  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
SCENARIO = ROOT / "scenarios" / "elastic_gate_2d.toml"
RESULTS_DIR = ROOT / "validation" / "results"
FIGURES_DIR = ROOT / "docs" / "figures"
#: particle spacings (m): the gate's 6 mm gap is 2, 3 and 4 spacings (scenario comment)
SPACINGS = (0.003, 0.002, 0.0015)
END_TIME = 0.4  # s


def case_path(l0: float) -> Path:
    return RESULTS_DIR / f"elastic_gate_{l0:g}.h5"


def overrides(l0: float, end_time: float) -> list[str]:
    return [f"fluid.spacing={l0!r}", "output.snapshot_interval=0", f"run.end_time={end_time!r}"]


def analyse(path: Path) -> dict:
    """Histories and one summary row of a finished (or partly run) results file."""
    with h5py.File(path, "r") as h5:
        t = h5["probes/tip/time"][:]
        tip = h5["probes/tip/value"][:]
        force = h5["probes/gate_force/value"][:]
        ft = h5["probes/gate_force/time"][:]
        c = h5["coupling"]
        it = c["iterations"][:]
        conv = c["converged"][:].astype(bool)
        n_particles = int(h5.attrs.get("particles", -1))
        wall = float(h5.attrs.get("wall_time", np.nan))
        status = str(h5.attrs.get("status", "unknown"))
    i_dx, i_dy = int(np.argmax(tip[:, 0])), int(np.argmax(tip[:, 1]))  # opens +x, tip rises
    row = {
        "spacing_m": float(path.stem.split("_")[-1]),
        "status": status,
        "t_end_s": float(t[-1]),
        "particles": n_particles,
        "windows": int(it.size),
        "iterations_mean": float(it.mean()),
        "iterations_max": int(it.max()),
        "unconverged_windows": int((~conv).sum()),
        "dx_max_m": float(tip[i_dx, 0]),
        "t_dx_max_s": float(t[i_dx]),
        "dy_max_m": float(tip[i_dy, 1]),
        "t_dy_max_s": float(t[i_dy]),
        "fx_max_N_per_m": float(force[:, 0].max()),
        "wall_time_s": wall,
    }
    return {"row": row, "t": t, "tip": tip, "ft": ft, "force": force}


def write_outputs(results: dict[float, dict]) -> None:
    keys = sorted(results, reverse=True)
    t = results[keys[0]]["t"]
    hist = []
    for ti in t:
        r: dict = {"t_s": float(ti)}
        for l0 in keys:
            d = results[l0]
            j = np.searchsorted(d["t"], ti)
            if j < d["t"].size and abs(d["t"][j] - ti) < 1e-9:
                r[f"dx_{l0:g}"], r[f"dy_{l0:g}"] = (float(v) for v in d["tip"][j])
            k = np.searchsorted(d["ft"], ti)
            if k < d["ft"].size and abs(d["ft"][k] - ti) < 1e-9:
                r[f"fx_{l0:g}"], r[f"fy_{l0:g}"] = (float(v) for v in d["force"][k])
        hist.append(r)
    cols = ["t_s"] + [f"{q}_{l0:g}" for l0 in keys for q in ("dx", "dy", "fx", "fy")]
    write_csv(
        hist,
        RESULTS_DIR / "elastic_gate.csv",
        cols,
        "tip displacement (m) and gate force (N/m) of the rubber gate; validation/elastic_gate.py",
    )
    write_csv(
        [results[k]["row"] for k in keys],
        RESULTS_DIR / "elastic_gate_cases.csv",
        comment="one row per spacing; validation/elastic_gate.py",
    )
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(1, 2, figsize=(10, 3.8))
    for l0 in keys:
        d = results[l0]
        ax[0].plot(d["t"], 1e3 * d["tip"][:, 0], label=f"l0 = {1e3 * l0:g} mm")
        ax[1].plot(d["t"], 1e3 * d["tip"][:, 1], label=f"l0 = {1e3 * l0:g} mm")
    for a, q in zip(ax, ("dx", "dy"), strict=True):
        a.set_xlabel("t (s)")
        a.set_ylabel(f"tip {q} (mm)")
        a.grid(alpha=0.3)
        a.legend(fontsize=8)
    fig.suptitle("rubber gate (Antoci et al. 2007 set-up), co-rotational beam", fontsize=9)
    fig.tight_layout()
    FIGURES_DIR.mkdir(parents=True, exist_ok=True)
    fig.savefig(FIGURES_DIR / "elastic_gate_tip.png", dpi=110)
    plt.close(fig)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    case_runner.add_run_options(ap)
    ap.add_argument("--spacings", default=",".join(f"{s:g}" for s in SPACINGS))
    ap.add_argument("--end-time", type=float, default=END_TIME)
    args = ap.parse_args(argv)
    RESULTS_DIR.mkdir(parents=True, exist_ok=True)
    spacings = [float(s) for s in args.spacings.split(",")]
    cases = {l0: (case_path(l0), overrides(l0, args.end_time), f"[l0 = {l0:g}]") for l0 in spacings}
    paths = case_runner.finished_cases(
        SCENARIO, cases, args.threads, args.analyse_only, args.retry_failed
    )
    if not paths:
        print("nothing to analyse")
        return 1
    results = {l0: analyse(p) for l0, p in paths.items()}
    write_outputs(results)
    for l0 in sorted(results, reverse=True):
        r = results[l0]["row"]
        print(
            f"l0 = {l0:g}: dx max {1e3 * r['dx_max_m']:.1f} mm at {r['t_dx_max_s']:.3f} s, "
            f"dy max {1e3 * r['dy_max_m']:.1f} mm at {r['t_dy_max_s']:.3f} s, iterations "
            f"{r['iterations_mean']:.2f} / {r['iterations_max']}, unconverged "
            f"{r['unconverged_windows']}, wall {r['wall_time_s']:.0f} s"
        )
    return 0 if len(paths) == len(spacings) else 1


if __name__ == "__main__":
    sys.exit(main())
