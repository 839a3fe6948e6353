"""Do the fluid's load terms make a time-discretisation instability for a near-massless member?

A one-degree-of-freedom model of a member coupled to δ-SPH, converged in every window (an
exact fixed point): a spring K with a tiny mass m_s, loaded by two parts of the fluid's load,
taken as the window-end load by the structure's integrator (Newmark average acceleration,
HHT-alpha, generalised-alpha; Chung & Hulbert 1993):

* the inertia Adami's wall pressure p_w = p_f + rho (g - a_w) . r puts there within a window,
  -m_d (w_n+1 - w_n) / T (the window's constant wall acceleration, w the velocity the fluid is
  given: the structure's, or the displacement rate (d_n+1 - d_n) / T);
* the weakly compressible fluid's push back, -k_f d, as the coupler samples it: its window
  mean (``coupling.force_sampling = "mean"``, the default; the wall moves linearly over the
  window, so the mean is -k_f (d_n + d_n+1) / 2) or its value at the window's end ("end").

It prints the spectral radius of the exact one-window amplification matrix of the state
(d, v, a, w, F): above 1 the converged coupled scheme itself would grow; near 1 a mode
survives for many windows. With the window mean, the member's displacement has the mode
d_n+1 = -k_f / (2 K + k_f) d_n: a period-two alternation that hardly decays where the fluid is
much stiffer than the member, whatever the structure's integrator (its own mass is too small
to matter).

    python benchmarks/adami_inertia_model.py

docs/validation_coupling_stress.md, "Elastic obstacle at mass ratio 1e-4".
"""

from __future__ import annotations

import numpy as np

from mpsfem.scenario.structure import StructureTime

MASS_RATIO = 0.029 / 10.0  # m_s / m_d: the obstacle at 1e-4 (0.029 kg/m^2) against ~10 kg/m^2


def parameters(scheme: str) -> tuple[float, float, float, float]:
    """(alpha_m, alpha_f, beta, gamma) of a scheme name: 'newmark', 'hht0.3' (hht_alpha =
    -0.3), 'ga0.0' (generalised-alpha, rho_inf = 0), as the structure solver takes them from
    ``structure.time`` (:class:`mpsfem.scenario.structure.StructureTime`)."""
    if scheme == "newmark":
        t = StructureTime(dt=1.0)
    elif scheme.startswith("hht"):
        t = StructureTime(dt=1.0, scheme="hht", hht_alpha=-float(scheme[3:]))
    else:
        t = StructureTime(dt=1.0, scheme="generalized_alpha", rho_inf=float(scheme[2:]))
    return t.alpha_m, t.alpha_f, t.beta, t.gamma


def step(
    x: np.ndarray,
    wt: float,
    scheme: str,
    rate: bool,
    kf: float = 0.0,
    sampling: str = "mean",
    md: float = 1.0,
) -> np.ndarray:
    """One window (T = 1) of the linear model from state x = (d, v, a, w, F): K = wt^2 (with
    m_d = 1, wt = omega T), fluid stiffness kf sampled as ``sampling``."""
    am, af, beta, gamma = parameters(scheme)
    K, ms = wt * wt, MASS_RATIO * md
    d, v, a, w, F = x

    def window(d1: float) -> tuple[float, ...]:
        a1 = (d1 - d - v - (0.5 - beta) * a) / beta  # Newmark, T = 1
        v1 = v + (1.0 - gamma) * a + gamma * a1
        w1 = d1 - d if rate else v1
        F1 = -md * (w1 - w) - kf * (0.5 * (d + d1) if sampling == "mean" else d1)
        r = ms * ((1 - am) * a1 + am * a) + K * ((1 - af) * d1 + af * d) - ((1 - af) * F1 + af * F)
        return r, a1, v1, w1, F1

    r0, r1 = window(0.0)[0], window(1.0)[0]  # the equation is affine in d1
    d1 = -r0 / (r1 - r0)
    _, a1, v1, w1, F1 = window(d1)
    return np.array([d1, v1, a1, w1, F1])


def spectral_radius(wt: float, scheme: str, rate: bool, **fluid: float | str) -> float:
    A = np.column_stack([step(e, wt, scheme, rate, **fluid) for e in np.eye(5)])
    return float(np.max(np.abs(np.linalg.eigvals(A))))


def main() -> None:
    wts = [0.1, 0.5, 1.0, 2.0, 4.0, 10.0, 100.0]
    print("spectral radius of one window; columns omega T =", wts)
    for scheme in ("newmark", "hht0.3", "ga0.8", "ga0.0"):
        for rate in (False, True):
            radii = [spectral_radius(wt, scheme, rate) for wt in wts]
            label = f"{scheme:8s} {'displacement_rate' if rate else 'structure':18s}"
            print(label, " ".join(f"{r:6.3f}" for r in radii))
    ratios = [0.1, 1.0, 10.0, 100.0, 1e3, 1e4]
    print("\nwith the fluid's stiffness k_f (K = 1, m_d = 1e-3); columns k_f / K =", ratios)
    for scheme in ("newmark", "hht0.3", "ga0.0"):
        for sampling in ("mean", "end"):
            radii = [
                spectral_radius(1.0, scheme, False, kf=kf, sampling=sampling, md=1e-3)
                for kf in ratios
            ]
            print(f"{scheme:8s} {sampling:18s}", " ".join(f"{r:6.4f}" for r in radii))


if __name__ == "__main__":
    main()
