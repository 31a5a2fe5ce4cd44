"""Blind benchmark scoring (mrhyst.blind.scoring, .tradeoff): the score counts what it says (strict, fair, false
alarms, open world, compound), refuses a case not in the key, and replays a policy over thresholds. Split from
test_blind.py (which keeps the cases, the key's isolation and the command line) to keep modules under 600 lines."""

import json

import pytest
from mrhyst import blind
from mrhyst.data import io


# ---------------------------------------------------------------- scoring
def _fake(tmp_path, rows, cfg):
    key = {"cases": {}}
    paths = []
    for i, (truth, pred, amb, det, equiv) in enumerate(rows):
        cid = f"case_{i:03d}"
        key["cases"][cid] = {"class": truth, "detectable": det, "equivalent_to": equiv, "noise_sigma_T": 1.5e-4,
                             "sigma_eff_T": 1.5e-4, "rms_left_T": 1e-4, "n_over_le": 3000.0,
                             "size_param": None if truth == "none" else "x",
                             "size_value": None if truth == "none" else 1.0}
        diag = {"effect": pred, "ambiguous_with": amb, "rms_before_T": 3e-4, "rms_after_T": 1.6e-4,
                "noise_floor_T": 1.5e-4, "effect_size": {"param": "x", "value": 1.1, "stderr": 0.05}}
        io.write_json(diag, tmp_path / f"{cid}.json")
        paths.append(tmp_path / f"{cid}.json")
    io.write_json(key, tmp_path / "key.json")
    return blind.score(paths, tmp_path / "key.json", cfg)


def test_score_counts_strict_fair_and_false_alarms(tmp_path, small):
    cfg = dict(small, classes=["none", "hall_offset", "remanent_start"])
    rows = [
        ("none", "none", [], False, []),                      # right
        ("none", "hall_offset", [], False, []),               # false alarm
        ("hall_offset", "hall_offset", [], True, []),         # right
        ("hall_offset", "none", [], False, []),               # absorbed: fair, not strict
        ("hall_offset", "none", [], True, []),                # detectable and missed
        ("remanent_start", "hall_offset", ["remanent_start"], True, ["hall_offset"]),  # equivalent, said so
        ("remanent_start", "hall_offset", [], True, ["hall_offset"]),  # equivalent, but not said: wrong
    ]
    s = _fake(tmp_path, rows, cfg)
    o = s["overall"]
    assert o["n"] == 7
    assert o["top1_strict"] == pytest.approx(2 / 7)
    assert o["top1_fair"] == pytest.approx(4 / 7)
    assert o["false_alarm_none"] == pytest.approx(0.5)
    assert o["top1_detectable"] == pytest.approx(1 / 4)
    assert s["confusion"]["remanent_start"]["hall_offset"] == 2
    assert s["per_class"]["hall_offset"]["size_ratio_median"] == pytest.approx(1.1)
    assert o["residual_within_factor"] == 1.0  # 1.6e-4 <= 1.5 x 1.5e-4
    assert len(s["misses"]) == 3
    assert s["strict_misses"] == {"none_on_undetectable": 1, "none_on_detectable": 1, "other_flagged_ambiguous": 1,
                                  "other_unflagged": 2,
                                  "pairs": {"none -> hall_offset": 1, "remanent_start -> hall_offset": 2}}


def _fake_open(tmp_path, rows, cfg):
    """rows: (class, kind, members, detectable, vocab_closes, diagnosis fields)."""
    key = {"cases": {}}
    paths = []
    for i, (cls, kind, members, det, closes, diag) in enumerate(rows):
        cid = f"case_{i:03d}"
        key["cases"][cid] = {"class": cls, "kind": kind, "members": members, "detectable": det,
                             "vocab_closes": closes, "equivalent_to": [], "noise_sigma_T": 1.5e-4,
                             "sigma_eff_T": 1.5e-4, "rms_left_T": 1e-3, "n_over_le": 3000.0}
        io.write_json(dict({"ambiguous_with": [], "rms_before_T": 1e-3, "rms_after_T": 5e-4,
                            "noise_floor_T": 1.5e-4}, **diag), tmp_path / f"{cid}.json")
        paths.append(tmp_path / f"{cid}.json")
    io.write_json(key, tmp_path / "key.json")
    return blind.score(paths, tmp_path / "key.json", cfg)


def test_score_open_world_and_compound_measures(tmp_path, small):
    cfg = dict(small, classes=["preisach", "leakage", "hall_offset+eddy_lag"])
    pair = ["hall_offset", "eddy_lag"]
    rows = [
        ("preisach", "openworld", [], True, [], {"effect": "thermal_drift"}),          # false attribution
        ("preisach", "openworld", [], True, [], {"effect": "model_form"}),             # right, model form
        ("preisach", "openworld", [], True, [], {"effect": "unexplained"}),            # right
        ("leakage", "openworld", [], True, ["hall_offset"], {"effect": "hall_offset"}),  # false, but mimicked
        ("leakage", "openworld", [], False, [], {"effect": "none"}),                   # no gap: none is right
        ("hall_offset+eddy_lag", "compound", pair, True, [], {"effect": "eddy_lag"}),  # one of pair
        ("hall_offset+eddy_lag", "compound", pair, True, [],                          # both (secondary)
         {"effect": "hall_offset", "secondary": {"effect": "eddy_lag", "accepted": True}}),
        ("hall_offset+eddy_lag", "compound", pair, True, [],                          # secondary not accepted
         {"effect": "hall_offset", "secondary": {"effect": "eddy_lag", "accepted": False}}),
        ("hall_offset+eddy_lag", "compound", pair, True, [], {"effect": "air_gap"}),   # neither
    ]
    s = _fake_open(tmp_path, rows, cfg)
    w, c = s["open_world"], s["compound"]
    assert (w["n"], w["n_gap"]) == (5, 4)
    assert w["false_attribution"] == pytest.approx(2 / 4) and w["model_form_recall"] == pytest.approx(1 / 4)
    assert w["false_attribution_unmimicked"] == pytest.approx(1 / 3)
    assert w["right"] == pytest.approx(3 / 5) and w["falsely_named"] == {"hall_offset": 1, "thermal_drift": 1}
    assert c["n"] == 4 and c["one_of_pair"] == pytest.approx(3 / 4) and c["both_named"] == pytest.approx(1 / 4)
    assert s["per_class"]["preisach"]["false_attribution"] == pytest.approx(1 / 3)
    assert s["per_class"]["hall_offset+eddy_lag"]["kind"] == "compound"
    assert s["overall"]["n"] == 0 and "model_form" in s["labels"]


def test_named_effects_reads_every_secondary_form():
    assert blind.named_effects({"effect": "a", "secondary": {"effect": "b", "accepted": True}}) == ["a", "b"]
    assert blind.named_effects({"effect": "a", "secondary": {"effect": "b", "accepted": False}}) == ["a"]
    assert blind.named_effects({"effect": "a", "secondary": [{"effect": "b"}, "c"]}) == ["a", "b", "c"]
    assert blind.named_effects({"effect": "a", "secondary": None, "effects": ["a", "d"]}) == ["a", "d"]


def test_tradeoff_curve_replays_a_policy_over_thresholds():
    """A toy policy: name the candidate with the lowest RMS when it is below close x sigma, else unexplained.
    A loose threshold names effects for out-of-vocabulary gaps; a strict one misses closed-world effects."""
    from mrhyst.blind import tradeoff

    def decide(ev, th):
        best = min(ev["rms"], key=ev["rms"].get)
        return {"effect": best} if ev["rms"][best] <= th["close"] * ev["sigma"] else "unexplained"

    keys = [{"id": "c1", "class": "hall_offset", "kind": "closed", "detectable": True, "equivalent_to": []},
            {"id": "c2", "class": "eddy_lag", "kind": "closed", "detectable": True, "equivalent_to": []},
            {"id": "o1", "class": "preisach", "kind": "openworld", "detectable": True, "members": []},
            {"id": "o2", "class": "leakage", "kind": "openworld", "detectable": True, "members": []},
            {"id": "x", "class": "none", "kind": "closed", "detectable": False, "equivalent_to": []}]
    ev = {"c1": {"rms": {"hall_offset": 1.0, "eddy_lag": 3.0}, "sigma": 1.0},
          "c2": {"rms": {"hall_offset": 3.0, "eddy_lag": 1.8}, "sigma": 1.0},
          "o1": {"rms": {"thermal_drift": 2.5}, "sigma": 1.0},
          "o2": {"rms": {"thermal_drift": 1.4}, "sigma": 1.0}, "x": None}
    grid = tradeoff.grid_product({"close": [1.2, 1.5, 2.0, 3.0]})
    cur = tradeoff.curve(keys, ev, decide, grid, base={"close": 2.0}, judge=blind.judge)
    pts = {p["thresholds"]["close"]: p for p in cur["points"]}
    assert cur["n_without_evidence"] == 1
    assert [pts[c]["closed_top1"] for c in (1.2, 1.5, 2.0, 3.0)] == [0.5, 0.5, 1.0, 1.0]
    assert [pts[c]["false_attribution"] for c in (1.2, 1.5, 2.0, 3.0)] == [0.0, 0.5, 0.5, 1.0]
    assert pts[2.0]["chosen"] and not pts[1.5]["chosen"]
    assert [pts[c]["pareto"] for c in (1.2, 1.5, 2.0, 3.0)] == [True, False, True, False]
    assert tradeoff.one_at_a_time({"close": 2.0, "name": "x"}, [0.5, 1.0, 2.0]) == [
        {"close": 2.0, "name": "x"}, {"close": 1.0, "name": "x"}, {"close": 4.0, "name": "x"}]


def test_score_refuses_a_case_not_in_the_key(tmp_path, small):
    io.write_json({"cases": {}}, tmp_path / "key.json")
    io.write_json({"effect": "none"}, tmp_path / "case_999.json")
    with pytest.raises(io.InputError, match="not in the key"):
        blind.score([tmp_path / "case_999.json"], tmp_path / "key.json", small)


def test_score_wires_a_policy_module_into_the_tradeoff(tmp_path, small, monkeypatch):
    """blind_score replays a policy (decide and its default thresholds; the diagnosis's own is
    mrhyst.diagnose.policy) on each diagnosis's evidence and marks the thresholds in use."""
    from mrhyst.blind import tradeoff
    from mrhyst.diagnose import policy

    assert tradeoff.load_policy() == (policy.decide, policy.DEFAULT_THRESHOLDS)
    base = {"close": 2.0, "strict": True}

    def decide(ev, th):
        return ev["best"] if ev["rms"] <= th["close"] else "unexplained"

    grid = tradeoff.policy_grid(dict(small, tradeoff={"grid": {}, "factors": [0.5, 1.0, 2.0]}), base)
    assert [g["close"] for g in grid] == [2.0, 1.0, 4.0] and all(g["strict"] for g in grid)
    cfg = dict(small, classes=["hall_offset", "preisach"])
    rows = [("hall_offset", "closed", ["hall_offset"], True, [], {"effect": "hall_offset",
                                                                  "evidence": {"best": "hall_offset", "rms": 1.5}}),
            ("preisach", "openworld", [], True, [], {"effect": "thermal_drift",
                                                    "evidence": {"best": "thermal_drift", "rms": 3.0}})]
    cfg = dict(cfg, tradeoff={"grid": {}, "factors": [0.5, 1.0, 2.0]})
    _fake_open(tmp_path, rows, cfg)
    s = blind.score(sorted(tmp_path.glob("case_*.json")), tmp_path / "key.json", cfg, policy=(decide, base))
    pts = {p["thresholds"]["close"]: p for p in s["tradeoff"]["points"]}
    assert (pts[1.0]["closed_top1"], pts[1.0]["false_attribution"]) == (0.0, 0.0)
    assert (pts[2.0]["closed_top1"], pts[2.0]["false_attribution"], pts[2.0]["chosen"]) == (1.0, 0.0, True)
    assert (pts[4.0]["closed_top1"], pts[4.0]["false_attribution"]) == (1.0, 1.0)
    # the diagnoses say which thresholds decided them: the curve is centred there and marks it
    for p in sorted(tmp_path.glob("case_*.json")):
        io.write_json(dict(json.loads(p.read_text()), policy={"thresholds": {"close": 1.0, "strict": True}}), p)
    s = blind.score(sorted(tmp_path.glob("case_*.json")), tmp_path / "key.json", cfg, policy=(decide, base))
    assert [(p["thresholds"]["close"], p["chosen"]) for p in s["tradeoff"]["points"]] == [
        (1.0, True), (0.5, False), (2.0, False)]
