"""Dam break: the far-wall pressure gauge and its noise level (issue 2).

Runs scenarios/dam_break_2d.toml to t = 0.4 s (the surge reaches the far wall at t ~ 0.25 s
and runs up it; later, from 0.42-0.56 s in runs to 0.6 s, the jet falling back from the far
wall throws particles over the 0.4 m high left wall and the run stops: a particle left the
domain) with the ``right_wall_p`` gauge (0.02 m above the floor
on the far wall, radius 5.5 mm) sampled every 1 ms: at l0 = L/20, L/40, L/80 with the default
Courant number 0.2, and at L/40 with 0.1 and 0.5 (the stability map's range,
``dam_break.py --stability``). Each case is an ``mpsfem run`` subprocess, resumable like every
study in validation/. Per run (:func:`gauge_statistics`):

* the arrival time (first sample above 1 % of rho g 2L) and the impact peak (largest sample);
* the smoothed signal, a Savitzky-Golay fit (quadratic, 11 ms window: it keeps the run-up's
  variation over tens of ms and removes the sample-to-sample scatter), and its peak;
* the noise level: the RMS of raw - smoothed over the wet interval after the impact (arrival +
  20 ms to the end), divided by sqrt(1 - h0), h0 the fit's own weight of the centre sample (so
  that white noise of standard deviation s reads s), in Pa and relative to the smoothed
  signal's mean there;

then writes docs/figures/dam_break_wall_gauge.csv and .png (raw and smoothed signals) and prints
the table. Discussion in docs/fluid.md ("Far-wall pressure gauge").

    python validation/dam_break_wall_gauge.py [--threads 1] [--analyse-only] [--retry-failed]
"""

from __future__ import annotations

import argparse
import sys
from dataclasses import dataclass
from pathlib import Path

import h5py
import numpy as np
from scipy.signal import savgol_coeffs, savgol_filter

sys.path.insert(0, str(Path(__file__).resolve().parent))
import case_runner  # noqa: E402 - validation/case_runner.py: resumable runs of one case
from dam_break import FIGURES_DIR, RESULTS_DIR, SCENARIO, L  # noqa: E402
from results_csv import write_csv  # noqa: E402

RHO, G = 1000.0, 9.81
P_SCALE = RHO * G * 2 * L  # Pa: the column's hydrostatic pressure at the floor, 2864 Pa
END_TIME = 0.4  # s
SAMPLE = 1e-3  # s, probe interval
SMOOTHING = 11  # samples of the Savitzky-Golay window (11 ms)
SETTLE = 0.02  # s after arrival before the noise interval starts (the impact transient)
#: (resolution L / l0, Courant number) of the study, the default first
CASES = ((20, 0.2), (40, 0.2), (80, 0.2), (40, 0.1), (40, 0.5))


def case_path(n: int, courant: float) -> Path:
    return RESULTS_DIR / f"dam_break_wall_gauge_L{n}_C{courant:g}.h5"


def overrides(n: int, courant: float) -> list[str]:
    return [
        f"fluid.spacing={L / n!r}",
        f"fluid.time_step.courant={courant:g}",
        "output.snapshot_interval=0",
        f"output.probe_interval={SAMPLE}",
        f"run.end_time={END_TIME}",
    ]


def read_gauge(path: Path) -> tuple[np.ndarray, np.ndarray]:
    """(t, p) of the right_wall_p probe (s, Pa); a dry gauge (NaN) reads 0."""
    with h5py.File(path, "r") as h5:
        t = h5["probes/right_wall_p/time"][:]
        p = h5["probes/right_wall_p/value"][:]
    return t, np.nan_to_num(p, nan=0.0)


@dataclass
class GaugeStatistics:
    """What :func:`gauge_statistics` measures on a gauge signal (s, Pa)."""

    arrival_s: float
    peak_pa: float
    peak_time_s: float
    smoothed_peak_pa: float
    mean_after_impact_pa: float  # smoothed signal, arrival + SETTLE .. end
    noise_rms_pa: float  # RMS of raw - smoothed over the same interval, / sqrt(1 - h0)
    noise_relative: float  # noise_rms_pa / mean_after_impact_pa


def smoothed(p: np.ndarray) -> np.ndarray:
    """Savitzky-Golay fit of a uniformly sampled signal: quadratic, SMOOTHING samples."""
    return savgol_filter(p, SMOOTHING, 2, mode="interp")


def gauge_statistics(t: np.ndarray, p: np.ndarray) -> GaugeStatistics:
    """Arrival, peaks, and the noise level after the impact of a gauge signal (s, Pa)."""
    wet = np.flatnonzero(p > 0.01 * P_SCALE)
    if wet.size == 0:
        raise ValueError("the gauge never reads more than 1 % of rho g 2L: no arrival")
    arrival = float(t[wet[0]])
    ps = smoothed(p)
    after = t >= arrival + SETTLE
    if np.count_nonzero(after) < 2 * SMOOTHING:
        raise ValueError(f"fewer than {2 * SMOOTHING} samples after the impact transient")
    k = int(np.argmax(p))
    mean = float(np.mean(ps[after]))
    # the residual of white noise has variance s^2 (1 - h0): the centre sample is in its own fit
    h0 = savgol_coeffs(SMOOTHING, 2)[SMOOTHING // 2]
    noise = float(np.sqrt(np.mean((p[after] - ps[after]) ** 2) / (1.0 - h0)))
    return GaugeStatistics(
        arrival_s=arrival,
        peak_pa=float(p[k]),
        peak_time_s=float(t[k]),
        smoothed_peak_pa=float(np.max(ps)),
        mean_after_impact_pa=mean,
        noise_rms_pa=noise,
        noise_relative=noise / mean,
    )


def write_outputs(rows: list[dict], paths: dict[tuple[int, float], Path]) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    comment = (
        "dam break far-wall gauge (right_wall_p, 0.02 m above the floor), "
        "validation/dam_break_wall_gauge.py: arrival, impact peak, Savitzky-Golay smoothed peak "
        f"({SMOOTHING} ms, quadratic), and the noise level: RMS of raw - smoothed from arrival + "
        f"{SETTLE * 1e3:.0f} ms to t = {END_TIME} s, in Pa and relative to the smoothed mean there"
    )
    write_csv(rows, FIGURES_DIR / "dam_break_wall_gauge.csv", comment=comment)
    fig, axes = plt.subplots(
        len(paths), 1, figsize=(6.5, 1.9 * len(paths)), sharex=True, squeeze=False
    )
    axes = axes[:, 0]  # one panel per run, also when only one run is analysed
    for ax, ((n, courant), path), row in zip(axes, paths.items(), rows, strict=True):
        t, p = read_gauge(path)
        ax.plot(t, p / P_SCALE, lw=0.6, color="0.6", label="raw (1 ms samples)")
        ax.plot(t, smoothed(p) / P_SCALE, lw=1.2, color="C0", label="smoothed")
        ax.set_title(
            f"L/{n}, Courant {courant:g}: noise {row['noise_rms_pa']:.0f} Pa rms "
            f"({100 * row['noise_relative']:.0f} % of the mean after the impact)",
            fontsize=8,
        )
        ax.set_ylabel("p / (rho g 2L)", fontsize=8)
        ax.set_xlim(0.2, END_TIME)
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=7)
    axes[-1].set_xlabel("t (s)")
    fig.tight_layout()
    fig.savefig(FIGURES_DIR / "dam_break_wall_gauge.png", dpi=110)
    plt.close(fig)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    case_runner.add_run_options(ap)
    args = ap.parse_args(argv)
    RESULTS_DIR.mkdir(parents=True, exist_ok=True)
    paths: dict[tuple[int, float], Path] = {}
    for n, courant in CASES:
        out = case_path(n, courant)
        status = case_runner.case_status(
            SCENARIO,
            out,
            overrides(n, courant),
            args.threads,
            args.analyse_only,
            args.retry_failed,
            f"[L/{n} C={courant:g}]",
        )
        if status == "finished":
            paths[(n, courant)] = out
        else:
            print(f"L/{n}, Courant {courant:g}: {status}, not analysed")
    if not paths:
        print("nothing to analyse")
        return 1
    rows = []
    for (n, courant), path in paths.items():
        with h5py.File(path, "r") as h5:
            wall = float(h5.attrs.get("wall_time", np.nan))
        stats = gauge_statistics(*read_gauge(path))
        rows.append(
            {"resolution_L_over_l0": n, "courant": courant, "wall_time_s": wall} | vars(stats)
        )
    write_outputs(rows, paths)
    print("L/l0  Courant  arrival  peak (Pa)  smoothed peak  mean after  noise rms       wall")
    for r in rows:
        print(
            f"{r['resolution_L_over_l0']:>4}  {r['courant']:>7.2f}  {r['arrival_s']:.3f} s  "
            f"{r['peak_pa']:8.0f}  {r['smoothed_peak_pa']:12.0f}  {r['mean_after_impact_pa']:9.0f}  "
            f"{r['noise_rms_pa']:5.0f} Pa ({100 * r['noise_relative']:4.1f} %)  {r['wall_time_s']:6.0f} s"
        )
    return 0 if len(paths) == len(CASES) else 1


if __name__ == "__main__":
    sys.exit(main())
