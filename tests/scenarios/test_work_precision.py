"""validation/work_precision.py: the error metrics on known inputs, the case grid and its filter,
and the page and figure generated from a small synthetic CSV."""

import numpy as np
import pytest
from validation_script import load

wp = load("work_precision")
dam_break = load("dam_break")
plate_study = load("delta_sph_hydrostatic_plate")


def _ko():
    return dam_break.references()["Koshizuka & Oka 1996"]


def _lagged_ko(lag_s: float):
    """The experiment's curve itself, moved earlier by ``lag_s``: a simulation the experiment
    lags by exactly that much."""
    ref = _ko()
    T = np.linspace(0.0, 3.2, 641)
    Z = np.interp(T + lag_s * dam_break.T_SCALE, ref[:, 0], ref[:, 1])
    return T, Z


def test_dam_break_error_of_the_experiment_itself_is_zero():
    T = np.union1d(np.linspace(0.0, 3.2, 641), _ko()[:, 0])  # the experiment's points exactly
    Z = np.interp(T, _ko()[:, 0], _ko()[:, 1])
    e = wp.dam_break_errors(T, Z, _ko())
    assert e["error_raw"] < 1e-12
    assert e["error_shifted"] < 1e-4  # the bounded search stops within 1e-5 in T


def test_dam_break_shift_recovers_a_lag_within_the_30_ms_bound():
    T, Z = _lagged_ko(0.020)
    e = wp.dam_break_errors(T, Z, _ko())
    assert e["error_raw"] > 0.03  # 20 ms ahead is a visible error unshifted
    assert e["lag_ms"] == pytest.approx(20.0, abs=0.5)
    assert e["error_shifted"] < 0.1 * e["error_raw"]


def test_dam_break_shift_stops_at_30_ms():
    T, Z = _lagged_ko(0.060)
    e = wp.dam_break_errors(T, Z, _ko())
    assert e["lag_ms"] == pytest.approx(30.0, abs=0.5)  # the bound
    assert e["error_shifted"] > 0.02  # half the 60 ms lead is left


def test_dam_break_end_time_covers_the_metric_window():
    end = wp.dam_break_end_time()
    needed = _ko()[_ko()[:, 0] <= 3.0, 0].max() / dam_break.T_SCALE
    assert needed + wp.PROBE_INTERVAL <= end < needed + 0.01


def test_plate_error_of_a_decaying_oscillation_about_a_known_mean():
    t = np.arange(0.0, 0.2, 2e-4)
    mean = -plate_study.W_STATIC * 1.02  # 2 % too deep
    w = mean * (1.0 - np.exp(-t / 0.02) * np.cos(2 * np.pi * 145.0 * t))
    e = wp.plate_error(t, w)
    assert e["error"] == pytest.approx(0.02, abs=1e-3)
    assert e["mean_w_mid_m"] == pytest.approx(mean, rel=1e-3)
    assert 0.0 < e["error_noise"] < 0.005  # a decayed oscillation: its batch means agree


def test_plate_noise_grows_with_a_slow_wander_of_the_mean():
    t = np.arange(0.0, 0.2, 2e-4)
    steady = -plate_study.W_STATIC * np.ones_like(t)
    wander = steady * (1.0 + 0.05 * np.sin(2 * np.pi * t / 0.15))  # 5 % over the window
    assert wp.plate_error(t, steady)["error_noise"] == 0.0
    assert wp.plate_error(t, wander)["error_noise"] > 0.01


def test_dam_break_noise_is_the_spread_of_the_mps_realisations():
    # docs/figures/dam_break_front_sensitivity.csv: defaults 6.21 %, CG tolerances 4.65-5.68 %
    assert wp.dam_break_noise() == pytest.approx(0.0620952 - 0.0465047, abs=1e-6)


def test_case_grid_and_filter():
    cases = wp.all_cases("full", (1, 2), ())
    assert len(cases) == 2 * 2 * 3 * 2
    assert len({c.path for c in cases}) == len(cases)
    only = wp.all_cases("full", (1, 2), ("mps", "plate", "2"))
    assert [(c.method, c.case, c.threads) for c in only] == [("mps", "plate", 2)] * 3
    both = wp.all_cases("full", (1,), ("dam_break", "fine"))
    assert {c.method for c in both} == {"mps", "delta-sph"}
    assert {c.spacing for c in both} == {dam_break.L / 40}
    with pytest.raises(SystemExit, match="--only 'sph'"):
        wp.all_cases("full", (1,), ("sph",))


def _row(case, method, res, threads, error, cost, load=0.5, use=0.99):
    noise = 0.016 if case == "dam_break" else 0.001
    return {
        "error_noise": str(noise),
        "config": "full",
        "case": case,
        "method": method,
        "level": res,
        "resolution": res,
        "spacing_m": {"coarse": 3.0, "medium": 2.0, "fine": 1.0}[res],
        "threads": str(threads),
        "t_end_s": "0.24" if case == "dam_break" else "0.2",
        "status": "finished",
        "error": str(error),
        "error_raw": str(2 * error) if case == "dam_break" else "",
        "wall_per_sim_s": str(cost),
        "cpu_s": "10",
        "cpu_per_wall_thread": str(use),
        "load_start": str(load),
        "load_end": str(load),
        "cpu_count": "2",
        "particles": "100",
        "steps": "10",
    }


def _synthetic(load=0.5, use=0.99):
    rows = []
    for threads, speed in ((1, 1.0), (2, 0.6)):
        # dam break: MPS cheap, δ-SPH more accurate at its finest, dearer everywhere
        for res, e_m, c_m, e_d, c_d in (
            ("coarse", 0.08, 10, 0.09, 50),
            ("medium", 0.06, 40, 0.05, 300),
            ("fine", 0.055, 200, 0.03, 2000),
        ):
            rows.append(_row("dam_break", "mps", res, threads, e_m, c_m * speed, load, use))
            rows.append(_row("dam_break", "delta-sph", res, threads, e_d, c_d * speed, load, use))
        # plate: MPS both cheaper and more accurate at every level
        for res, e_m, c_m, e_d, c_d in (
            ("coarse", 0.01, 100, 0.02, 150),
            ("medium", 0.005, 150, 0.012, 200),
            ("fine", 0.003, 200, 0.008, 300),
        ):
            rows.append(_row("plate", "mps", res, threads, e_m, c_m * speed, load, use))
            rows.append(_row("plate", "delta-sph", res, threads, e_d, c_d * speed, load, use))
    rows.append({**_row("plate", "delta-sph", "fine", 1, 1, 1), "status": "failed: NaN"})
    return rows


def test_pareto_front_and_who_wins():
    rows = [r for r in _synthetic() if r["threads"] == "1"]
    dam = [r for r in rows if r["case"] == "dam_break"]
    strict = wp.pareto_front(wp.finished_rows(dam))
    assert [(r["method"], r["level"]) for r in strict] == [
        ("mps", "coarse"),
        ("mps", "medium"),
        ("mps", "fine"),
        ("delta-sph", "medium"),
        ("delta-sph", "fine"),
    ]
    # with the metric's noise as a tie, 5.5 and 5 % do not beat 6 %; 3 % does
    assert wp.noise(dam) == pytest.approx(0.016)
    with_tie = wp.pareto_front(wp.finished_rows(dam), wp.noise(dam))
    assert [(r["method"], r["level"]) for r in with_tie] == [
        ("mps", "coarse"),
        ("mps", "medium"),
        ("delta-sph", "fine"),
    ]
    text = wp.who_wins(dam)
    assert "MPS (coarse, medium) at 10-40 s/s, error 8-6 %; then δ-SPH (fine) at 2000 s/s" in text
    plate = wp.who_wins([r for r in rows if r["case"] == "plate"])
    assert plate.startswith("MPS wins over the whole measured range")
    assert wp.who_wins([r for r in rows if r["method"] == "mps"]).startswith("only MPS")


def test_page_and_figure_from_a_synthetic_csv(tmp_path):
    csv = tmp_path / "wp.csv"
    wp.write_csv(_synthetic(), csv, wp.COLUMNS)
    rows = wp.read_csv(csv)
    page, fig = tmp_path / "page.md", tmp_path / "wp.png"
    wp.write_report(rows, page, fig)
    text = page.read_text()
    assert fig.stat().st_size > 10_000
    assert "Generated by `validation/work_precision.py`" in text
    assert text.count("| dam break | MPS |") == 6
    assert "failed: NaN" in text
    assert "coupled hydrostatic plate, 2 threads: MPS wins over the whole measured range" in text
    assert "MPS dam break coarse 1.67" in text  # the two-thread speed-up, 1 / 0.6
    assert "| run to | 0.24 s" in text
    assert "| threads | 1, 2 (numba) |" in text
    assert "loaded machine" not in text
    assert "quiet enough" in text


@pytest.mark.parametrize("load, use", [(3.5, 0.99), (1.0, 0.6)])
def test_page_says_when_the_machine_was_loaded(load, use):
    text = wp.page(_synthetic(load, use))
    assert "**These timings come from a loaded machine**" in text
    assert "these verdicts are the pipeline's, not the study's" in text


def test_two_thread_runs_below_full_cpu_use_are_not_a_loaded_machine():
    rows = _synthetic()
    for r in rows:
        if r["threads"] == "2":
            r["cpu_per_wall_thread"] = "0.6"  # serial parts: normal on a quiet machine
    assert not wp.is_loaded(rows)


def test_errors_all_within_the_noise_make_it_a_cost_verdict():
    rows = [
        _row("plate", "mps", "coarse", 1, 0.010, 100),
        _row("plate", "delta-sph", "coarse", 1, 0.0105, 80),
        _row("plate", "mps", "fine", 1, 0.0102, 200),
    ]  # noise 0.001: the errors span 0.05 percentage points
    text = wp.who_wins(rows)
    assert text.startswith("every error lies within the noise")
    assert text.endswith("the cheapest run is δ-SPH coarse at 80 s/s.")


def test_estimate_covers_every_case_and_fits_the_budget():
    full = wp.all_cases("full", (1, 2), ())
    assert wp.estimate_seconds(full) + wp.WARMUP_S <= 15 * 60
    assert wp.estimate_seconds(wp.all_cases("reduced", (1, 2), ())) < wp.estimate_seconds(full)


def _results_file(path, probes: dict, **attrs):
    """A finished results file with ``probes`` ({name: (time, value)}) and the attributes the
    study reads."""
    import h5py

    with h5py.File(path, "w") as h5:
        for name, (t, v) in probes.items():
            h5[f"probes/{name}/time"] = t
            h5[f"probes/{name}/value"] = v
        h5.attrs.update(
            status="finished",
            wall_time=12.0,
            steps=300,
            stage_times=str({"neighbours": 2.0, "rhs": 6.0, "rhs_calls": 900.0}),
            wp_process_wall_s=16.0,
            wp_cpu_s=15.2,
            wp_attempts=1,
            wp_load_start=0.4,
            wp_load_end=1.1,
            wp_cpu_count=2,
        )
        for key, value in attrs.items():
            if key == "kind":
                h5["particles/00000/kind"] = value
            elif key == "iterations":
                h5["coupling/iterations"] = value
            else:
                h5.attrs[key] = value


def test_analyse_case_reads_a_dam_break_results_file(tmp_path, monkeypatch):
    monkeypatch.setattr(wp, "RUNS", tmp_path)
    case = wp.Case("mps", "dam_break", "medium", 20, 1, "full")
    T, Z = _lagged_ko(0.020)
    t = T / dam_break.T_SCALE
    kind = np.r_[np.zeros(800, np.int32), np.ones(300, np.int32)]
    _results_file(case.path, {"front": (t, Z * dam_break.L)}, kind=kind)
    row = wp.analyse_case(case)
    assert row["status"] == "finished"
    assert (row["particles"], row["fluid_particles"], row["steps"]) == (1100, 800, 300)
    assert row["lag_ms"] == pytest.approx(20.0, abs=0.5)
    assert row["error"] < 0.1 * row["error_raw"]
    assert row["wall_per_sim_s"] == pytest.approx(12.0 / wp.dam_break_end_time())
    assert row["fluid_stages_s"] == pytest.approx(8.0)  # call counts are not seconds
    assert row["cpu_per_wall_thread"] == pytest.approx(0.95)


def test_analyse_case_refuses_a_front_curve_short_of_the_metric_window(tmp_path, monkeypatch):
    monkeypatch.setattr(wp, "RUNS", tmp_path)
    case = wp.Case("delta-sph", "dam_break", "coarse", 10, 2, "full")
    T, Z = _lagged_ko(0.0)
    keep = T <= 2.5  # stops before Koshizuka & Oka's T = 2.719 point
    t = T[keep] / dam_break.T_SCALE
    _results_file(case.path, {"front": (t, Z[keep] * dam_break.L)}, kind=np.zeros(5, np.int32))
    row = wp.analyse_case(case)
    assert row["status"].startswith("front curve ends at T = 2.5")
    assert "error" not in row


def test_analyse_case_reads_a_plate_results_file(tmp_path, monkeypatch):
    monkeypatch.setattr(wp, "RUNS", tmp_path)
    case = wp.Case("delta-sph", "plate", "fine", 1 / 40, 2, "full")
    t = np.arange(0.0, 0.2 + 1e-9, 2e-4)
    w = -plate_study.W_STATIC * 0.99 * (1.0 - np.exp(-t / 0.01) * np.cos(900.0 * t))
    value = np.c_[np.zeros_like(w), w]
    _results_file(
        case.path, {"mid_deflection": (t, value)}, particles=5312, iterations=np.full(10, 2)
    )
    row = wp.analyse_case(case)
    assert row["error"] == pytest.approx(0.01, abs=5e-4)  # 1 % too shallow
    assert row["particles"] == 5312
    assert row["coupling_iterations_mean"] == 2.0
    assert row["wall_per_sim_s"] == pytest.approx(12.0 / 0.2)


def test_fresh_deletes_only_the_selected_runs(tmp_path, monkeypatch):
    monkeypatch.setattr(wp, "RUNS", tmp_path)
    chosen, other = wp.all_cases("full", (1, 2), ("mps", "coarse", "dam_break"))
    for c in (chosen, other):
        for suffix in (".h5", ".ckpt.h5", ".xdmf"):
            (tmp_path / f"{c.label}{suffix}").write_text("x")
    wp.delete_results([chosen])
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(
        f"{other.label}{s}" for s in (".h5", ".ckpt.h5", ".xdmf")
    )
