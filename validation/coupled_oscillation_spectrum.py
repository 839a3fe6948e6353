"""The light plate's high-frequency load oscillation under δ-SPH: its frequency and size in every
stored run of validation/bottom_slamming_light_delta_sph.py (issue 21, the period-two stops at
A/H = 0.4 and 0.5; docs/validation_bottom_slamming_light.md, "The MF table's other wave heights
under δ-SPH").

For each row of bottom_slamming_light_delta_sph.csv whose results file is here, over its wet
span (from the first to the last 1 ms sample of the member's vertical load above 1 N/m, to the
run's end or stop):

- from the member's vertical load (probe "uplift", N/m, 1 ms samples): the RMS of its second
  difference and the share of its spectrum at 300 Hz and above (the load less its 11-sample
  running mean, Hann window);
- elastic runs, from the fluid's work on the member per coupling window (coupling/work_fluid,
  sampled at the window rate, so resolved to the window's Nyquist frequency 1 / (2 window)):
  the frequency of the spectrum's peak and the share above half the Nyquist frequency.

Rigid runs have no coupling records (their columns are blank). Reads the stored files only; a
few seconds in all.

    python validation/coupled_oscillation_spectrum.py
"""

from __future__ import annotations

import sys
from pathlib import Path

import h5py
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from results_csv import read_csv, write_csv  # noqa: E402

RESULTS_DIR = Path(__file__).resolve().parent / "results"
STUDY_CSV = RESULTS_DIR / "bottom_slamming_light_delta_sph.csv"
CSV = RESULTS_DIR / "bottom_slamming_light_delta_sph_spectrum.csv"
WET_LOAD = 1.0  # N/m: the wet span's threshold on |vertical load|
HIGH_HZ = 300.0  # Hz: "high frequency" in the 1 ms load's spectrum


def power_spectrum(x: np.ndarray, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """Frequencies (Hz) and normalised power of ``x`` less its 11-sample running mean."""
    y = x - np.convolve(x, np.ones(11) / 11.0, "same")
    p = np.abs(np.fft.rfft(y * np.hanning(len(y)))) ** 2
    return np.fft.rfftfreq(len(y), dt), p / max(p.sum(), 1e-300)


def analyse(path: Path) -> dict:
    """The spectral figures of one results file (module docstring)."""
    with h5py.File(path, "r") as h5:
        t = h5["probes/uplift/time"][:]
        fy = h5["probes/uplift/value"][:, 1]
        work = h5["coupling/work_fluid"][:] if "coupling" in h5 else None
        tw = h5["coupling/time"][:] if "coupling" in h5 else None
    wet = t[np.abs(fy) > WET_LOAD]
    row: dict = {"wet_from_s": np.nan, "wet_to_s": np.nan}
    if len(wet) < 32:
        return row
    a, b = float(wet[0]), float(wet[-1])
    m = (t >= a) & (t <= b)
    freq, p = power_spectrum(fy[m], float(np.median(np.diff(t))))
    row.update(
        wet_from_s=a,
        wet_to_s=b,
        load_rms=float(np.sqrt(np.mean(fy[m] ** 2))),
        load_second_diff_rms=float(np.sqrt(np.mean(np.diff(fy[m], 2) ** 2))),
        load_share_above_300hz=float(p[freq >= HIGH_HZ].sum()),
    )
    if work is not None and len(tw) > 1:
        window = float(np.median(np.diff(tw)))
        mw = (tw >= a) & (tw <= b)
        if mw.sum() >= 32:
            fw, pw = power_spectrum(work[mw], window)
            nyquist = 0.5 / window
            row.update(
                window_s=window,
                work_peak_hz=float(fw[np.argmax(pw)]),
                work_share_above_half_nyquist=float(pw[fw >= 0.5 * nyquist].sum()),
            )
    return row


def main() -> None:
    rows = []
    for r in read_csv(STUDY_CSV):
        path = RESULTS_DIR / r["results_file"]
        if not path.is_file() or not r["status"]:
            continue
        row = {
            "run": r["run"],
            "a_over_h": r["a_over_h"],
            "d_over_h": r["d_over_h"],
            "status": r["status"].split(":")[0],
            "t_end_s": r["t_end_s"],
        }
        row.update(analyse(path))
        rows.append(row)
        print(
            f"{row['run']:34s} A/H {row['a_over_h']} D/H {row['d_over_h']}: "
            + ", ".join(f"{k} {v:.4g}" for k, v in row.items() if isinstance(v, float))
        )
    columns = [
        "run", "a_over_h", "d_over_h", "status", "t_end_s", "wet_from_s", "wet_to_s",
        "load_rms", "load_second_diff_rms", "load_share_above_300hz", "window_s",
        "work_peak_hz", "work_share_above_half_nyquist",
    ]  # fmt: skip
    write_csv(
        rows,
        CSV,
        columns,
        comment="the δ-SPH light plate's high-frequency load oscillation per run "
        "(validation/coupled_oscillation_spectrum.py); loads N/m, frequencies Hz, times s",
    )
    print(f"wrote {CSV.relative_to(RESULTS_DIR.parents[1])}")


if __name__ == "__main__":
    main()
