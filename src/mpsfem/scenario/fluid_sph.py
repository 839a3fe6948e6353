"""Schema of ``[fluid.sph]``: the numerical keys of the δ-SPH fluid (``fluid.method = "delta-sph"``).

The δ-SPH method owns this table, as MPS owns ``fluid.kernel``, ``fluid.pressure``,
``fluid.surface`` and ``fluid.collision``; ``FluidSection`` refuses a table of the other method
(docs/fluid_sph.md). Sources: Huang, Sun, Lyu & Zhong 2022 (the seed paper, δ-SPHC), Antuono et
al. 2010/2012 (δ-SPH).
"""

from __future__ import annotations

from typing import Literal

from pydantic import Field, model_validator

from mpsfem.scenario.base import InvalidValue, Point, Section

#: the keys that tune fluid.sph.shifting (read only with shifting != "none")
SHIFTING_KEYS = (
    "shifting_coefficient", "shifting_r", "shifting_n", "shifting_surface", "shifting_layer",
    "shifting_max", "shifting_density",
)  # fmt: skip


class DeltaSPHSection(Section):
    """δ-SPH numerics: kernel, equation of state, density diffusion, viscosity, integrator."""

    smoothing_ratio: float = Field(
        1.3,
        ge=1.0,
        le=2.5,
        description="alpha_s = h / spacing of the Wendland C2 kernel (support 2h); the seed "
        "paper uses 1.3 and 2.0",
    )
    gradient: Literal["corrected", "plain"] = Field(
        "corrected",
        description="pressure gradient: 'corrected', δ-SPHC's symmetric kernel-gradient-corrected "
        "form sum (p_i M_i + p_j M_j) grad W_ij V_j (seed eq. 12); 'plain', δ-SPH's sum (p_i + "
        "p_j) grad W_ij V_j (seed eq. 6)",
    )
    sound_speed: float | None = Field(
        None,
        gt=0.0,
        le=1e5,
        description="artificial sound speed c0, m/s (default: 10 max(reference_speed, sqrt(g H)), "
        "H the tallest fluid block; seed eq. 1)",
    )
    reference_speed: float | None = Field(
        None,
        ge=0.0,
        le=1e4,
        description="largest flow speed expected, m/s, for the default c0 (default: 2 sqrt(g H), "
        "the dam-break front speed of Ritter's solution)",
    )
    density_diffusion: float = Field(
        0.1,
        ge=0.0,
        le=1.0,
        description="delta of the density diffusion term delta h c0 D_i (seed eq. 2; 0 = off)",
    )
    viscosity_alpha: float = Field(
        0.02,
        ge=0.0,
        le=10.0,
        description="alpha of the artificial viscosity alpha h c0 (rho0 / rho_i) sum phi_ij "
        "grad W_ij V_j (seed eq. 3) outside damping zones (everywhere with damping = "
        "'sponge'); fluid-wall pairs carry none (free slip)",
    )
    viscosity_form: Literal["seed", "antuono"] = Field(
        "seed",
        description="how alpha maps to a viscosity: 'seed', eq. 3 as the seed prints it, with "
        "2 (n + 2) inside phi_ij: nu = alpha h c0 (today's default); 'antuono', the usual "
        "delta-SPH normalisation (Antuono et al. 2010, Marrone et al. 2011) without that factor: "
        "nu = alpha h c0 / (2 (n + 2)), 8 times less in 2D for the same alpha. The seed's own "
        "wave-tank results need the 'antuono' reading (docs/validation_delta_sph_wave_tank.md). "
        "Applies to viscosity_alpha and damping_alpha alike",
    )
    damping_alpha: float = Field(
        0.6,
        ge=0.0,
        le=100.0,
        description="alpha at the outer edge of each fluid.sponges zone: alpha = max("
        "viscosity_alpha, damping_alpha r), r rising 0 -> 1 across the zone (seed eq. 4; read "
        "only with damping = 'viscosity')",
    )
    damping: Literal["viscosity", "sponge"] = Field(
        "viscosity",
        description="what a fluid.sponges zone does under δ-SPH: 'viscosity', the seed's "
        "artificial-viscosity ramp up to damping_alpha (seed eq. 4; the zone's coefficient is "
        "unread; its viscous time-step limit makes the whole run about 3 times longer); "
        "'sponge', MPS's velocity damping u <- u (1 - dt alpha_s r) with the zone's "
        "coefficient alpha_s, once per step at its end (thesis eq. 3-9, "
        "fluid_mps.sponge.SpongeLayer; damping_alpha unread)",
    )
    integrator: Literal["rk4", "symplectic"] = Field(
        "rk4",
        description="time integrator: 'rk4', classical Runge-Kutta, four right-hand sides per "
        "step (the seed paper's); 'symplectic', kick-drift-kick leapfrog, one per step but a "
        "smaller stable Courant number (docs/fluid_sph.md)",
    )
    cfl: float | None = Field(
        None,
        gt=0.0,
        le=3.0,
        description="acoustic Courant number: dt <= cfl h / (c0 + u_max) (default 0.8 "
        "rk4, 0.1 symplectic); also dt <= 0.25 sqrt(h / a_max), the artificial viscosity's "
        "dt <= 0.15 h / (alpha_max c0) (0.1 symplectic) and fluid.time_step.dt_max",
    )
    max_mach: float = Field(
        0.5,
        gt=0.0,
        le=1.0,
        description="a run stops when the fastest fluid particle exceeds this fraction of c0 "
        "(weak compressibility is lost; raise sound_speed)",
    )
    central_field_omega: float = Field(
        0.0,
        ge=0.0,
        le=1e3,
        description="Omega, 1/s, of a central body force f = -Omega^2 (r - central_field_center) "
        "added to gravity (oscillating drop; 0 = off)",
    )
    central_field_center: Point | None = Field(
        None, description="centre of the central body force, m (default: the origin)"
    )
    structure_load: Literal["normal", "normal_pairs", "exchange"] = Field(
        "normal",
        description="pressure pair forces between the fluid and coupled structure members: "
        "'normal', the member receives at each interface point the pair exchange with its "
        "virtual particles projected on the face normal (a corner: on the face and end-cap "
        "normals), the end-cap part pushing only (free slip, no tension on a free end; "
        "docs/validation_delta_sph_coupled.md, 'Axial load'), while the fluid feels the whole "
        "pairs; 'normal_pairs', every pair projected and gated so for the fluid too: the member "
        "receives exactly what the fluid loses, but the fluid near a member's ends and along "
        "faces the pressure varies on loses the kernel's consistency (docs/fluid_sph.md, "
        "'Coupled to a structure'); 'exchange', the whole pair exchange on both sides (the "
        "behaviour before this key)",
    )
    wall_pressure: Literal["adami", "wetted", "clamped"] = Field(
        "adami",
        description="pressure of the wall and structure dummy particles: 'adami', extrapolated "
        "from every fluid neighbour, p_w = (sum p_f W + (g - a_w) . sum rho_f r_wf W) / sum W "
        "(Adami et al. 2012, eq. 27; across an air gap narrower than the kernel it is "
        "negative and pulls the wall and the free surface together); 'wetted', the same but "
        "zero on a dry wall: a pressure-layer particle whose fluid kernel sum sum W V_f is "
        "below that of a half-space 3/4 of a spacing beyond the wall face is dry (p_w = 0, and "
        "the fluid's own pressure is dropped from its pairs: it exchanges no force), one whose "
        "fluid reaches within 1/4 spacing of the face keeps Adami's pressure, linear in the sum "
        "between; dummy layers are as wet as their face (docs/fluid_sph.md, 'Walls'); "
        "'clamped', Adami's pressure floored at zero, p_w <- max(p_w, 0) (PySPH's "
        "ClampWallPressure): no wall pulls, the real suction of a wall pulled out of water "
        "included",
    )

    # ---- particle shifting (δ+-SPH; fluid_sph/particle_shifting.py, docs/fluid_sph.md)
    shifting: Literal["none", "delta_plus"] = Field(
        "none",
        description="particle shifting once per step, positions only: 'none' (the behaviour "
        "before this key); 'delta_plus', the δ+-SPH shift dr = -C CFL Ma (2h)^2 sum [1 + R "
        "(W_ij / W(l0))^n] grad W_ij V_j (Sun et al. 2017), none on the free surface, along "
        "the surface in the layer below it, wall and structure particles never shifted",
    )
    shifting_coefficient: float = Field(
        1.0,
        gt=0.0,
        le=10.0,
        description="C of the δ+-SPH shift (1 in Sun et al. 2017); CFL Ma (2h)^2 = 4 h U dt "
        "with U = reference_speed (default 2 sqrt(g H))",
    )
    shifting_r: float = Field(
        0.2,
        ge=0.0,
        le=1.0,
        description="R of the anti-clumping factor 1 + R (W_ij / W(l0))^n (Sun et al. 2017: 0.2)",
    )
    shifting_n: int = Field(
        4, ge=1, le=8, description="n of the anti-clumping factor (Sun et al. 2017: 4)"
    )
    shifting_surface: float = Field(
        0.6,
        ge=0.0,
        le=1.0,
        description="a fluid particle whose smallest eigenvalue lambda of the moment matrix B = "
        "sum (r_j - r_i) (x) grad W_ij V_j is below this is on the free surface and not "
        "shifted (lambda about 1 inside the fluid; on a lattice: 0.49 on a flat surface, 0.56 "
        "where it meets a wall, 0.90 / 0.70 one row below at h = 1.3 / 2.0 l0)",
    )
    shifting_layer: float = Field(
        0.75,
        ge=0.0,
        le=1.0,
        description="a fluid particle with lambda below this, or with a free-surface particle "
        "within its support, is shifted along the surface only, (I - n n) dr (0.75: Marrone "
        "et al. 2010's bound of the interior); above shifting_surface",
    )
    shifting_max: float = Field(
        0.1,
        gt=0.0,
        le=0.5,
        description="longest shift of one step, in particle spacings (a longer one is scaled back)",
    )

    shifting_density: Literal["keep", "taylor"] = Field(
        "keep",
        description="the density of a shifted particle: 'keep' (Sun et al. 2017: positions "
        "only); 'taylor', rho += dr . <grad rho> (the CSPM gradient; Lind et al. 2012), the "
        "density field at the new position to first order (mass and momentum unchanged)",
    )

    @model_validator(mode="after")
    def _check_shifting(self) -> DeltaSPHSection:
        if self.shifting == "none":
            given = [k for k in SHIFTING_KEYS if k in self.model_fields_set]
            if given:
                raise InvalidValue(
                    given[0],
                    "is read only with shifting = 'delta_plus'; shifting is 'none'",
                    getattr(self, given[0]),
                )
        elif self.shifting_layer <= self.shifting_surface:
            raise InvalidValue(
                "shifting_layer",
                f"must exceed shifting_surface = {self.shifting_surface}",
                self.shifting_layer,
            )
        return self
