"""2D solitary-wave tank validation (thesis ch. 3.3; references.md sections 6 and 9).

Runs scenarios/solitary_wave_2d.toml for A/H = 0.2, 0.3, 0.4, 0.5 at one particle spacing (each
case an ``mpsfem run`` subprocess on NUMBA_NUM_THREADS threads, default 1), then analyses every
results file against the solitary-wave theory and writes

* validation/results/wave_tank_<l0>.csv: one row per A/H (columns: :data:`CSV_COLUMNS`);
* docs/figures/solitary_eta_x1.2_<l0>.png: eta(t) at x = 1.2 m for every A/H with the first-order
  and Grimshaw third-order profiles overlaid; docs/figures/solitary_gauges_<l0>.png: every gauge
  of every case (the wave along the tank, the sponge);

and prints a table with the wall time per case. Definitions: docs/validation_wave_tank.md and
the docstrings of :func:`crest`, :func:`profile_rms`, :func:`crest_speed` and
:func:`reflection`.

Resumable: a case whose results file says ``status = finished`` is not run again; one that a kill
left at ``running`` resumes from its checkpoint (``mpsfem run --restart``); a ``failed`` one is
reported and only rerun with ``--retry-failed`` (runs are deterministic, so a rerun fails again
unless the scenario changed).

    python validation/wave_tank.py [--l0 0.004] [--ratios 0.2,0.3,0.4,0.5] [--threads 1]
                                   [--analyse-only] [--retry-failed]
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from dataclasses import asdict, dataclass, fields
from pathlib import Path

import h5py
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import case_runner  # noqa: E402 - validation/case_runner.py: resumable runs of one case
from case_runner import read_status  # noqa: E402
from results_csv import write_csv  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
SCENARIO = ROOT / "scenarios" / "solitary_wave_2d.toml"
RESULTS_DIR = ROOT / "validation" / "results"
FIGURES_DIR = ROOT / "docs" / "figures"

DEPTH = 0.114  # H, m (thesis ch. 3.3)
GRAVITY = 9.81  # m/s^2
RATIOS = (0.2, 0.3, 0.4, 0.5)  # A/H (thesis ch. 3.3)
PADDLE_WALL = 1  # index of the paddle in fluid.walls of the scenario
MAIN_GAUGE = 1.2  # m from the paddle's initial face (thesis ch. 3.4 gauge, ch. 5.1 plate)
SPEED_GAUGES = (0.6, 1.6)  # crest speed between these two gauges, m
CREST_GAUGES = (0.6, 1.0, 1.2, 1.6)  # gauges whose crest is measured, m
REFLECTION_GAUGE = 1.0  # far enough upstream that incident and reflected wave separate, m
SPONGE_START = 2.0  # inner edge of the sponge, m (scenario)
TANK_END = 2.5  # end wall, m (scenario)
SPONGE_GAUGE = 2.4  # inside the sponge, 0.1 m before the end wall, m
GORING_HALF_SPAN = 3.8  # |k (x - c t)| at which the wave is truncated (thesis eq. 3-8)
RMS_HALF_SPAN = 3.0  # RMS window |k c (t - t_c)| <= 3: the first-order eta >= 1 % of A
AMPLITUDE_TARGET = 0.05  # crest amplitude at 1.2 m within 5 % of A (issue 5)


# ---------------------------------------------------------------------- theory (references.md 6)
@dataclass(frozen=True)
class SolitaryWave:
    """Solitary wave of amplitude A (m) on depth H (m) under gravity g (m/s^2)."""

    amplitude: float
    depth: float = DEPTH
    gravity: float = GRAVITY

    @property
    def eps(self) -> float:
        return self.amplitude / self.depth

    @property
    def k(self) -> float:
        """k = sqrt(3 A / (4 H^3)), 1/m (thesis eq. 3-2)."""
        return math.sqrt(3.0 * self.amplitude / (4.0 * self.depth**3))

    @property
    def c_first_order(self) -> float:
        """c = sqrt(g (H + A)), m/s (thesis eq. 3-3)."""
        return math.sqrt(self.gravity * (self.depth + self.amplitude))

    @property
    def c_grimshaw(self) -> float:
        """c = sqrt(g H) sqrt(1 + eps - eps^2/20 - 3 eps^3/70), m/s (Grimshaw 1971, 3rd order)."""
        e = self.eps
        return math.sqrt(self.gravity * self.depth) * math.sqrt(
            1.0 + e - e * e / 20.0 - 3.0 * e**3 / 70.0
        )

    @property
    def passage_time(self) -> float:
        """Half the time the first-order wave needs to pass a point, truncated at
        |k (x - c t)| = 3.8 (thesis eq. 3-8): 3.8 / (k c), s."""
        return GORING_HALF_SPAN / (self.k * self.c_first_order)

    def first_order(self, t: np.ndarray, t_crest: float) -> np.ndarray:
        """eta(t) (m) at a fixed gauge, crest at t_crest: A sech^2(k c (t - t_c)) (eq. 3-1)."""
        s = 1.0 / np.cosh(self.k * self.c_first_order * (np.asarray(t) - t_crest))
        return self.amplitude * s * s

    def grimshaw(self, t: np.ndarray, t_crest: float) -> np.ndarray:
        """eta(t) (m) of Grimshaw's third-order wave at a fixed gauge, crest at t_crest
        (references.md section 6, X = x - c t = -c (t - t_c))."""
        e, h = self.eps, self.depth
        alpha = math.sqrt(0.75 * e) * (1.0 - 5.0 * e / 8.0 + 71.0 * e * e / 128.0)
        arg = alpha * (-self.c_grimshaw * (np.asarray(t) - t_crest)) / h
        s2 = 1.0 / np.cosh(arg) ** 2
        q2 = np.tanh(arg) ** 2
        return h * (
            e * s2
            - 0.75 * e * e * s2 * q2
            + e**3 * (5.0 / 8.0 * s2 * q2 - 101.0 / 80.0 * s2 * s2 * q2)
        )


def paddle_timing(wave: SolitaryWave, start_time: float) -> tuple[float, float, float]:
    """(crest time at the mid-stroke, mid-stroke x, paddle end time) of the Goring paddle whose
    face rests at x = 0 until ``start_time`` (docs/wave_tank.md): the virtual crest passes the
    mid-stroke X = tanh(3.8) S / 2 at start_time + T/2, T = 2 (3.8 + A/H) / (k c) (eq. 3-8)."""
    k, c = wave.k, wave.c_first_order
    duration = 2.0 * (GORING_HALF_SPAN + wave.eps) / (k * c)
    stroke = math.sqrt(16.0 * wave.amplitude * wave.depth / 3.0)  # eq. 3-7
    mid = 0.5 * math.tanh(GORING_HALF_SPAN) * stroke
    return start_time + 0.5 * duration, mid, start_time + duration


def predicted_crest_time(wave: SolitaryWave, start_time: float, x: float) -> float:
    """When the design wave's crest reaches x (m): from the mid-stroke at speed c (s)."""
    t_mid, x_mid, _ = paddle_timing(wave, start_time)
    return t_mid + (x - x_mid) / wave.c_first_order


# ---------------------------------------------------------------------- measurements
def running_mean(eta: np.ndarray, n: int) -> np.ndarray:
    """Centred running mean over n (odd) samples; the n // 2 samples at each end are NaN."""
    out = np.full(eta.shape, np.nan)
    h = n // 2
    if eta.size >= n:
        out[h : eta.size - h] = np.convolve(eta, np.ones(n) / n, mode="valid")
    return out


def crest(
    t: np.ndarray, eta: np.ndarray, wave: SolitaryWave, t_guess: float
) -> tuple[float, float]:
    """(crest time s, crest elevation m) of a gauge record: the vertex of the least-squares
    parabola through the samples with |k c (t - t_c)| <= 0.4 (where the first-order profile is
    above 0.86 A: 21 samples at 0.01 s for A/H = 0.2, 11 for A/H = 0.5).

    The window is centred on the largest value of the record's running mean (over the same
    window's length) within t_guess +- 3.8 / (k c), then recentred once on the vertex. A fit
    rather than the largest sample: the surface particles' noise (up to about l0 / 4 here)
    would bias a single sample upwards. On the exact first-order profile the estimator gives
    A (1 - 0.0015) (the sech^2 profile's quartic term) and t_c to 1e-4 s."""
    k_c = wave.k * wave.c_first_order
    half = 0.4 / k_c
    dt = float(np.median(np.diff(t)))
    n = 2 * max(1, int(half / dt)) + 1
    smooth = running_mean(eta, n)
    p = wave.passage_time
    sel = np.flatnonzero((t >= t_guess - p) & (t <= t_guess + p) & np.isfinite(smooth))
    if sel.size == 0:
        raise ValueError(f"no gauge samples around t = {t_guess:.3f} s")
    t_c = float(t[sel[np.argmax(smooth[sel])]])
    for _ in range(2):
        win = np.isfinite(eta) & (np.abs(t - t_c) <= half)
        if np.count_nonzero(win) < 5:
            raise ValueError(f"too few gauge samples around the crest at t = {t_c:.3f} s")
        tau = t[win] - t_c
        c2, c1, c0 = np.polyfit(tau, eta[win], 2)
        if not c2 < 0.0:
            raise ValueError(f"the gauge record has no crest near t = {t_c:.3f} s")
        shift = -c1 / (2.0 * c2)
        if abs(shift) > half:
            raise ValueError(f"the crest fit near t = {t_c:.3f} s left its window")
        t_c += shift
        a = c0 - c1 * c1 / (4.0 * c2)
    return float(t_c), float(a)


def noise_rms(t: np.ndarray, eta: np.ndarray, wave: SolitaryWave, t_crest: float) -> float:
    """RMS of eta minus its running mean over 0.05 s (5 samples) in the window of
    :func:`profile_rms`, as a fraction of A: the part of the RMS that is the surface's particle
    noise, not the wave's shape (the running mean changes the smooth profile by < 0.3 % of A)."""
    dt = float(np.median(np.diff(t)))
    d = eta - running_mean(eta, 2 * max(1, int(0.025 / dt)) + 1)
    sel = np.abs(wave.k * wave.c_first_order * (t - t_crest)) <= RMS_HALF_SPAN
    return float(np.sqrt(np.nanmean(d[sel] ** 2)) / wave.amplitude)


def profile_rms(
    t: np.ndarray, eta: np.ndarray, theory: np.ndarray, wave: SolitaryWave, t_crest: float
) -> float:
    """RMS of eta - theory over |k c (t - t_c)| <= 3 (where the first-order eta >= 1 % of A),
    as a fraction of A; the theory is aligned with the measured crest time t_c."""
    sel = np.abs(wave.k * wave.c_first_order * (t - t_crest)) <= RMS_HALF_SPAN
    d = eta[sel] - theory[sel]
    return float(np.sqrt(np.nanmean(d * d)) / wave.amplitude)


def crest_speed(t_crest_1: float, t_crest_2: float, x1: float, x2: float) -> float:
    """Crest speed (m/s) from the crest arrival times at two gauges: (x2 - x1) / (t2 - t1)."""
    return (x2 - x1) / (t_crest_2 - t_crest_1)


def reflection(
    t: np.ndarray,
    eta: np.ndarray,
    wave: SolitaryWave,
    t_crest: float,
    x_gauge: float,
    still: float,
    sponge_start: float = SPONGE_START,
) -> tuple[float, tuple[float, float]]:
    """Largest |eta - still| at an upstream gauge x_g after the incident wave has passed and
    before a wave reflected by the paddle could arrive, as a fraction of A; and that window (s).
    eta is the record's running mean over 0.11 s (11 samples at 0.01 s), which removes most of
    the surface particles' noise and lowers the peak of a pulse as long as the incident wave by
    (k c 0.055 s)^2 / 3 = 1.3-3.2 % (A/H = 0.2-0.5).

    Window: from t_c + P, P = 3.8 / (k c) (the incident first-order wave is below sech^2(3.8) =
    0.2 % of A after it), to t_c + (x_s - x_g) / c + (x_s - S + x_g - S) / c0 - P: the crest of
    a wave reflected at the sponge's inner edge x_s (2.0 m in the thesis's tank) and again at
    the paddle (at rest at x = S after its stroke) reaches x_g at t_c + (x_s - x_g) / c + ...,
    and its front P earlier (c = sqrt(g (H + A)) to the sponge, c0 = sqrt(g H) back); cut at the
    end of the record. In between pass the crest reflected at the sponge's inner edge (t_c +
    (x_s - x_g) (1/c + 1/c0)) and part of what the end wall sends back. Whatever is in the
    window came from the sponge and the end wall, plus the incident wave's own trailing tail, so
    this is an upper bound of the sponge's reflection. ``still`` is the gauge's still-water
    level before the paddle started (m), subtracted first."""
    c, c0 = wave.c_first_order, math.sqrt(wave.gravity * wave.depth)
    stroke = math.tanh(GORING_HALF_SPAN) * math.sqrt(16.0 * wave.amplitude * wave.depth / 3.0)
    p = wave.passage_time
    t_start = t_crest + p
    t_back = t_crest + (sponge_start - x_gauge) / c + (sponge_start + x_gauge - 2.0 * stroke) / c0
    t_stop = min(t_back - p, float(t[-1]))
    smooth = running_mean(eta, 11)
    sel = (t >= t_start) & (t <= t_stop) & np.isfinite(smooth)
    if not sel.any():
        return math.nan, (t_start, t_stop)
    return float(np.max(np.abs(smooth[sel] - still)) / wave.amplitude), (t_start, t_stop)


def closed_tank_setup(wave: SolitaryWave, tank_end: float = TANK_END) -> float:
    """Rise of the mean water level (m) once the wave's volume has spread over the whole tank:
    the paddle pushes S' H (S' = tanh(3.8) S its travel) into the tank and stays there, and a
    sponge only damps velocities, it cannot remove water. Spread over the tank from the paddle's
    final face to the end wall: S' H / (L - S'). The wave carries exactly this volume
    (integral of A sech^2 = 2 A / k = S H), so after the sponge has stopped the wave, the water
    it piled up flows back as a long low wave of about this height: no sponge in a closed tank
    can make the reflection metric smaller."""
    travel = math.tanh(GORING_HALF_SPAN) * math.sqrt(16.0 * wave.amplitude * wave.depth / 3.0)
    return travel * wave.depth / (tank_end - travel)


def long_wave_sponge_record(
    wave: SolitaryWave,
    alpha_s: float,
    sponge_start: float = SPONGE_START,
    tank_end: float = TANK_END,
    x_gauge: float = REFLECTION_GAUGE,
    dx: float = 0.0025,
    end_time: float | None = None,
    sample: float = 0.01,
) -> tuple[np.ndarray, np.ndarray, float]:
    """What a gauge at x_gauge records in a 1D model of the tank's sponge: linear long waves,
    eta_t + H u_x = 0, u_t + g eta_x = -alpha(x) u with alpha = alpha_s (x - x_s) / L_s in the
    zone (thesis eq. 3-9, the same velocity damping as the MPS sponge), a reflecting end wall
    at tank_end. The incident wave is the first-order profile A sech^2(k (x - x_0)) with the
    right-going velocity u = sqrt(g / H) eta, started upstream of the gauge; the upstream end
    lets left-going waves out (u = -sqrt(g / H) eta), so nothing comes back from there (the
    MPS analysis window closes before the paddle's re-reflection arrives, see :func:`reflection`).
    Staggered grid, forward-backward in time, dt = 0.4 dx / sqrt(g H), damping implicit. The
    model has no dispersion and no nonlinearity: it estimates what a velocity sponge in a
    closed tank sends back, not the wave's shape.

    Returns (t (s), eta (m) sampled every ``sample`` s, t_crest (s) of the incident wave at the
    gauge)."""
    h, g = wave.depth, wave.gravity
    c0 = math.sqrt(g * h)
    half = GORING_HALF_SPAN / wave.k
    x0 = x_gauge - 2.0 * half  # the crest starts 2 half-lengths upstream of the gauge,
    x_left = x_gauge - 3.0 * half  # its back (sech^2(3.8) = 0.2 % of A) at the upstream end
    n = int(round((tank_end - x_left) / dx))
    dx = (tank_end - x_left) / n
    xc = x_left + (np.arange(n) + 0.5) * dx  # eta at cell centres
    xf = x_left + np.arange(n + 1) * dx  # u at faces; face n is the end wall
    eta = wave.amplitude / np.cosh(wave.k * (xc - x0)) ** 2
    u = c0 / h * wave.amplitude / np.cosh(wave.k * (xf - x0)) ** 2
    u[-1] = 0.0
    length = tank_end - sponge_start
    rate = np.where(xf > sponge_start, alpha_s * (xf - sponge_start) / length, 0.0)
    dt = 0.4 * dx / c0
    if end_time is None:  # the incident crest at the wall and back past the gauge, plus its length
        end_time = (tank_end - x0) / c0 + (tank_end - x_gauge) / c0 + 4.0 * half / c0
    steps = int(math.ceil(end_time / dt))
    every = max(1, int(round(sample / dt)))
    i_gauge = int(np.searchsorted(xc, x_gauge))
    w = (x_gauge - xc[i_gauge - 1]) / dx  # linear between the two cells around the gauge
    t_out, eta_out = [], []
    damp = 1.0 / (1.0 + dt * rate[1:-1])  # implicit in the damping: stable for any alpha_s
    for step in range(steps + 1):
        if step % every == 0:
            t_out.append(step * dt)
            eta_out.append((1.0 - w) * eta[i_gauge - 1] + w * eta[i_gauge])
        eta -= dt * h * np.diff(u) / dx
        u[1:-1] = (u[1:-1] - dt * g * np.diff(eta) / dx) * damp
        u[0] = -math.sqrt(g / h) * eta[0]  # upstream end: left-going waves leave
    t_arr, eta_arr = np.asarray(t_out), np.asarray(eta_out)
    passing = t_arr < (x_gauge - x0 + half) / c0
    t_crest = float(t_arr[passing][np.argmax(eta_arr[passing])])
    return t_arr, eta_arr, t_crest


def long_wave_sponge_reflection(
    wave: SolitaryWave,
    alpha_s: float,
    sponge_start: float = SPONGE_START,
    tank_end: float = TANK_END,
    x_gauge: float = REFLECTION_GAUGE,
) -> float:
    """The :func:`reflection` metric (fraction of A) of the 1D long-wave model
    (:func:`long_wave_sponge_record`): what the MPS tank's measurement would read if the sponge
    acted as on linear long waves."""
    t, eta, t_crest = long_wave_sponge_record(wave, alpha_s, sponge_start, tank_end, x_gauge)
    return reflection(t, eta, wave, t_crest, x_gauge, 0.0, sponge_start)[0]


def return_peak(
    t: np.ndarray, eta: np.ndarray, wave: SolitaryWave, t_crest: float
) -> tuple[float, float]:
    """Everything the sponge and the end wall send back in a record of the 1D long-wave model
    (:func:`long_wave_sponge_record`), without a window: the largest |eta| (fraction of A) after
    the incident wave's passage (t_c + 3.8 / (k c)) to the record's end, and when it comes (s
    after t_c). In a closed tank the wave's volume 2 A / k must come back: it leaves the model
    through its open upstream end, as a pulse whose height is that volume over its duration
    times sqrt(g H). A sponge lowers the return only by spreading it in time."""
    sel = t > t_crest + wave.passage_time
    i = int(np.argmax(np.abs(eta[sel])))
    return float(np.abs(eta[sel][i]) / wave.amplitude), float(t[sel][i] - t_crest)


@dataclass(frozen=True)
class SpongeScanRow:
    """One zone and rate of :func:`sponge_scan` (lengths m, alpha_s 1/s, metrics % of A)."""

    a_over_h: float
    tank_end_m: float
    sponge_start_m: float
    alpha_s: float
    window_reflection_pct: float  # the MPS analysis's windowed metric (:func:`reflection`)
    return_peak_pct: float  # everything sent back within the horizon (:func:`return_peak`)
    return_peak_after_s: float
    closed_tank_setup_pct: float


def sponge_scan(
    ratios: tuple[float, ...] = (0.2, 0.5),
    layouts: tuple[tuple[float, float], ...] = (
        (2.5, 2.0),
        (2.5, 1.6),
        (4.0, 2.0),
        (6.0, 2.0),
        (10.0, 2.0),
    ),
    alphas: tuple[float, ...] = (1.0, 2.0, 4.0, 8.0, 16.0, 50.0),
    horizon: float = 40.0,
) -> list[SpongeScanRow]:
    """The 1D long-wave model over sponge layouts (tank end, sponge start; m) and rates alpha_s
    (1/s): one record per zone, ``horizon`` s long, read both through the MPS analysis's window
    and whole, with the closed tank's set-up."""
    rows = []
    for tank_end, start in layouts:
        for alpha in alphas:
            for ratio in ratios:
                wave = SolitaryWave(ratio * DEPTH)
                t, eta, t_c = long_wave_sponge_record(
                    wave, alpha, start, tank_end, end_time=horizon
                )
                peak, after = return_peak(t, eta, wave, t_c)
                window = reflection(t, eta, wave, t_c, REFLECTION_GAUGE, 0.0, start)[0]
                setup = closed_tank_setup(wave, tank_end) / wave.amplitude
                rows.append(
                    SpongeScanRow(
                        ratio, tank_end, start, alpha, 100 * window, 100 * peak, after, 100 * setup
                    )
                )
    return rows


def still_level(t: np.ndarray, eta: np.ndarray, start_time: float) -> float:
    """Mean gauge reading (m) over the second half of the still water before the paddle starts:
    the settled surface's offset from H (0 when the paddle starts at t = 0)."""
    sel = (t > 0.5 * start_time) & (t <= start_time)
    return float(np.nanmean(eta[sel])) if sel.any() else 0.0


# ---------------------------------------------------------------------- results files
def gauge_name(x: float) -> str:
    return f"gauge_{x:.1f}"


def read_gauge(h5: h5py.File, x: float) -> tuple[np.ndarray, np.ndarray]:
    g = h5["probes"][gauge_name(x)]
    return g["time"][:], g["value"][:]


@dataclass
class CaseResult:
    """One row of validation/results/wave_tank_<l0>.csv (lengths m, times s, errors %)."""

    a_over_h: float
    l0: float
    fluid_particles: int
    status: str
    amplitude_m: float
    amplitude_measured_m: float
    amplitude_error_pct: float  # at x = 1.2 m; the target is |.| <= 5
    amplitude_error_x0_6_pct: float
    amplitude_error_x1_0_pct: float
    amplitude_error_x1_6_pct: float
    crest_time_s: float  # at x = 1.2 m
    crest_time_predicted_s: float  # design wave from the paddle's mid-stroke at c
    rms_first_order_pct: float
    rms_grimshaw_pct: float
    noise_pct: float  # the gauge noise part of both RMS values
    crest_speed_m_s: float  # between SPEED_GAUGES
    c_first_order_m_s: float
    c_grimshaw_m_s: float
    speed_error_first_order_pct: float
    speed_error_grimshaw_pct: float
    still_water_offset_m: float  # at x = 1.0 m before the paddle starts
    reflection_pct: float
    reflection_window_s: str
    closed_tank_setup_pct: float  # the wave's volume spread over the tank: reflection's floor
    sponge_max_pct: float
    steps: int
    wall_time_s: float


CSV_COLUMNS = tuple(f.name for f in fields(CaseResult))


def analyse(path: Path) -> CaseResult:
    """Every measurement of one results file (definitions: the functions above); amplitude,
    depth, paddle start and spacing come from the file's resolved scenario."""
    with h5py.File(path, "r") as h5:
        resolved = json.loads(h5.attrs["scenario_resolved"])
        fluid = resolved["fluid"]
        motion = fluid["walls"][PADDLE_WALL]["motion"]
        wave = SolitaryWave(motion["amplitude"], motion["depth"], abs(fluid["gravity"][1]))
        start = motion["start_time"]
        status = str(h5.attrs.get("status", "unknown"))
        steps = int(h5.attrs.get("steps", 0))
        wall = float(h5.attrs.get("wall_time", math.nan))
        gauges = {x: read_gauge(h5, x) for x in (*CREST_GAUGES, SPONGE_GAUGE)}
        snaps = h5["particles"]
        n_fluid = (
            int(np.count_nonzero(snaps[next(iter(snaps))]["kind"][:] == 0)) if len(snaps) else -1
        )
    crests = {
        x: crest(*gauges[x], wave, predicted_crest_time(wave, start, x)) for x in CREST_GAUGES
    }
    t, eta = gauges[MAIN_GAUGE]
    t_c, a_meas = crests[MAIN_GAUGE]
    speed = crest_speed(crests[SPEED_GAUGES[0]][0], crests[SPEED_GAUGES[1]][0], *SPEED_GAUGES)
    tr, er = gauges[REFLECTION_GAUGE]
    still = still_level(tr, er, start)
    sponges = fluid.get("sponges") or []
    sponge_start = float(sponges[0]["start"]) if sponges else TANK_END
    refl, window = reflection(
        tr, er, wave, crests[REFLECTION_GAUGE][0], REFLECTION_GAUGE, still, sponge_start
    )
    ts, es = gauges[SPONGE_GAUGE]
    sponge = float(np.nanmax(np.abs(running_mean(es, 11) - still_level(ts, es, start))))

    def err(x: float) -> float:
        return 100.0 * (crests[x][1] / wave.amplitude - 1.0)

    return CaseResult(
        a_over_h=round(wave.eps, 6),
        l0=fluid["spacing"],
        fluid_particles=n_fluid,
        status=status,
        amplitude_m=wave.amplitude,
        amplitude_measured_m=a_meas,
        amplitude_error_pct=err(MAIN_GAUGE),
        amplitude_error_x0_6_pct=err(0.6),
        amplitude_error_x1_0_pct=err(1.0),
        amplitude_error_x1_6_pct=err(1.6),
        crest_time_s=t_c,
        crest_time_predicted_s=predicted_crest_time(wave, start, MAIN_GAUGE),
        rms_first_order_pct=100.0 * profile_rms(t, eta, wave.first_order(t, t_c), wave, t_c),
        rms_grimshaw_pct=100.0 * profile_rms(t, eta, wave.grimshaw(t, t_c), wave, t_c),
        noise_pct=100.0 * noise_rms(t, eta, wave, t_c),
        crest_speed_m_s=speed,
        c_first_order_m_s=wave.c_first_order,
        c_grimshaw_m_s=wave.c_grimshaw,
        speed_error_first_order_pct=100.0 * (speed / wave.c_first_order - 1.0),
        speed_error_grimshaw_pct=100.0 * (speed / wave.c_grimshaw - 1.0),
        still_water_offset_m=still,
        reflection_pct=100.0 * refl,
        reflection_window_s=f"{window[0]:.2f}-{window[1]:.2f}",
        closed_tank_setup_pct=100.0 * closed_tank_setup(wave) / wave.amplitude,
        sponge_max_pct=100.0 * sponge / wave.amplitude,
        steps=steps,
        wall_time_s=wall,
    )


# ---------------------------------------------------------------------- running
def spacing_for(l0: float, depth: float = DEPTH) -> float:
    """The spacing nearest ``l0`` that puts a whole number of particle layers in the depth:
    H / round(H / l0) (the lattice fills a block with round(size / l0) particles, so any other
    spacing changes the still-water depth)."""
    return depth / max(1, round(depth / l0))


def case_path(l0_label: str, ratio: float) -> Path:
    return RESULTS_DIR / f"wave_tank_{l0_label}_AH{ratio:.2f}.h5"


def case_overrides(ratio: float, spacing: float) -> list[str]:
    return [
        f"fluid.spacing={spacing!r}",
        f"fluid.walls.{PADDLE_WALL}.motion.amplitude={ratio * DEPTH!r}",
        f"fluid.walls.{PADDLE_WALL}.motion.depth={DEPTH!r}",
        f'title="solitary wave A/H = {ratio:g}, l0 = {spacing:.6g} m"',
    ]


def ensure_case(ratio: float, spacing: float, out: Path, threads: int, retry: bool) -> str:
    """Run (or resume) one case unless its results file says finished; its final status."""
    overrides = case_overrides(ratio, spacing)
    return case_runner.ensure_case(SCENARIO, out, overrides, threads, retry, f"[A/H = {ratio:g}]")


# ---------------------------------------------------------------------- output
def plot_profiles(paths: dict[float, Path], label: str, out: Path) -> None:
    """eta(t) at 1.2 m per A/H with both theories aligned at the measured crest."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    n = len(paths)
    fig, axes = plt.subplots(1, n, figsize=(3.2 * n, 2.8), squeeze=False, sharey=False)
    for ax, (ratio, path) in zip(axes[0], sorted(paths.items()), strict=True):
        res = analyse(path)
        wave = SolitaryWave(ratio * DEPTH)
        with h5py.File(path, "r") as h5:
            t, eta = read_gauge(h5, MAIN_GAUGE)
        tc = res.crest_time_s
        span = 1.6 * wave.passage_time
        sel = np.abs(t - tc) <= span
        tt = np.linspace(tc - span, tc + span, 400)
        ax.plot(t[sel] - tc, eta[sel] / DEPTH, "k.", ms=2.5, label="MPS")
        ax.plot(tt - tc, wave.first_order(tt, tc) / DEPTH, "C0-", lw=1, label="1st order")
        ax.plot(tt - tc, wave.grimshaw(tt, tc) / DEPTH, "C3--", lw=1, label="Grimshaw")
        ax.set_title(f"A/H = {ratio:g}: {res.amplitude_error_pct:+.1f} %", fontsize=9)
        ax.set_xlabel("t - t_crest (s)", fontsize=8)
        ax.tick_params(labelsize=7)
        ax.grid(alpha=0.3)
    axes[0][0].set_ylabel("eta / H at x = 1.2 m", fontsize=8)
    axes[0][0].legend(fontsize=7, loc="upper right")
    fig.suptitle(f"Solitary wave at x = 1.2 m, l0 = {label} m (crests aligned)", fontsize=9)
    fig.tight_layout()
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=90)
    plt.close(fig)


def plot_gauges(paths: dict[float, Path], label: str, out: Path) -> None:
    """Every gauge's eta(t) / A per case: the wave along the tank and inside the sponge."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    n = len(paths)
    fig, axes = plt.subplots(n, 1, figsize=(7.0, 1.9 * n), squeeze=False, sharex=True)
    for ax, (ratio, path) in zip(axes[:, 0], sorted(paths.items()), strict=True):
        with h5py.File(path, "r") as h5:
            names = sorted(
                (k for k in h5["probes"] if k.startswith("gauge_")),
                key=lambda k: float(k.split("_")[1]),
            )
            for i, name in enumerate(names):
                g = h5["probes"][name]
                ax.plot(
                    g["time"][:],
                    g["value"][:] / (ratio * DEPTH),
                    lw=0.8,
                    color=f"C{i}",
                    label=f"x = {name.split('_')[1]} m",
                )
        ax.axhline(0.0, color="k", lw=0.4)
        ax.set_ylabel(f"eta / A\nA/H = {ratio:g}", fontsize=8)
        ax.tick_params(labelsize=7)
        ax.grid(alpha=0.3)
    axes[0, 0].legend(fontsize=6, ncol=4, loc="upper left")
    axes[-1, 0].set_xlabel("t (s)", fontsize=8)
    fig.suptitle(f"Wave gauges, l0 = {label} m (sponge from x = 2.0 m)", fontsize=9)
    fig.tight_layout()
    fig.savefig(out, dpi=80)
    plt.close(fig)


def print_table(rows: list[CaseResult]) -> None:
    head = (
        f"{'A/H':>4} {'status':>9} {'A_meas/A-1':>10} {'rms 1st':>8} {'rms 3rd':>8} "
        f"{'c_meas':>7} {'vs c1':>7} {'vs c3':>7} {'refl':>6} {'setup':>6} {'sponge':>7} "
        f"{'steps':>6} "
        f"{'wall s':>7}"
    )
    print(head)
    for r in rows:
        print(
            f"{r.a_over_h:>4g} {r.status[:9]:>9} {r.amplitude_error_pct:>+9.2f}% "
            f"{r.rms_first_order_pct:>7.2f}% {r.rms_grimshaw_pct:>7.2f}% "
            f"{r.crest_speed_m_s:>7.4f} {r.speed_error_first_order_pct:>+6.2f}% "
            f"{r.speed_error_grimshaw_pct:>+6.2f}% {r.reflection_pct:>5.2f}% "
            f"{r.closed_tank_setup_pct:>5.2f}% "
            f"{r.sponge_max_pct:>6.2f}% {r.steps:>6d} {r.wall_time_s:>7.0f}"
        )


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--l0", default="0.004", help="particle spacing, m (default 0.004)")
    ap.add_argument("--ratios", default=",".join(f"{r:g}" for r in RATIOS), help="A/H list")
    case_runner.add_run_options(ap)
    ap.add_argument(
        "--sponge-scan",
        action="store_true",
        help="only the 1D long-wave model of the sponge over zones and rates: "
        "validation/results/sponge_long_wave_model.csv",
    )
    args = ap.parse_args(argv)
    if args.sponge_scan:
        rows = sponge_scan()
        out = RESULTS_DIR / "sponge_long_wave_model.csv"
        write_csv(rows, out)
        for row in rows:
            print(" ".join(f"{k}={v:.4g}" for k, v in asdict(row).items()))
        print(f"wrote {out.relative_to(ROOT)}")
        return 0
    l0 = float(args.l0)
    if not l0 > 0.0:
        ap.error(f"--l0 = {args.l0}: must be > 0")
    ratios = [float(r) for r in args.ratios.split(",")]
    for r in ratios:
        if not 0.0 < r < 0.78:
            ap.error(f"--ratios: A/H = {r} must lie in (0, 0.78) (a solitary wave breaks above)")
    spacing = spacing_for(l0)
    print(
        f"l0 = {l0:g} m -> {spacing:.7g} m: {round(DEPTH / l0)} layers over H = {DEPTH} m "
        f"(the lattice needs a whole number of layers in the depth)"
    )
    RESULTS_DIR.mkdir(parents=True, exist_ok=True)
    paths: dict[float, Path] = {}
    for r in ratios:
        out = case_path(args.l0, r)
        status = (
            read_status(out)
            if args.analyse_only
            else ensure_case(r, spacing, out, args.threads, args.retry_failed)
        )
        if case_runner.analysable(status):
            paths[r] = out
    rows = []
    for r, p in paths.items():
        try:
            rows.append(analyse(p))
        except (KeyError, ValueError) as exc:
            print(f"[A/H = {r:g}] {p.name}: cannot analyse ({exc})")
    if not rows:
        print("nothing to analyse")
        return 1
    csv_path = RESULTS_DIR / f"wave_tank_{args.l0}.csv"
    write_csv(rows, csv_path, CSV_COLUMNS)
    done = {r.a_over_h: paths[r.a_over_h] for r in rows if r.a_over_h in paths}
    plot_profiles(done, args.l0, FIGURES_DIR / f"solitary_eta_x1.2_{args.l0}.png")
    plot_gauges(done, args.l0, FIGURES_DIR / f"solitary_gauges_{args.l0}.png")
    print_table(rows)
    print(f"wrote {csv_path.relative_to(ROOT)} and docs/figures/solitary_*_{args.l0}.png")
    return 0 if all(r.status == "finished" for r in rows) else 1


if __name__ == "__main__":
    sys.exit(main())
