"""Dam break: the far-wall pressure gauge and its noise level (issue 2).

Runs scenarios/dam_break_2d.toml to t = 0.4 s (the surge reaches the far wall at t ~ 0.25 s
and runs up it; later, from 0.42-0.56 s in runs to 0.6 s, the jet falling back from the far
wall throws particles over the 0.4 m high left wall and the run stops: a particle left the
domain) with the ``right_wall_p`` gauge (0.02 m above the floor
on the far wall, radius 5.5 mm) sampled every 1 ms: at l0 = L/20, L/40, L/80 with the default
Courant number 0.2, and at L/40 with 0.1 and 0.5 (the stability map's range,
``dam_break.py --stability``); then with artificial compressibility
(``fluid.pressure.compressibility``, sound speed 1 / sqrt(rho kappa)) at L/40 from kappa = 1e-7
to 1e-5 1/Pa (100 to 10 m/s) and at L/20, L/80 with 1e-6 (31.6 m/s), with the front's error
(dam_break.py's metric) beside the noise: does a compressible fluid quieten the gauge without
moving the front? Each case is an ``mpsfem run`` subprocess, resumable like every
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
from dam_break import (  # noqa: E402
    FIGURES_DIR,
    REFERENCE_KEYS,
    RESULTS_DIR,
    SCENARIO,
    L,
    front_curve,
    front_error,
    references,
)
from results_csv import write_csv  # noqa: E402

RHO, G = 1000.0, 9.81
P_SCALE = RHO * G * 2 * L  # Pa: the column's hydrostatic pressure at the floor, 2864 Pa
END_TIME = 0.4  # s
SAMPLE = 1e-3  # s, probe interval
SMOOTHING = 11  # samples of the Savitzky-Golay window (11 ms)
SETTLE = 0.02  # s after arrival before the noise interval starts (the impact transient)
#: (resolution L / l0, Courant number, artificial compressibility kappa in 1/Pa) of the study,
#: the default first; kappa = 0 is the incompressible default
CASES = (
    (20, 0.2, 0.0),
    (40, 0.2, 0.0),
    (80, 0.2, 0.0),
    (40, 0.1, 0.0),
    (40, 0.5, 0.0),
    (40, 0.2, 1e-7),
    (40, 0.2, 1e-6),
    (40, 0.2, 3e-6),
    (40, 0.2, 1e-5),
    (20, 0.2, 1e-6),
    (80, 0.2, 1e-6),
)


def sound_speed(kappa: float) -> float:
    """m/s: 1 / sqrt(rho kappa), infinite for the incompressible kappa = 0."""
    return 1.0 / np.sqrt(RHO * kappa) if kappa > 0 else np.inf


def case_path(n: int, courant: float, kappa: float = 0.0) -> Path:
    tail = f"_k{kappa:g}" if kappa > 0 else ""
    return RESULTS_DIR / f"dam_break_wall_gauge_L{n}_C{courant:g}{tail}.h5"


def overrides(n: int, courant: float, kappa: float = 0.0) -> list[str]:
    return [
        f"fluid.spacing={L / n!r}",
        f"fluid.time_step.courant={courant:g}",
        f"fluid.pressure.compressibility={kappa!r}",
        "output.snapshot_interval=0",
        f"output.probe_interval={SAMPLE}",
        f"run.end_time={END_TIME}",
    ]


def case_label(n: int, courant: float, kappa: float) -> str:
    tail = f", kappa {kappa:g} 1/Pa" if kappa > 0 else ""
    return f"L/{n}, Courant {courant:g}{tail}"


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


def write_outputs(rows: list[dict], paths: dict[tuple[int, float, float], Path]) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    comment = (
        "dam break far-wall gauge (right_wall_p, 0.02 m above the floor), "
        "validation/dam_break_wall_gauge.py: arrival, impact peak, Savitzky-Golay smoothed peak "
        f"({SMOOTHING} ms, quadratic), and the noise level: RMS of raw - smoothed from arrival + "
        f"{SETTLE * 1e3:.0f} ms to t = {END_TIME} s, in Pa and relative to the smoothed mean there; "
        "compressibility kappa (1/Pa, 0 = incompressible) and its sound speed; the front's RMS "
        "error over 0.5 <= T <= 3 against Koshizuka & Oka / Martin & Moyce (dam_break.py)"
    )
    write_csv(rows, FIGURES_DIR / "dam_break_wall_gauge.csv", comment=comment)
    fig, axes = plt.subplots(
        len(paths), 1, figsize=(6.5, 1.9 * len(paths)), sharex=True, squeeze=False
    )
    axes = axes[:, 0]  # one panel per run, also when only one run is analysed
    for ax, (case, path), row in zip(axes, paths.items(), rows, strict=True):
        t, p = read_gauge(path)
        ax.plot(t, p / P_SCALE, lw=0.6, color="0.6", label="raw (1 ms samples)")
        ax.plot(t, smoothed(p) / P_SCALE, lw=1.2, color="C0", label="smoothed")
        ax.set_title(
            f"{case_label(*case)}: noise {row['noise_rms_pa']:.0f} Pa rms "
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
    cases = {c: (case_path(*c), overrides(*c), f"[{case_label(*c)}]") for c in CASES}
    paths: dict[tuple[int, float, float], Path] = case_runner.finished_cases(
        SCENARIO, cases, args.threads, args.analyse_only, args.retry_failed
    )
    if not paths:
        print("nothing to analyse")
        return 1
    rows = []
    refs = references()
    for (n, courant, kappa), path in paths.items():
        with h5py.File(path, "r") as h5:
            wall = float(h5.attrs.get("wall_time", np.nan))
        stats = gauge_statistics(*read_gauge(path))
        T, Z = front_curve(path)
        front = {
            f"front_rms_error_{key}": front_error(T, Z, ref)
            for key, ref in zip(REFERENCE_KEYS, refs.values(), strict=True)
        }
        rows.append(
            {
                "resolution_L_over_l0": n,
                "courant": courant,
                "compressibility_per_pa": kappa,
                "sound_speed_m_s": sound_speed(kappa),
                "wall_time_s": wall,
            }
            | vars(stats)
            | front
        )
    write_outputs(rows, paths)
    print(
        "L/l0  Courant  kappa (1/Pa)  arrival  peak (Pa)  smoothed peak  mean after  "
        "noise rms           front K&O     wall"
    )
    for r in rows:
        print(
            f"{r['resolution_L_over_l0']:>4}  {r['courant']:>7.2f}  "
            f"{r['compressibility_per_pa']:12.0e}  {r['arrival_s']:.3f} s  "
            f"{r['peak_pa']:8.0f}  {r['smoothed_peak_pa']:12.0f}  {r['mean_after_impact_pa']:9.0f}  "
            f"{r['noise_rms_pa']:5.0f} Pa ({100 * r['noise_relative']:5.1f} %)  "
            f"{100 * r['front_rms_error_ko']:5.1f} %  {r['wall_time_s']:6.0f} s"
        )
    return 0 if len(paths) == len(CASES) else 1


if __name__ == "__main__":
    sys.exit(main())
