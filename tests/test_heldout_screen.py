"""The measurement candidates' held-out screen (mrhyst.diagnose.candidates.needs_holdout, issue 23's speed goal):
held-out refits only for a candidate with delta BIC > 0, the only ones a verdict can read them for at any
thresholds the schema allows (bic_margin >= 0, cross_seed_margin >= 0). Checked against the unscreened diagnosis
(every candidate cross-validated, as before the screen): the whole diagnosis is the same but for the held-out keys
of the skipped candidates, and the plain rule's verdict from the screened evidence is the complete one's at any
thresholds (hypothesis; the trade-off curve replays saved evidence)."""

import importlib
import json
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from mrhyst import diagnose as dg
from mrhyst.diagnose import contract, policy
from screens import screened_and_full
from test_diagnose import FAST, make

cd = importlib.import_module("mrhyst.diagnose.candidates")
ROOT = Path(__file__).resolve().parent.parent
CV = ("cv_interleaved_T", "cv_blocks_T", "cv_blocks_folds_T", "heldout_T")


def _json(d):
    out = json.loads(json.dumps(contract.clean(d), default=str))
    out.pop("search", None)  # model-evaluation counts: fewer refits by design
    return out


def _both(sw):
    """(screened, unscreened) diagnoses of one sweep: unscreened, every candidate cross-validated."""
    return screened_and_full(sw, [(cd, "needs_holdout", lambda scores: set(scores))], _json)


@pytest.fixture(scope="module")
def cases():
    clean, _ = make([], seed=0)
    offset, _ = make([("hall_offset", {"offset_T": 3.0e-3})], seed=2)
    drift, _ = make([("thermal_drift", {"drift_T_per_s": 2.0e-5})], seed=5)
    rig = dg.load_sweep(ROOT / "data/raw/li_gong_rig.csv", "hall1", dg.resolve_config(FAST))
    return {"clean": _both(clean), "offset": _both(offset), "drift": _both(drift), "rig": _both(rig)}


def test_only_candidates_that_cannot_earn_lose_their_held_out_errors(cases):
    skipped = kept = 0
    for screened, full in cases.values():
        s, f = screened["evidence"]["candidates"], full["evidence"]["candidates"]
        assert set(s) == set(f)
        assert all(k in c for c in f.values() for k in ("cv_interleaved_T", "cv_blocks_T", "heldout_T"))  # unscreened
        for e, c in f.items():
            if all(k in s[e] for k in ("cv_interleaved_T", "cv_blocks_T", "heldout_T")):
                assert s[e] == c  # the same refits from the same fit: the same bytes
                kept += c["delta_bic"] > 0
            else:
                assert c["delta_bic"] <= 0, e
                assert s[e] == {k: v for k, v in c.items() if k not in CV}
                skipped += 1
        # nothing else in the diagnosis moves: verdict, layers, budget, figures' series, texts
        strip = {e: {k: v for k, v in c.items() if k not in CV or k in s[e]} for e, c in f.items()}
        assert screened == dict(full, evidence=dict(full["evidence"], candidates=strip))
    assert skipped > 0 and kept > 0  # the screen did something, and kept what it must


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(bic=st.floats(0.0, 40.0), close=st.floats(1.0001, 50.0), held=st.floats(0.5, 5.0),
       blocks=st.floats(0.5, 5.0), tie=st.floats(0.0, 20.0), sec=st.floats(0.5, 5.0), cvmax=st.integers(1, 7))
def test_any_thresholds_give_the_verdict_of_the_complete_evidence(cases, bic, close, held, blocks, tie, sec, cvmax):
    th = {"bic_margin": bic, "close_factor": close, "heldout_factor": held, "blocks_factor": blocks,
          "tie_margin": tie, "secondary_factor": sec}
    for screened, full in cases.values():
        es, ef = (dict(d["evidence"], cv_max_candidates=cvmax) for d in (screened, full))
        assert policy.decide(es, th) == policy.decide(ef, th)
