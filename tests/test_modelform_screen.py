"""Two screens of issue 23's speed goal, each against the unscreened diagnosis. The model-form stage's screen
(mrhyst.diagnose.modelform.needs_holdout, issue 23's speed goal): held-out refits
only for the candidates a verdict can read them for (delta BIC > 0, since bic_margin >= 0; and the lowest-BIC one,
whose held-out errors the ``model_form`` block reports). Checked against the unscreened stage (every candidate
cross-validated, as before the screen): at any thresholds the schema allows or the trade-off curve replays
(hypothesis), the verdict and the model_form block from the screened evidence are those of the complete one. The
layers' stability refits (mrhyst.diagnose.layerfit.stability_read: only where check (d) can be read): the layered
verdict, its budget and the confounds it reports are the complete evidence's at any layer thresholds."""

import importlib
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from mrhyst import diagnose as dg
from mrhyst.diagnose import contract, layered, layerfit, policy
from screens import screened_and_full
from test_diagnose import FAST, make

modelform = importlib.import_module("mrhyst.diagnose.modelform")
ROOT = Path(__file__).resolve().parent.parent
CV = ("cv_interleaved_T", "cv_blocks_T", "heldout_T")


def _both(sw):
    """(screened, unscreened) diagnoses of one sweep: unscreened, every model-form candidate cross-validated and
    every increment's sizes taken on the other bases."""
    return screened_and_full(sw, [(modelform, "needs_holdout", lambda out: set(out)),
                                  (layerfit, "stability_read", lambda inc: True)])


@pytest.fixture(scope="module")
def cases():
    clean, _ = make([], seed=0)
    offset, _ = make([("hall_offset", {"offset_T": 3.0e-3})], seed=2)
    rig = dg.load_sweep(ROOT / "data/raw/li_gong_rig.csv", "hall1", dg.resolve_config(FAST))
    return {"clean": _both(clean), "offset": _both(offset), "rig": _both(rig)}


def _verdict(v):
    return (v["effect"], sorted(v["ambiguous_with"]), v.get("model_form"), sorted(v.get("model_form_checks") or {}))


def test_the_screen_skips_only_candidates_that_cannot_earn(cases):
    skipped = 0
    for screened, full in cases.values():
        s, f = screened["evidence"]["model_form"], full["evidence"]["model_form"]
        assert set(s) == set(f)
        assert all(k in m for m in f.values() for k in CV)  # the unscreened stage cross-validated every candidate
        best = min(f, key=lambda n: f[n]["bic"])
        for n, m in s.items():
            assert m["bic"] == f[n]["bic"]  # the full fits are the same fits
            if all(k in m for k in CV):
                assert all(m[k] == f[n][k] for k in CV)
            else:  # no held-out refit: a candidate no verdict names (delta BIC <= 0), never the reported best
                assert f[n]["delta_bic"] <= 0 and n != best
                skipped += 1
    assert skipped > 0  # the screen did something on these sweeps


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(bic=st.floats(0.0, 40.0), close=st.floats(0.3, 50.0), held=st.floats(0.5, 5.0), blocks=st.floats(0.5, 5.0),
       unexpl=st.floats(1.0001, 5.0))
def test_any_thresholds_give_the_verdict_of_the_complete_evidence(cases, bic, close, held, blocks, unexpl):
    th = {"bic_margin": bic, "close_factor": close, "heldout_factor": held, "blocks_factor": blocks,
          "unexplained_factor": unexpl}
    for screened, full in cases.values():
        vs, vf = policy.decide(screened["evidence"], th), policy.decide(full["evidence"], th)
        assert _verdict(vs) == _verdict(vf)
        ok = lambda v: sorted(n for n, c in (v.get("model_form_checks") or {}).items() if all(c.values()))  # noqa: E731
        assert ok(vs) == ok(vf)
        bs = contract.model_form_block(screened["evidence"], vs)
        bf = contract.model_form_block(full["evidence"], vf)
        assert {k: bs[k] for k in bs if k != "candidates"} == {k: bf[k] for k in bf if k != "candidates"}


def test_the_stability_screen_skips_some_refits(cases):
    skipped = 0
    for screened, full in cases.values():
        s, f = (d["layers"]["evidence"]["increments"] for d in (screened, full))
        assert set(s) == set(f)
        for e in s:
            assert s[e]["bic"] == f[e]["bic"] and s[e]["size"] == f[e]["size"]
            skipped += "sizes_other_bases" not in s[e]
            if "sizes_other_bases" in s[e]:
                assert s[e]["sizes_other_bases"] == f[e]["sizes_other_bases"]
    assert skipped > 0


@settings(max_examples=80, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(bic=st.floats(0.0, 40.0), tie=st.floats(0.0, 20.0), ratio=st.floats(1.0, 4.0), share=st.floats(0.0, 1.0))
def test_any_layer_thresholds_give_the_layered_verdict_of_the_complete_evidence(cases, bic, tie, ratio, share):
    th = {"bic_margin": bic, "tie_margin": tie, "stable_ratio": ratio, "min_share": share}
    for screened, full in cases.values():
        vs, vf = (layered.decide(d["layers"]["evidence"], th) for d in (screened, full))
        for k in ("effect", "ambiguous_with", "budget", "base", "size", "unseparated"):
            assert vs[k] == vf[k], k
