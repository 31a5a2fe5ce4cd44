"""Issue 22: an effect is ONE registry entry, in fact. A toy effect that needs sample times, defined only here
(``toy_hum``: pickup of a pump's 0.7 Hz vibration, B_obs = B + A sin(2 pi f (t - t0))), flows virtual rig ->
diagnosis -> blind score with no edit anywhere else; a B(H) loop without sample times skips it, with the reason
the entry gives; and the blind cases of every other class are drawn exactly as without it (each class draws from
a stream keyed by its name, not by its place among the classes or in the registry).

Why not a time-linear offset: that is ``thermal_drift`` under another name, and the diagnosis rightly reports the
two tied (ambiguous_with); a quadratic creep was tried and is, over one sweep, within the tie margin of a linear
drift plus J-A's shape. A periodic pickup in time is told apart from every vocabulary effect."""

import copy
import math

import numpy as np
import pytest
from mrhyst import blind, rig
from mrhyst import diagnose as dg
from mrhyst.model import effects as fx
from mrhyst.model import hall, ja
from workflow_util import ROOT

TRUTH = np.array([1.357e6, 2.6882e4, 1.4697e-4, 0.4199, 5.6943e3])
NLE = 3026.4
SIGMA = 1.5e-4
FAST = {"budget_seeds": 1, "n_random": 600, "series": False}
FERRITE = ROOT / "data/external/mnzn-ferrite-jamodel/loops.csv"
TOY = "toy_hum"
F_HZ = 0.7  # below half the fastest sampling (dwell 0.05-0.5 s: 0.035-0.35 cycles per sample, never aliased away)
WHY = "no sample times: a pickup at 0.7 Hz needs them"


def _wave(t):
    t = np.asarray(t, dtype=float)
    return np.sin(2.0 * math.pi * F_HZ * (t - t[0]))


def _start(ctx, r):
    """The amplitude (mT) by linear least squares of the residual on [1, sin(2 pi f t)] (t = t_rel x duration)."""
    v = ctx.mask
    A = np.column_stack([np.ones(int(v.sum())), np.sin(2.0 * math.pi * F_HZ * ctx.t_rel[v] * ctx.duration_s)])
    return [0.0, float(np.linalg.lstsq(A, r[v], rcond=None)[0][1])]


def _draw(rng, m, c):
    """8-20 sigma of amplitude, either sign (the test's own range, not config blind.magnitude)."""
    s = 1.0 if rng.uniform() < 0.5 else -1.0
    k = math.exp(rng.uniform(math.log(8.0), math.log(20.0)))
    return {"amp_T": s * k * c["sigma_T"]}, {"sigmas": k}


def _ref_starts(c):
    w = np.sin(2.0 * math.pi * F_HZ * c["t_s"])
    return [float(np.dot(w, c["resid_T"]) / max(float(np.dot(w, w)), 1e-30)), 0.0], (-c["peak_T"], c["peak_T"])


def toy_effect() -> fx.Effect:
    return fx.Effect(
        TOY, "amp_T", "zero", "toy: pickup of a 0.7 Hz vibration",
        signal=lambda B, v, t: B + np.asarray(v, dtype=float)[..., None] * _wave(t),
        coord="hum_mT", unit=lambda ctx: 1e-3, bounds=lambda ctx: (-ctx.span_mT, ctx.span_mT), starts=_start,
        grid=lambda ctx: [x * ctx.span_mT for x in (-0.2, -0.05, 0.05, 0.2)],
        draw=_draw, ref_starts=_ref_starts, needs={"time": WHY})


@pytest.fixture
def toy():
    e = fx.register(toy_effect())
    yield e
    fx.unregister(TOY)


def _measure(effects, seed=3, dwell=0.1):
    current = ja.paper_current_path()
    peak = float(np.max(ja.simulate(TRUTH, current, NLE, form="physical", substeps=8)[0]))
    v, t, cur, side = rig.simulate_case(TRUTH, effects, SIGMA, seed, current, n_over_le=NLE, dwell_s=dwell,
                                        sensitivity_V_per_T=min(5.0, 1.3 / peak), declare_limits=False)
    s = side["sensors"]["hall1"]
    return cur, t, hall.volts_to_tesla(v["hall1"], s["sensitivity_V_per_T"], s["quiescent_V"])


def test_the_toy_flows_from_the_rig_into_the_diagnosis_which_names_and_sizes_it(toy):
    """1.5 mT (10 sigma) of 0.7 Hz pickup on the paper's sweep at 0.1 s per step: named, its amplitude recovered,
    and what is left is the noise. Hand check of the injected signal: at t - t0 = 5/14 s (a quarter period) the
    pickup is the whole amplitude; the sweep's samples sit every 0.1 s, so sample 5 (t - t0 = 0.5 s) carries
    1.5 mT x sin(0.7 pi) = 1.2135 mT."""
    amp = 1.5e-3
    cur, t, B = _measure([(TOY, {"amp_T": amp})])
    B0 = rig.observe(TRUTH, cur, t, NLE, [])[0]
    assert math.isclose(fx.forward(TRUTH, cur, t, NLE, TOY, {"amp_T": amp}, form="physical", substeps=8)[0][5] - B0[5],
                        1.5e-3 * 0.80901699437494745, rel_tol=1e-9)
    d = dg.diagnose(dg.sweep_from_arrays(cur, t, B, NLE), FAST)
    assert TOY not in d["skipped"]
    assert d["effect"] == TOY, d["verdict"]
    size = d["effect_size"]
    assert size["param"] == "amp_T"
    assert abs(size["value"] - amp) < max(4 * size["stderr"], 1e-4), size
    assert d["rms_after_T"] <= 1.5 * d["noise_floor_T"]


def test_a_bh_loop_without_sample_times_skips_the_toy_with_its_own_reason(toy):
    d = dg.diagnose_bh_file(FERRITE, 1, config=dict(FAST, model_form={"candidates": []}))
    assert d["skipped"][TOY] == WHY
    assert TOY not in [c["effect"] for c in d["candidates"]]
    assert TOY not in d["evidence"]["candidates"]


@pytest.fixture(scope="module")
def with_and_without(config, tmp_path_factory):
    """The same small blind benchmark generated twice: without the toy (not registered), then with it registered
    and its class inserted among the others (before them in ``classes``, the last in the registry)."""
    b = copy.deepcopy(config["blind"])
    b.update(classes=["none", "hall_offset", "thermal_drift"], counts={}, n_per_class=1, noise_sigma_T=[1.5e-4],
             reference=dict(b["reference"], max_nfev=60))
    d0, d1 = tmp_path_factory.mktemp("without"), tmp_path_factory.mktemp("with")
    assert TOY not in fx.REGISTRY
    k0 = blind.generate(b, d0 / "cases", d0 / "key.json")
    fx.register(toy_effect())
    try:
        b1 = dict(b, classes=["none", TOY, "hall_offset", "thermal_drift"], counts={TOY: 2})
        k1 = blind.generate(b1, d1 / "cases", d1 / "key.json")
        yield (d0, k0), (d1, k1, b1)
    finally:
        fx.unregister(TOY)


def test_adding_the_toy_leaves_every_other_class_drawn_as_it_was(with_and_without):
    """Every case of the benchmark without the toy is in the one with it: the same draw (truth, drive, noise,
    dwell, effect size, seeds) and the same bytes on disk (under another, reshuffled id). Its key entry is the
    same too, but for the toy's own refit, which the key now also tries (alternatives_rms_T, equivalent_to)."""
    (d0, k0), (d1, k1, _) = with_and_without
    by_seed = {c["noise_seed"]: (cid, c) for cid, c in k1["cases"].items()}
    assert sorted(c["class"] for c in k1["cases"].values()) == sorted(
        [c["class"] for c in k0["cases"].values()] + [TOY, TOY])
    for cid0, c0 in k0["cases"].items():
        cid1, c1 = by_seed[c0["noise_seed"]]
        for ext in (".csv", ".json"):
            assert (d1 / "cases" / (cid1 + ext)).read_bytes() == (d0 / "cases" / (cid0 + ext)).read_bytes()
        alt1 = dict(c1["alternatives_rms_T"])
        if c0["class"] != "none":
            assert TOY in alt1
        alt1.pop(TOY, None)
        assert alt1 == c0["alternatives_rms_T"]
        assert [e for e in c1["equivalent_to"] if e != TOY] == c0["equivalent_to"]
        same = {k: v for k, v in c1.items() if k not in ("alternatives_rms_T", "equivalent_to")}
        assert same == {k: v for k, v in c0.items() if k not in ("alternatives_rms_T", "equivalent_to")}


def test_the_toy_is_scored_by_the_blind_benchmark(with_and_without, tmp_path):
    """The toy's blind cases (drawn by its entry's own draw) are detectable by the key's independent reference
    fit, named by the diagnosis and counted right by blind_score."""
    _, (d1, k1, b1) = with_and_without
    fx.register(toy_effect())
    try:
        toys = sorted(cid for cid, c in k1["cases"].items() if c["class"] in (TOY, "none"))
        assert all(k1["cases"][cid]["detectable"] for cid in toys if k1["cases"][cid]["class"] == TOY)
        paths = []
        for cid in toys:
            out = tmp_path / f"{cid}.json"
            dg.diagnose_file(d1 / "cases" / f"{cid}.csv", blind.SENSOR, out=out, config=FAST)
            paths.append(out)
        s = blind.score(paths, d1 / "key.json", b1)
    finally:
        fx.unregister(TOY)
    assert s["per_class"][TOY]["n"] == 2 and s["per_class"][TOY]["top1_strict"] == 1.0, s["per_class"]
    assert s["overall"]["false_alarm_none"] == 0.0
