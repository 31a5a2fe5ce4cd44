"""The diagnosis figure and the plain summaries (issue 26): byte-stable PNG, signatures drawn when present,
the gap parts from hand arithmetic, the CLI's --figure / --quiet."""

from __future__ import annotations

import copy
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from mrhyst.report import diagfig
from mrhyst.report.summary import diagnosis_summary, fit_summary, gap_parts, verdict_title

ROOT = Path(__file__).resolve().parents[1]


def _hand_diagnosis(signatures: bool = False) -> dict:
    """A diagnosis JSON written by hand (no fit): 40 samples up and down a loop, plain J-A off by a constant
    5 mT, the named hall_offset leaves 3 mT, noise 1 mT (so the measurement part is 4 mT: 3-4-5)."""
    n = 40
    H = np.concatenate([np.linspace(-100, 100, n // 2), np.linspace(100, -100, n // 2)])
    B = np.tanh(H / 40.0)
    region = ["asc_low"] * 10 + ["asc_high"] * 10 + ["desc_high"] * 10 + ["desc_low"] * 10
    d = {
        "effect": "hall_offset", "ambiguous_with": ["remanent_start"], "ambiguity_reason": "both move the start",
        "rms_before_T": 5e-3, "rms_after_T": 3e-3, "noise_floor_T": 1e-3, "partial": None, "model_form": None,
        "secondary": None, "verdict": "hall_offset: ...",
        "next_measurement": {"protocol": "bipolar", "separation_sigma": 12.0, "why": "..."},
        "where": {"region_order": ["asc_low", "asc_high", "desc_high", "desc_low"], "largest_share_before": "asc_low",
                  "regions": {r: {"share_before": s} for r, s in zip(
                      ["asc_low", "asc_high", "desc_high", "desc_low"], [0.4, 0.3, 0.2, 0.1])}},
        "input": {"kind": "bh", "raw": "nowhere.csv (loop_index 0)"},
        "series": {"current_A": H.tolist(), "B_T": B.tolist(), "B_before_T": (B - 5e-3).tolist(),
                   "B_after_T": (B - 3e-3).tolist(), "B_with_secondary_T": None, "valid": [1] * n, "region": region,
                   "time_s": None},
    }
    if signatures:
        d["signatures"] = [{"kind": "held_current_change", "size_T": 4e-3, "sigma": 9.5, "samples": [19, 20]},
                           {"kind": "loop_centre_offset", "size_T": 2e-3, "sigma": 3.1, "samples": [5]}]
    return d


def _png(d, tmp_path, name) -> bytes:
    p = tmp_path / name
    diagfig.save(d, p, name="hand")
    return p.read_bytes()


def test_gap_parts_from_hand_arithmetic():
    p = gap_parts(_hand_diagnosis())
    assert p["measurement_T"] == pytest.approx(4e-3, rel=1e-12)  # sqrt(5^2 - 3^2) mT
    assert p["measurement_named"] and p["measurement_what"] == "hall_offset"
    assert p["material_T"] is None and p["noise_T"] == 1e-3
    assert p["left_T"] == 3e-3 and p["left_over_noise"] == pytest.approx(3.0)
    assert p["source"] == "alone"


def test_gap_parts_take_the_layered_budget_when_present():
    d = _hand_diagnosis()
    d["budget"] = {"material_T": 2.5e-3, "measurement_T": 1.5e-3, "left_T": 1.2e-3}
    p = gap_parts(d)
    assert (p["material_T"], p["measurement_T"], p["left_T"], p["source"]) == (2.5e-3, 1.5e-3, 1.2e-3, "budget")
    assert p["left_over_noise"] == pytest.approx(1.2)


def test_partial_candidates_are_reported_as_not_named():
    d = _hand_diagnosis()
    d.update(effect="unexplained", rms_after_T=5e-3, ambiguous_with=[],
             partial={"effect": "sensor_saturation", "rms_after_T": 4e-3,
                      "model_form": {"best": "two_phase", "rms_after_T": 3e-3}},
             model_form={"best": "two_phase", "rms_after_T": 3e-3, "named": False})
    p = gap_parts(d)
    assert p["measurement_T"] == pytest.approx(3e-3) and not p["measurement_named"]  # sqrt(25 - 16)
    assert p["material_T"] == pytest.approx(4e-3) and not p["material_named"]  # sqrt(25 - 9)
    assert p["left_T"] == 5e-3
    text = diagnosis_summary(d)
    assert "verdict: unexplained" in text and "sensor_saturation explains 3 mT (not named)" in text


def test_summary_says_verdict_left_ambiguity_and_next_measurement():
    text = diagnosis_summary(_hand_diagnosis())
    lines = text.splitlines()
    assert lines[0] == "verdict: hall_offset (ambiguous with remanent_start)" == verdict_title(_hand_diagnosis())
    assert "left: 3 mT = 3.0x noise" in text and "asc_low" in text
    assert "next measurement: bipolar" in text and 4 <= len(lines) <= 8
    # a declared confound's measurement has no simulated separation (issue 23): said, not a crash
    d = dict(_hand_diagnosis(), next_measurement={"protocol": "saturating", "separation_sigma": None, "why": "w"})
    assert "next measurement: saturating" in diagnosis_summary(d)


def test_png_is_byte_stable_and_depends_on_the_input(tmp_path):
    d = _hand_diagnosis()
    a, b = _png(d, tmp_path, "a.png"), _png(copy.deepcopy(d), tmp_path, "b.png")
    assert a[:8] == b"\x89PNG\r\n\x1a\n" and a == b
    d2 = copy.deepcopy(d)
    d2["series"]["B_before_T"][7] -= 2e-3
    assert _png(d2, tmp_path, "c.png") != a


def _texts(fig) -> list[str]:
    return [t.get_text() for ax in fig.axes for t in ax.texts] + [t.get_text() for t in fig.texts]


def test_signatures_are_marked_when_the_json_has_them():
    plain = _texts(diagfig.draw(_hand_diagnosis(), "hand"))
    fig = diagfig.draw(_hand_diagnosis(signatures=True), "hand")
    texts = _texts(fig)
    assert not any("held_current_change" in t for t in plain)
    assert any(t.startswith("held_current_change 4 mT (9.5 sigma)") for t in texts)
    assert any(t.startswith("loop_centre_offset 2 mT") for t in texts)
    resid = fig.axes[1]
    marks = [ln for ln in resid.lines if ln.get_marker() == "D"]
    assert sorted(len(m.get_xdata()) for m in marks) == [1, 2]
    # the marks sit on the plain fit's residual at those samples: B - B_before = 5 mT everywhere
    assert all(np.allclose(m.get_ydata(), 5.0) for m in marks)


def test_title_is_the_verdict_and_budget_bars_are_in_mT():
    fig = diagfig.draw(_hand_diagnosis(), "hand")
    assert fig._suptitle.get_text() == "hand: verdict: hall_offset (ambiguous with remanent_start)"
    bars = [p.get_height() for p in fig.axes[2].patches]
    assert bars == pytest.approx([1.0, 0.0, 4.0, 3.0])  # noise, material (none), measurement, left in mT


def test_the_budgets_material_base_is_drawn_or_said_not_drawn():
    """M130-27s loop 2 (issue 26): panel 3 credited "base everett" while panel 1 drew only the two_phase model form.
    The base the budget names is drawn (a model form's curve: in 1 and its residual in 2) or said not drawn."""
    d = _hand_diagnosis()
    B = np.array(d["series"]["B_T"])
    d.update(effect="unexplained", rms_after_T=5e-3, ambiguous_with=[],
             partial={"effect": None, "model_form": {"best": "two_phase", "rms_after_T": 2e-3}},
             model_form={"best": "two_phase", "rms_after_T": 2e-3, "named": False},
             budget={"base": "everett", "material_T": 4.8e-3, "measurement_T": 0.0, "left_T": 1.4e-3},
             layers={"evidence": {"bases": {"everett": {"rms_T": 1.4e-3}}}})
    d["series"]["B_model_form_T"] = (B - 2e-3).tolist()
    assert diagfig.budget_base(d) == ("everett", None)
    fig = diagfig.draw(d, "hand")
    labels = [" ".join(t.get_text().split()) for t in fig.axes[0].get_legend().get_texts()]  # wrapped: joined
    assert any("not the budget's base" in t and "two_phase" in t for t in labels)
    assert any(t.startswith("budget's material base (3): everett, 1.4 mT (not drawn)") for t in labels)
    assert any("base everett" in t and "(not drawn in 1)" in t for t in _texts(fig))
    d["budget"]["base"] = "two_phase"  # the model form is the base: drawn in 1, its residual (2 mT) in 2
    assert diagfig.budget_base(d) == ("two_phase", "model_form")
    fig = diagfig.draw(d, "hand")
    labels = [" ".join(t.get_text().split()) for t in fig.axes[0].get_legend().get_texts()]  # wrapped: joined
    assert any("the budget's material base (3)" in t for t in labels) and not any("not drawn" in t for t in labels)
    base_res = [ln for ln in fig.axes[1].lines if ln.get_label() == "the budget's material base (two_phase)"]
    assert len(base_res) == 1 and np.allclose(base_res[0].get_ydata(), 2.0)
    assert any("(dash-dot in 1)" in t for t in _texts(fig))


def test_the_flexible_base_is_drawn_from_the_series_when_the_budget_credits_it(tmp_path):
    """M130-27s loop 2, Hiperco, ferrite L3 (issue 26): the budget's base is the flexible everett base; with its curve
    in the series (``B_everett_T``) panel 1 draws it and panel 2 its residual (here 1.4 mT everywhere)."""
    d = _hand_diagnosis()
    B = np.array(d["series"]["B_T"])
    d.update(effect="unexplained", rms_after_T=5e-3, ambiguous_with=[],
             budget={"base": "everett", "material_T": 4.8e-3, "measurement_T": 0.0, "left_T": 1.4e-3},
             layers={"evidence": {"bases": {"everett": {"rms_T": 1.4e-3}}}})
    d["series"]["B_everett_T"] = (B - 1.4e-3).tolist()
    assert diagfig.budget_base(d) == ("everett", "everett")
    fig = diagfig.draw(d, "hand")
    labels = [" ".join(t.get_text().split()) for t in fig.axes[0].get_legend().get_texts()]  # wrapped: joined
    assert not any("not drawn" in t for t in labels)
    drawn = [ln for ln in fig.axes[0].lines if "everett" in ln.get_label()]
    assert len(drawn) == 1 and np.allclose(drawn[0].get_ydata(), (B - 1.4e-3) * 1e3)
    res = [ln for ln in fig.axes[1].lines if ln.get_label() == "the budget's material base (everett)"]
    assert len(res) == 1 and np.allclose(res[0].get_ydata(), 1.4)
    assert any("base everett" in t and "(brown in 1)" in t for t in _texts(fig))
    assert any("5 mT -> 1.4 mT left on the material base everett (a Preisach model" in t for t in _texts(fig))
    a = _png(d, tmp_path, "a.png")
    assert a == _png(copy.deepcopy(d), tmp_path, "b.png")  # byte-stable with the base drawn
    d["series"]["B_everett_T"][3] += 5e-3  # and the base's curve is part of what the PNG shows
    assert _png(d, tmp_path, "c.png") != a


@pytest.mark.parametrize("worst", [1, 20, 38])
def test_no_legend_covers_the_largest_miss(worst):
    """after_001 (issue 26): the red "largest miss" label sat under panel 2's legend (fixed lower left). Wherever the
    largest miss is (start, middle, end of the path; below the rest), neither legend of panels 1-2 covers its circle
    or label, and the label stays inside the axes."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    d = _hand_diagnosis(signatures=True)
    d["series"]["B_before_T"][worst] += 12e-3  # B - B_before = 5 - 12 = -7 mT: the largest miss, at the bottom
    fig = diagfig.draw(d, "hand")
    r = FigureCanvasAgg(fig).get_renderer()
    for ax in fig.axes[:2]:
        leg = ax.get_legend().get_window_extent(r)
        marks = [a for a in [*ax.lines, *ax.texts] if a.get_gid() == diagfig.MISS]
        assert marks and not any(leg.overlaps(a.get_window_extent(r)) for a in marks)
    box, lab = fig.axes[1].get_window_extent(r), next(t for t in fig.axes[1].texts if t.get_gid() == diagfig.MISS)
    assert lab.get_text() == "largest miss -7 mT"
    e = lab.get_window_extent(r)
    assert box.x0 <= e.x0 and e.x1 <= box.x1 and box.y0 <= e.y0 and e.y1 <= box.y1


def test_panel_1_zooms_on_the_largest_miss():
    """A 7 mT miss on a loop 2000 mT high is invisible at the loop's scale (M130-27s loop 2: 38 mT on 3000 mT): panel
    1 has an inset whose window holds the sample, the data's B and plain J-A's B there, and no more than 2.5 misses
    either side; the inset covers neither the largest-miss circle nor the legend."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    d = _hand_diagnosis()
    d["series"]["B_before_T"][20] += 12e-3  # B - B_before = -7 mT at sample 20 (H = 100, B = tanh(2.5) T)
    fig = diagfig.draw(d, "hand")
    ax = fig.axes[0]
    (ins,) = ax.child_axes
    B, x = 1e3 * np.tanh(2.5), 100.0
    (x0, x1), (y0, y1) = ins.get_xlim(), ins.get_ylim()
    assert x0 < x < x1 and y0 < B < B + 7 < y1 and (y1 - y0) == pytest.approx(2 * 2.5 * 7)  # J-A: B + 7 mT
    r = FigureCanvasAgg(fig).get_renderer()
    box = ins.get_tightbbox(r)
    circle = next(ln for ln in ax.lines if ln.get_gid() == diagfig.MISS)
    assert not box.overlaps(circle.get_window_extent(r)) and not box.overlaps(ax.get_legend().get_window_extent(r))


def test_no_zoom_where_the_miss_shows_at_the_loops_scale():
    """A miss as large as the loop (a sensor mounted the other way round: B runs against the current) needs no zoom:
    its window would be larger than the panel, its frame and connector lines drawn across panels 1 and 2."""
    d = _hand_diagnosis()
    d["series"]["B_before_T"] = (-np.asarray(d["series"]["B_T"])).tolist()
    assert not diagfig.draw(d, "hand").axes[0].child_axes


def test_fit_summary_one_line():
    res = {"model": "anisotropic", "method": "lsm", "rms_T": 2e-3, "per_loop": [{"B_peak_T": 1.0}, {"B_peak_T": 0.5}],
           "model_choice": {"why": "lowest BIC"}}
    line = fit_summary(res, "F.json")
    assert "\n" not in line and "anisotropic (auto: lowest BIC)" in line and "0.2 % of peak" in line


def test_cli_diagnose_figure_summary_and_quiet(tmp_path, monkeypatch, capsys):
    """The CLI's wiring, in-process on the hand-made diagnosis: --figure writes the PNG the module draws, the
    summary goes to stdout, --quiet silences it."""
    from mrhyst import cli, diagnose

    monkeypatch.setattr(diagnose, "diagnose_bh_file", lambda *a, **k: _hand_diagnosis())
    src = tmp_path / "bh.csv"
    src.write_text("H_A_per_m,B_T\n0,0\n")
    args = ["diagnose", str(src), "--out", str(tmp_path / "d.json"), "--figure", str(tmp_path / "d.png")]
    assert cli.main(args) == 0
    assert capsys.readouterr().out == diagnosis_summary(_hand_diagnosis()) + "\n"
    diagfig.save(_hand_diagnosis(), tmp_path / "ref.png")
    assert (tmp_path / "d.png").read_bytes() == (tmp_path / "ref.png").read_bytes()
    assert cli.main(args[:2] + ["--out", str(tmp_path / "e.json"), "--quiet"]) == 0
    assert capsys.readouterr().out == "" and json.loads((tmp_path / "e.json").read_text())["effect"] == "hall_offset"


def test_cli_diagnose_real_sweep_end_to_end(tmp_path):
    raw = ROOT / "data" / "raw" / "li_gong_rig.csv"
    r = subprocess.run([sys.executable, "-m", "mrhyst", "diagnose", str(raw), "--sensor", "hall1", "--out",
                        str(tmp_path / "d.json"), "--figure", str(tmp_path / "d.png")],
                       capture_output=True, text=True, cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    d = json.loads((tmp_path / "d.json").read_text())
    assert r.stdout.splitlines()[0] == verdict_title(d)
    assert (tmp_path / "d.png").read_bytes()[:4] == b"\x89PNG"


def test_cli_starts_without_the_numerics():
    """`mrhyst --help` must not load numpy, pandas, numba, scipy, jsonschema or matplotlib (issue 26: start-up;
    timed in bench/bench_startup.py, never here)."""
    code = ("import sys; from mrhyst import cli; cli.build_parser().format_help(); "
            "print(sorted({m.split('.')[0] for m in sys.modules} & {'numpy', 'pandas', 'numba', 'scipy', "
            "'jsonschema', 'matplotlib'}))")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert r.returncode == 0 and r.stdout.strip() == "[]", r.stdout + r.stderr


# --------------------------------------------------------------------------------------------------
# reference mode (issue 24's diagnosis against a calibrated model, drawn since issue 26)
# --------------------------------------------------------------------------------------------------
def _hand_reference(effect: str = "air_gap") -> dict:
    """The hand diagnosis as reference mode writes it: the base is the reference model held, the named change's
    size in effect_size (air_gap: Nd), or each parameter's move (material_changed)."""
    d = _hand_diagnosis()
    d.update(mode="reference", effect=effect, ambiguous_with=[], next_measurement=None,
             reference={"source": "table1:group1_pso", "rms_T": 5e-3})
    d["input"] = {"kind": "hall", "source": "nowhere.csv"}
    if effect == "air_gap":
        d["effect_size"] = {"param": "Nd", "value": 8.1e-4, "stderr": 1.7e-5}
    else:
        moves = {n: {"reference": 1.0, "value": r, "ratio": r, "stderr": se, "z": (r - 1) / se, "significant": sig}
                 for n, r, se, sig in (("Ms", 0.96, 0.3, False), ("a", 1.0, 0.1, False), ("alpha", 0.0, 25.0, False),
                                       ("c", 1.3, 0.02, True), ("k", 1.0, 0.03, False))}
        d["effect_size"] = {"param": "params", "value": None, "stderr": None, "moved": ["c"], "moves": moves}
    return d


def test_reference_figure_names_the_reference_and_the_size(tmp_path):
    d = _hand_reference()
    a, b = _png(d, tmp_path, "r1.png"), _png(copy.deepcopy(d), tmp_path, "r2.png")
    assert a[:8] == b"\x89PNG\r\n\x1a\n" and a == b  # byte-stable like the ordinary figure
    fig = diagfig.draw(d, "hand")
    assert fig._suptitle.get_text() == "hand: verdict: air_gap (against the reference table1:group1_pso)"
    labels = fig.axes[0].get_legend_handles_labels()[1]
    assert "reference model (held): 5 mT RMS" in labels
    assert "reference + air_gap (Nd = 0.00081 +- 1.7e-05) (named): 3 mT" in labels
    # panel 3: the reference's RMS, the named change's, the floor (mT), and the size of the change
    assert [p.get_height() for p in fig.axes[2].patches] == pytest.approx([5.0, 3.0, 1.0])
    assert "Nd = 0.00081 +- 1.7e-05" in _texts(fig)


def test_reference_figure_shows_what_moved(tmp_path):
    fig = diagfig.draw(_hand_reference("material_changed"), "hand")
    ax = fig.axes[2]
    widths = {t.get_text().split("\n")[0]: p.get_width() for t, p in zip(ax.get_yticklabels(), ax.patches)}
    assert widths == pytest.approx({"Ms": -4.0, "a": 0.0, "alpha": -100.0, "c": 30.0, "k": 0.0})
    filled = [p.get_facecolor()[3] > 0 for p in ax.patches]
    assert filled == [False, False, False, True, False]  # only c moved significantly
    assert ax.get_xlim() == pytest.approx((-45.0, 45.0))  # spans the significant move, not alpha's stderr
    d = _hand_reference("material_changed")  # the RMS before and after, and what moved, in the panel itself
    assert ax.get_title(loc="left").endswith("\nRMS 5 -> 3 mT; moved: c")
    d["effect_size"]["moved"] = []
    title = diagfig.draw(d, "hand").axes[2].get_title(loc="left")
    assert title.endswith("\nRMS 5 -> 3 mT; none significant")


def test_cli_reference_mode_draws_the_figure(tmp_path):
    import yaml
    from mrhyst import rig
    from mrhyst.blind.cases import current_path
    from mrhyst.model import ja

    cur = current_path({"i_max_A": 2.0, "n_up": 27, "protocol": "bipolar2"})
    P0 = ja.as_param_array(yaml.safe_load((ROOT / "config.yaml").read_text())["paper"]["table1"]["group1"]["pso"])
    V, t, I, side = rig.simulate_case(P0, [("air_gap", {"Nd": 8e-4})], 1.5e-4, 3, cur, n_over_le=3026.4,
                                        dwell_s=0.1)
    raw = tmp_path / "gap.csv"
    rig.write_case(raw, V, t, I, side)
    r = subprocess.run([sys.executable, "-m", "mrhyst", "diagnose", str(raw), "--sensor", "hall1", "--reference",
                        "table1:group1_pso", "--config", str(ROOT / "config.yaml"), "--out", str(tmp_path / "d.json"),
                        "--figure", str(tmp_path / "d.png")], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    d = json.loads((tmp_path / "d.json").read_text())
    assert d["effect"] == "air_gap" and len(d["series"]["B_before_T"]) == len(I)
    assert abs(d["effect_size"]["value"] - 8e-4) < 0.1 * 8e-4  # the rig's truth
    assert (tmp_path / "d.png").read_bytes()[:4] == b"\x89PNG"
    assert r.stdout.splitlines()[0] == "verdict: air_gap (against the reference table1:group1_pso)"


def test_reference_summary_has_the_lines_of_a_diagnosis():
    """Reference mode gets the summary every diagnosis gets (issue 26), with the reference in place of plain J-A
    and the named change's size: the hand reference misses by 5 mT, the change leaves 3 mT (4 mT explained, the
    3-4-5 triangle), noise 1 mT, the largest share of the gap in asc_low."""
    d = _hand_reference()
    d["next_measurement"] = {"protocol": "a bipolar sweep at two sweep rates", "separation_sigma": None}
    assert diagnosis_summary(d).splitlines() == [
        "verdict: air_gap (against the reference table1:group1_pso)",
        "  the reference table1:group1_pso misses by 5 mT RMS; noise floor 1 mT (5.0x noise)",
        "  change: air_gap (Nd = 0.00081 +- 1.7e-05) explains 4 mT (named)",
        "  left: 3 mT = 3.0x noise; the largest share of the gap is in asc_low",
        "  next measurement: a bipolar sweep at two sweep rates"]
    moved = diagnosis_summary(_hand_reference("material_changed")).splitlines()
    assert moved[2] == "  change: material_changed (moved: c) explains 4 mT (named)"
    d.update(effect="none", rms_after_T=5e-3, effect_size=None, next_measurement=None)
    assert [x.split(":")[0] for x in diagnosis_summary(d).splitlines()] == [
        "verdict", "  the reference table1", "  left"]  # nothing explained: no change line


def test_reference_that_cannot_be_integrated_is_one_line_not_none(tmp_path):
    """M130-27s: a J-A set fitted to the 65 A/m loop hits a pole on the larger loop 2. The diagnosis used to say
    'none: predicts this sweep within its floor (RMS inf mT)'; now it is one line, exit 2, and no output."""
    loops = ROOT / "data" / "external" / "m130-27s-jamodel" / "loops.csv"
    ref, out, png = tmp_path / "m1.json", tmp_path / "d.json", tmp_path / "d.png"
    run = [sys.executable, "-m", "mrhyst"]
    r = subprocess.run(run + ["fit", str(loops), "--loop-index", "1", "--method", "lsm", "--start", "cyclic",
                              "--out", str(ref), "--quiet"], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    r = subprocess.run(run + ["diagnose", str(loops), "--loop-index", "2", "--reference", str(ref), "--out", str(out),
                              "--figure", str(png)], capture_output=True, text=True)
    assert r.returncode == 2 and "cannot be integrated along this sweep" in r.stderr
    assert len(r.stderr.strip().splitlines()) == 1 and not out.exists() and not png.exists()


def test_summary_names_a_declared_separator_and_every_other_confounds_separator():
    d = _hand_diagnosis()
    d["next_measurement"] = {"protocol": "repeat", "separation_sigma": None, "why": "w",
                             "also": [{"protocol": "long_dwell", "separates": ["eddy_lag", "model_form"],
                                       "separation_sigma": None, "why": "v"}]}
    text = diagnosis_summary(d)  # a null separation (a declared confound's, not simulated)
    assert "next measurement: repeat" in text
    assert "and long_dwell: separates eddy_lag from model_form" in text
