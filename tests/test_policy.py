"""The selection policy (mrhyst.diagnose.policy) as a pure function: hand-built statistics -> verdict,
no fitting. Each case states the physics of the rule it pins (issue 12's evidence rule)."""

import copy

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from mrhyst.diagnose import policy

SIG = 1.5e-4  # noise floor (T)


def cand(e, rms, delta_bic, bic, cv=None, blocks=None, held=None, plausible=True):
    return {"effect": e, "n_params": 6, "rms_T": rms, "bic": bic, "delta_bic": delta_bic, "cv_interleaved_T": cv,
            "cv_blocks_T": blocks, "heldout_T": held, "plausible": plausible, "params": {}}


def evidence(**cands):
    """Plain J-A leaves 4 sigma; every candidate given by keyword."""
    none = {"rms_T": 4 * SIG, "bic": -800.0, "cv_interleaved_T": 4.2 * SIG, "cv_blocks_T": 5 * SIG,
            "heldout_T": 6 * SIG}
    return {"n": 53, "noise_floor_T": SIG, "none": none, "candidates": cands, "pairs": [], "model_form": {}}


def good(e="eddy_lag", **kw):
    args = dict(rms=1.0 * SIG, delta_bic=120.0, bic=-920.0, cv=1.1 * SIG, blocks=1.3 * SIG, held=1.4 * SIG)
    args.update(kw)
    return cand(e, **args)


def test_a_closing_predicting_plausible_effect_is_named():
    v = policy.decide(evidence(eddy_lag=good(), hall_offset=cand("hall_offset", 3.9 * SIG, 1.0, -801.0)))
    assert v["effect"] == "eddy_lag" and v["partial"] is None
    assert all(v["checks"].values())


def test_no_earner_and_a_small_gap_is_none():
    ev = evidence(hall_offset=cand("hall_offset", 1.1 * SIG, 2.0, -802.0))
    ev["none"]["rms_T"] = 1.2 * SIG
    assert policy.decide(ev)["effect"] == "none"


def test_an_effect_that_leaves_the_gap_open_is_not_named():
    """(a): thermal_drift earns its BIC margin but leaves 3x the floor: unexplained, with partial."""
    ev = evidence(thermal_drift=good("thermal_drift", rms=3 * SIG, delta_bic=30.0, bic=-830.0, cv=3.1 * SIG))
    v = policy.decide(ev)
    assert v["effect"] == "unexplained"
    assert v["partial"]["effect"] == "thermal_drift" and "closes" in v["partial"]["failed"]
    assert 0 < v["partial"]["excess_removed_frac"] < 1


def test_an_effect_that_predicts_held_out_data_worse_is_not_named():
    """(b): the branch hold-out (fit ascending, predict descending) 30x plain J-A's, or the contiguous-block CV
    worse than plain J-A's: not named."""
    ev = evidence(eddy_lag=good(held=30 * 6 * SIG))
    v = policy.decide(ev)
    assert v["effect"] == "unexplained" and "predicts_branch" in v["partial"]["failed"]
    ev = evidence(eddy_lag=good(blocks=5.5 * SIG))
    assert "predicts_blocks" in policy.decide(ev)["partial"]["failed"]


def test_most_blocks_predicted_better_pass_even_when_one_extrapolated_block_rules_the_pooled_rms():
    """(b) with blocks_majority: per-block RMS, plain J-A [0.77, 0.50, 1.13, 0.63, 1.29] sigma units; a true lag
    predicts four blocks 2-3x better and the last (the end of the descending branch) 2x worse, so its pooled RMS
    is above plain's; a mimic wins one block only. Pooled RMS sqrt(mean of squares), computed here."""
    plain = np.array([0.77, 0.50, 1.13, 0.63, 1.29]) * SIG
    lag = np.array([0.28, 0.27, 0.40, 0.31, 2.76]) * SIG
    mimic = np.array([0.85, 0.40, 1.20, 0.70, 1.40]) * SIG
    pooled = lambda f: float(np.sqrt(np.mean(f ** 2)))  # noqa: E731
    assert pooled(lag) > pooled(plain) and pooled(mimic) > pooled(plain)  # both fail the pooled rule

    def ev_with(folds):
        ev = evidence(eddy_lag=dict(good(blocks=pooled(folds)), cv_blocks_folds_T=list(folds)))
        ev["none"] = dict(ev["none"], cv_blocks_T=pooled(plain), cv_blocks_folds_T=list(plain))
        return ev

    assert policy.decide(ev_with(lag))["effect"] == "eddy_lag"
    assert policy.decide(ev_with(lag), {"blocks_majority": False})["effect"] == "unexplained"
    v = policy.decide(ev_with(mimic))
    assert v["effect"] == "unexplained" and "predicts_blocks" in v["partial"]["failed"]
    # evidence saved before the per-block errors were recorded: the pooled rule alone
    ev = ev_with(lag)
    del ev["candidates"]["eddy_lag"]["cv_blocks_folds_T"]
    assert policy.decide(ev)["effect"] == "unexplained"


def test_the_branch_hold_out_does_not_judge_an_effect_one_branch_cannot_determine():
    """A drift rate cannot be told from J-A's shape on the ascending branch alone: the registry says so, and
    the policy then judges it by the contiguous blocks only."""
    c = good("thermal_drift", held=50 * 6 * SIG)
    c["branch_identifiable"] = False
    assert policy.decide(evidence(thermal_drift=c))["effect"] == "thermal_drift"
    c["cv_blocks_T"] = 6 * SIG
    assert policy.decide(evidence(thermal_drift=c))["effect"] == "unexplained"


def test_an_implausible_size_is_not_named_unless_the_check_is_off():
    """(c): a drift larger than the sensor's quiescent tolerance allows."""
    ev = evidence(thermal_drift=good("thermal_drift", plausible=False))
    assert policy.decide(ev)["effect"] == "unexplained"
    assert policy.decide(ev, {"require_plausible": False})["effect"] == "thermal_drift"


def test_model_form_that_closes_the_gap_is_named_instead():
    mf = {"name": "two_phase", "n_params": 10, "rms_T": 1.05 * SIG, "bic": -900.0, "delta_bic": 100.0,
          "cv_interleaved_T": 1.2 * SIG, "cv_blocks_T": 1.5 * SIG, "heldout_T": 2 * SIG}
    ev = evidence(thermal_drift=good("thermal_drift", rms=2.5 * SIG, delta_bic=40.0, bic=-840.0))
    ev["model_form"] = {"two_phase": mf}
    v = policy.decide(ev)
    assert v["effect"] == "model_form" and v["model_form"] == "two_phase"
    assert v["partial"]["effect"] == "thermal_drift"


def test_an_effect_must_beat_model_form_physics_by_the_margin():
    """(d): an effect that closes the gap is not named when model-form physics explains the loop about as well."""
    mf = {"name": "preisach", "n_params": 5, "rms_T": 0.9 * SIG, "bic": -960.0, "delta_bic": 160.0,
          "cv_interleaved_T": 1.0 * SIG, "cv_blocks_T": 1.1 * SIG, "heldout_T": 1.2 * SIG}
    ev = evidence(eddy_lag=good())
    ev["model_form"] = {"preisach": mf}
    assert policy.decide(ev)["effect"] == "model_form"
    ev["model_form"]["preisach"]["bic"] = -917.0  # the effect beats it, but not by the margin: not named
    assert policy.decide(ev)["effect"] == "model_form"
    ev["model_form"]["preisach"]["bic"] = -910.0  # beaten by 10 > margin 6: the effect stands
    assert policy.decide(ev)["effect"] == "eddy_lag"


def test_ties_are_ambiguous_and_a_pair_can_swap_the_leader():
    ev = evidence(hall_offset=good("hall_offset", rms=1.6 * SIG, bic=-900.0),
                  remanent_start=good("remanent_start", rms=1.6 * SIG, bic=-897.0))
    v = policy.decide(ev, {"close_factor": 2.0})
    assert v["effect"] == "hall_offset" and v["ambiguous_with"] == ["remanent_start"]
    assert "Hall offset and a remanent start" in v["ambiguity_reason"]
    ev["pairs"] = [{"effects": ["remanent_start", "eddy_lag"], "rms_T": 1.0 * SIG, "bic": -950.0,
                    "cv_interleaved_T": 1.0 * SIG, "cv_blocks_T": 1.1 * SIG, "heldout_T": 1.2 * SIG, "plausible": True}]
    v = policy.decide(ev)
    assert v["effect"] == "remanent_start" and v["secondary"]["effect"] == "eddy_lag" and v["secondary"]["accepted"]
    assert v["ambiguous_with"] == ["hall_offset"]


def test_a_candidate_without_cross_validation_does_not_earn():
    ev = evidence(eddy_lag=good(cv=None))
    assert policy.decide(ev)["effect"] == "unexplained"


def test_default_thresholds_are_the_values_the_schema_states():
    """Read off workflow/mrhyst/schemas/config.schema.yaml (diagnose) by hand: a changed default fails here."""
    assert policy.DEFAULT_THRESHOLDS == {
        "bic_margin": 10.0, "tie_margin": 6.0, "unexplained_factor": 2.0, "secondary_factor": 1.1,
        "close_factor": 1.5, "heldout_factor": 20.0, "blocks_factor": 1.0, "blocks_majority": True,
        "require_plausible": True,
        "model_form_margin": 6.0, "time_bound_min_sigma": 3.0}


def test_a_config_threshold_is_the_one_that_decides():
    """Hand-worked: a candidate that lowers BIC by 20 earns the default margin of 10 but not a configured 25;
    one that leaves 1.4 sigma closes the gap at the default close_factor 1.5 but not at a configured 1.3."""
    from mrhyst.diagnose.settings import resolve_config

    ev = evidence(eddy_lag=good(delta_bic=20.0, bic=-820.0))
    assert policy.decide(ev)["effect"] == "eddy_lag"
    th = policy.thresholds_from(resolve_config({"bic_margin": 25.0}))
    assert th["bic_margin"] == 25.0 and policy.decide(ev, th)["effect"] == "unexplained"
    ev = evidence(eddy_lag=good(rms=1.4 * SIG, cv=1.45 * SIG))
    assert policy.decide(ev)["effect"] == "eddy_lag"
    th = policy.thresholds_from(resolve_config({"close_factor": 1.3}))
    assert policy.decide(ev, th)["effect"] == "unexplained"


@settings(max_examples=60, deadline=None)
@given(st.floats(1.0, 6.0), st.floats(1.05, 3.0), st.floats(0.5, 3.0))
def test_property_looser_thresholds_never_unname_an_effect(rms_sigmas, close, held_ratio):
    """Monotone: an effect named at some close_factor stays named at any larger one (the trade-off curve's
    closed-world top-1 can only rise as the rule loosens)."""
    ev = evidence(thermal_drift=good("thermal_drift", rms=rms_sigmas * SIG, held=held_ratio * 6 * SIG))
    named = [policy.decide(copy.deepcopy(ev), {"close_factor": c})["effect"] == "thermal_drift"
             for c in (close, close + 0.5, close + 2.0)]
    assert named == sorted(named)


@pytest.mark.parametrize("key", ["rms_T", "heldout_T"])
def test_missing_statistics_fail_safe(key):
    """A held-out figure lost to a failed refit (None in the JSON) counts as a failure, never as a pass."""
    c = good()
    c[key] = None
    v = policy.decide(evidence(eddy_lag=c))
    assert v["effect"] != "eddy_lag"


def test_a_named_pair_predicts_when_either_it_or_its_primary_alone_does():
    """data/raw's hall2: offset + eddy lag close the gap; the pair's 5-fold block CV is worse than plain J-A's
    (7 parameters, 53 samples) while the offset alone predicts the blocks better: (b) holds."""
    ev = evidence(hall_offset=good("hall_offset", rms=1.4 * SIG, cv=1.5 * SIG, blocks=2.0 * SIG))
    ev["pairs"] = [{"effects": ["hall_offset", "eddy_lag"], "rms_T": 0.9 * SIG, "bic": -960.0, "plausible": True,
                    "cv_interleaved_T": 1.0 * SIG, "cv_blocks_T": 8 * SIG, "heldout_T": 1.2 * SIG}]
    v = policy.decide(ev)
    assert v["effect"] == "hall_offset" and v["secondary"]["accepted"]
    ev["candidates"]["hall_offset"]["cv_blocks_T"] = 7 * SIG  # neither predicts the blocks
    assert policy.decide(ev)["effect"] != "hall_offset"


def test_the_block_cv_does_not_judge_a_remanent_start():
    """A remanent start shows in the first samples only; the contiguous block that holds them cannot be
    predicted from the others, so the block CV does not judge it (the registry says so)."""
    c = good("remanent_start", blocks=1000 * SIG)
    c["block_identifiable"] = False
    assert policy.decide(evidence(remanent_start=c))["effect"] == "remanent_start"


def pair(a, b, rms, bic, **kw):
    out = {"effects": [a, b], "rms_T": rms, "bic": bic, "cv_interleaved_T": 1.0 * SIG, "cv_blocks_T": 1.2 * SIG,
           "heldout_T": 1.3 * SIG, "plausible": True}
    out.update(kw)
    return out


def mimic_evidence():
    """A remanent start plus a thermal drift at high drive: a constant Hall offset alone mimics their sum best
    (it leads, but leaves 2.7 sigma); each true effect alone earns less."""
    ev = evidence(hall_offset=good("hall_offset", rms=2.7 * SIG, delta_bic=138.0, bic=-938.0, cv=3.4 * SIG),
                  remanent_start=good("remanent_start", rms=7.4 * SIG, delta_bic=33.0, bic=-833.0, cv=8.6 * SIG),
                  thermal_drift=good("thermal_drift", rms=7.4 * SIG, delta_bic=32.8, bic=-832.8, cv=7.6 * SIG))
    ev["none"]["rms_T"] = 10.0 * SIG
    ev["pairs"] = [pair("hall_offset", "remanent_start", 1.8 * SIG, -976.0),
                   pair("hall_offset", "thermal_drift", 2.35 * SIG, -950.0)]
    return ev


def test_a_pair_of_two_other_effects_replaces_a_leader_that_only_mimics_their_sum():
    """Without the pair of the two true effects the offset leads and nothing closes the gap (unexplained);
    with it, J-A + remanent start + drift beats every pair on top of the offset by more than the tie margin:
    both are named, the offset is not (not even as ambiguous: it does not fit as well)."""
    ev = mimic_evidence()
    assert policy.decide(copy.deepcopy(ev))["effect"] == "unexplained"
    ev["pairs"].append(pair("remanent_start", "thermal_drift", 0.95 * SIG, -1030.0))
    v = policy.decide(ev)
    assert v["effect"] == "remanent_start" and v["secondary"]["effect"] == "thermal_drift"
    assert v["secondary"]["accepted"] and v["secondary"]["swapped"] and all(v["checks"].values())
    assert "hall_offset" not in v["ambiguous_with"]


def test_a_pair_without_the_leader_within_the_tie_margin_does_not_replace_it():
    """The fuller model decides only by more than the tie margin: a pair of two others that fits about as well
    as the leader's best pair leaves the leader named (the evidence does not decide)."""
    ev = mimic_evidence()
    ev["pairs"][0] = pair("hall_offset", "remanent_start", 0.95 * SIG, -1026.0)
    ev["pairs"].append(pair("remanent_start", "thermal_drift", 0.95 * SIG, -1030.0))
    v = policy.decide(ev)
    assert v["effect"] == "hall_offset" and not v["secondary"]["swapped"]


def test_pairs_that_fit_alike_are_ambiguous_with_the_named_second_effect():
    """Drift + offset and drift + remanent start fit within the tie margin (a Hall offset and a remanent start
    are confounded on one 0 -> max -> 0 sweep): the lower BIC is named, the other pair is ambiguous_with it."""
    ev = evidence(thermal_drift=good("thermal_drift", rms=4.1 * SIG, delta_bic=113.0, bic=-913.0, cv=3.9 * SIG))
    ev["none"]["rms_T"] = 12.0 * SIG
    ev["pairs"] = [pair("thermal_drift", "hall_offset", 0.8 * SIG, -1083.0),
                   pair("thermal_drift", "remanent_start", 0.83 * SIG, -1079.6)]
    v = policy.decide(ev)
    assert v["effect"] == "thermal_drift" and v["secondary"]["effect"] == "hall_offset"
    assert v["secondary"]["ambiguous_with"] == [["thermal_drift", "remanent_start"]]
