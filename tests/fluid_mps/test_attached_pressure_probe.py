"""Pressure probes that ride with a wall or member (``[[probes]] attach``).

Case: still water 0.3 m deep in a 0.3 m wide tank (l0 = 0.02 m) whose left side wall slides down
along itself at U = 0.2 m/s (after a 0.05 s constant-acceleration ramp): the water stays at rest
and hydrostatic, so a probe riding on the wall at reference height y0 reads
rho g (H - y0 + s(t)), s the wall's travel. Tolerance: half of rho g l0 for 0.025 s means (the
pressure layer stands for the wall face half a spacing away: its depth is known to l0/2); the
measured error is at most 0.34 rho g l0. Still wall: the riding probe is the fixed probe on the
same particles (bit-identical), and within 0.25 rho g l0 of the fixed probe that also averages
the adjacent fluid.

Interval averages (``average``, the default; ``probes.AttachedPressureLedger``: I = sum dt_n p_n,
a sample (I(t) - I(t_prev)) / (t - t_prev)). References: a constant pressure averages to itself
and a +A / -A step-to-step alternation to zero (exact identities, to rounding: 1e-12 relative);
in a run, coarse averaged samples times their intervals sum to the impulse of the every-step
instantaneous series (the same identity, 1e-12 relative); a run restarted from a checkpoint
taken between two samples continues bit for bit (the ledger is solver state)."""

from __future__ import annotations

from pathlib import Path
from types import SimpleNamespace

import h5py
import numpy as np
import pytest

from mpsfem.fluid_mps.probes import AttachedPressure, AttachedPressureLedger
from mpsfem.scenario.base import ScenarioError
from mpsfem.scenario.loader import load_scenario, load_scenario_text
from mpsfem.simulation import run_fluid

ROOT = Path(__file__).resolve().parents[2]
RHO, G, H, L0 = 1000.0, 9.81, 0.3, 0.02
U, RAMP = 0.2, 0.05  # wall speed (m/s), ramp time (s)

CASE = """
title = "a side wall sliding down along itself in still water"
[run]
end_time = 0.25
progress = false
[output]
probe_interval = 0
snapshot_interval = 0
checkpoint_interval = 0
[fluid]
dim = 2
spacing = 0.02
hydrostatic_start = true
gravity = [0.0, -9.81]
[fluid.time_step]
courant = 0.2
dt_max = 5e-4
[[fluid.blocks]]
lower = [0.0, 0.0]
upper = [0.3, 0.3]
[[fluid.walls]]
name = "floor"
shape = "box"
lower = [0.0, -0.1]
upper = [0.3, 0.0]
[[fluid.walls]]
name = "right"
shape = "box"
lower = [0.3, -0.1]
upper = [0.4, 0.4]
[[fluid.walls]]
name = "left"
shape = "box"
lower = [-0.1, -0.1]
upper = [0.0, 0.5]
[fluid.walls.motion]
kind = "{kind}"
direction = [0.0, -1.0]
{file}
[[probes]]
name = "riding"
kind = "pressure"
attach = "{attach}"
position = [{x}, 0.15]
radius = 0.03
[[probes]]
name = "fixed"
kind = "pressure"
position = [0.0, 0.15]
radius = 0.03
[[probes]]
name = "riding_one"
kind = "pressure"
attach = "left"
position = [-0.01, 0.15]
radius = 0.015
average = false
[[probes]]
name = "fixed_one"
kind = "pressure"
position = [-0.01, 0.15]
radius = 0.015
"""


def travel(t: np.ndarray) -> np.ndarray:
    """The wall's downward travel (m): constant acceleration to U over RAMP, then U."""
    return np.where(t < RAMP, 0.5 * U * t * t / RAMP, 0.5 * U * RAMP + U * (t - RAMP))


def scenario(tmp: Path, moving: bool, attach: str = "left", x: float = 0.0):
    rows = [(t, 0.5 * U * t * t / RAMP) for t in np.linspace(0.0, RAMP, 11)]
    rows.append((1.0, float(travel(np.array(1.0)))))
    (tmp / "ramp.csv").write_text("".join(f"{float(a)!r},{float(b)!r}\n" for a, b in rows))
    text = CASE.format(
        kind="table" if moving else "none",
        file='file = "ramp.csv"' if moving else "",
        attach=attach,
        x=x,
    )
    (tmp / "case.toml").write_text(text)
    return load_scenario(tmp / "case.toml")


def series(path: Path) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    with h5py.File(path, "r") as h5:
        return {n: (g["time"][()], g["value"][()]) for n, g in h5["probes"].items()}


@pytest.fixture(scope="module")
def moving(tmp_path_factory) -> dict:
    tmp = tmp_path_factory.mktemp("sliding")
    run_fluid(scenario(tmp, True), tmp / "out.h5")
    return series(tmp / "out.h5")


def test_riding_probe_reads_the_hydrostatic_pressure_at_its_moving_depth(moving):
    t, p = moving["riding"]
    y0 = 0.15  # the mean height of its particles at t = 0 (the lattice rows 0.13 .. 0.17)
    expected = RHO * G * (H - y0 + travel(t))
    assert p[0] == pytest.approx(RHO * G * (H - y0), rel=1e-9)  # the hydrostatic start
    errors = []
    for a in np.arange(RAMP, 0.25, 0.025):
        s = (t >= a) & (t < a + 0.025)
        errors.append(np.mean(p[s] - expected[s]) / (RHO * G * L0))
    print("WINDOW_ERRORS (rho g l0):", np.round(errors, 3))
    assert np.max(np.abs(errors)) < 1.0
    # it follows the wall: after two spacings of travel it reads > rho g l0 more than a probe
    # left at its starting point
    late = t > 0.2
    tf, pf = moving["fixed"]
    assert np.mean(p[late]) - np.nanmean(pf[tf > 0.2]) > RHO * G * L0


def test_still_wall_riding_probe_matches_the_fixed_probe(tmp_path):
    run_fluid(scenario(tmp_path, False), tmp_path / "out.h5")
    s = series(tmp_path / "out.h5")
    # the same single wall particle: identical
    np.testing.assert_array_equal(s["riding_one"][1], s["fixed_one"][1])
    # the wall's particles alone against the wall's and the adjacent fluid's
    diff = s["riding"][1] - s["fixed"][1]
    assert abs(np.mean(diff)) < 0.25 * RHO * G * L0


def test_unknown_attach_target_is_refused(tmp_path):
    with pytest.raises(ScenarioError, match=r"probes\[0\]\.attach.*'nowhere'"):
        scenario(tmp_path, True, attach="nowhere")


def test_point_off_the_wall_is_refused_before_the_run(tmp_path):
    sc = scenario(tmp_path, True, x=0.15)  # mid-tank: no wall particle within 0.03 m
    with pytest.raises(ValueError, match=r"probes\.riding\.position.*no pressure-layer"):
        run_fluid(sc, tmp_path / "out.h5")
    assert not (tmp_path / "out.h5").exists() or "probes/riding" not in h5py.File(
        tmp_path / "out.h5", "r"
    )


def test_member_faces_are_accepted_and_other_names_refused():
    text = (ROOT / "scenarios" / "plate_water_entry_2d.toml").read_text()
    sc = load_scenario_text(text).scenario
    assert {p.attach for p in sc.probes if p.kind == "pressure"} == {"plate-"}
    for bad in ("plateX", "plate", "tank+"):
        wrong = text.replace('attach = "plate-"', f'attach = "{bad}"', 1)
        if bad == "plate":  # a member's name (both faces) is allowed
            load_scenario_text(wrong)
            continue
        with pytest.raises(ScenarioError, match=r"attach"):
            load_scenario_text(wrong)


def ledger(average: bool = True) -> tuple[AttachedPressureLedger, np.ndarray]:
    """A ledger of one probe on the three wall particles 1..3 of a five-particle row."""
    pos = np.array([[0.0, 0.0], [1.0, 0.0], [2.0, 0.0], [3.0, 0.0], [9.0, 0.0]])
    kind = np.array([0, 1, 1, 1, 1], np.int8)
    patch = SimpleNamespace(name="w", start=1, stop=5)
    probe = SimpleNamespace(name="a", attach="w", position=[2.0, 0.0], radius=1.0, average=average)
    a = AttachedPressure(probe, [patch], pos, kind, 1.0)
    assert a.index.tolist() == [1, 2, 3]
    return AttachedPressureLedger({"a": a}), np.zeros(5)


def test_constant_pressure_reads_the_same_averaged_or_not():
    led, p = ledger()
    p[1:4] = 1234.5
    p[4] = -7.0e6  # a particle outside the probe: ignored
    assert led.sample("a", p, 0.0) == 1234.5  # the first sample: instantaneous
    t = 0.0
    for dt in (1e-4, 3e-4, 2.5e-4, 7e-5):
        led.accumulate(p, dt)
        t += dt
    assert led.sample("a", p, t) == pytest.approx(1234.5, rel=1e-12)
    assert led.impulse("a") == pytest.approx(1234.5 * t, rel=1e-12)
    assert led.sample("a", p, t) == 1234.5  # again at the same time: instantaneous


def test_alternating_pressure_averages_out_but_not_instantaneously():
    inst, _ = ledger(average=False)
    led, p = ledger()
    led.sample("a", p, 0.0)
    inst.sample("a", p, 0.0)
    t, amp, dt = 0.0, 5.0e4, 2e-4
    for n in range(10):  # five +A / -A pairs of equal steps
        p[1:4] = amp if n % 2 == 0 else -amp
        led.accumulate(p, dt)
        inst.accumulate(p, dt)
        t += dt
    assert abs(led.sample("a", p, t)) < 1e-12 * amp
    assert inst.sample("a", p, t) == -amp  # average = false: the last step's value


def test_average_false_needs_attach():
    text = scenario_text().replace('name = "fixed"\n', 'name = "fixed"\naverage = false\n', 1)
    with pytest.raises(ScenarioError, match=r"average.*attach"):
        load_scenario_text(text)


def scenario_text() -> str:
    return CASE.format(kind="none", file="", attach="left", x=0.0)


PROBES = """
[[probes]]
name = "coarse"
kind = "pressure"
attach = "left"
position = [0.0, 0.15]
radius = 0.03
interval = 0.01
[[probes]]
name = "every_step"
kind = "pressure"
attach = "left"
position = [0.0, 0.15]
radius = 0.03
interval = 0
average = false
"""


def sliding(tmp: Path, sets=()):
    loaded = scenario(tmp, True)
    text = loaded.text + PROBES
    return load_scenario_text(text, ["run.end_time=0.06", *sets], path=tmp / "case.toml")


def test_coarse_averages_integrate_to_the_every_step_impulse(tmp_path):
    run_fluid(sliding(tmp_path), tmp_path / "out.h5", log=lambda m: None)
    s = series(tmp_path / "out.h5")
    tc, pc = s["coarse"]
    tn, pn = s["every_step"]
    assert tc[-1] == tn[-1] == pytest.approx(0.06) and len(tn) > 10 * len(tc)
    impulse_coarse = np.sum(np.diff(tc) * pc[1:])
    impulse_steps = np.sum(np.diff(tn) * pn[1:])  # I = sum dt_n p(t_n), the step's end pressure
    assert impulse_coarse == pytest.approx(impulse_steps, rel=1e-12)
    # the averages are not the instantaneous samples at the same times (the signal varies)
    at = np.searchsorted(tn, tc[1:])
    assert np.max(np.abs(pc[1:] - pn[at])) > 0.0


def test_restart_between_samples_is_bit_identical(tmp_path, monkeypatch):
    """Restart from the run's own checkpoint at ~0.025 s, between the coarse probe's samples at
    0.02 and 0.03 s (kept aside as it is written): the resumed run, which drops the samples
    after it (truncate_after), takes them again bit for bit."""
    import shutil

    from mpsfem import simulation
    from mpsfem.results.checkpoint import read_checkpoint

    write = simulation.write_checkpoint
    kept = tmp_path / "first.ckpt.h5"

    def keep_first(path, *args, **kwargs):
        out = write(path, *args, **kwargs)
        if not kept.exists():
            shutil.copy(out, kept)
        return out

    monkeypatch.setattr(simulation, "write_checkpoint", keep_first)
    sets = ["output.checkpoint_interval=0.025"]
    full, part = tmp_path / "full.h5", tmp_path / "part.h5"
    run_fluid(sliding(tmp_path, sets), full, log=lambda m: None)
    shutil.copy(full, part)
    run_fluid(sliding(tmp_path, sets), part, restart=kept, log=lambda m: None)
    a, b = series(full), series(part)
    arrays, meta, _ = read_checkpoint(kept)
    t_ckpt = meta["fluid"]["t"]
    assert 0.025 <= t_ckpt < 0.03
    # rows (I, t, I(t)) at the last sample of the attached probes in scenario order: riding,
    # riding_one (every step), coarse
    coarse = arrays["fluid"]["attached_pressure"][2]
    assert coarse[1] == pytest.approx(0.02) and coarse[0] > coarse[2] > 0.0
    for name in ("coarse", "every_step"):
        assert a[name][0].tobytes() == b[name][0].tobytes()
        assert a[name][1].tobytes() == b[name][1].tobytes()


def test_riding_probe_under_delta_sph_reads_the_hydrostatic_pressure(tmp_path):
    """The same still-wall case with fluid.method = "delta-sph": the δ-SPH solver books the
    attached probes' ledger too (a riding probe used to stop the run with an AttributeError).
    Tolerance rho g l0, as for MPS: the wall's pressure layer stands for the face l0/2 away."""
    scenario(tmp_path, False)  # writes case.toml
    text = (tmp_path / "case.toml").read_text()
    text = text.replace("[fluid]\ndim = 2", '[fluid]\nmethod = "delta-sph"\ndim = 2')
    text = text.replace("end_time = 0.25", "end_time = 0.1")
    (tmp_path / "sph.toml").write_text(text)
    sc = load_scenario(tmp_path / "sph.toml")
    run_fluid(sc, tmp_path / "sph.h5")
    t, p = series(tmp_path / "sph.h5")["riding"]
    late = t >= 0.05
    assert late.any()
    expected = RHO * G * (H - 0.15)
    assert np.all(np.abs(p[late] - expected) <= RHO * G * L0), (p[late], expected)
