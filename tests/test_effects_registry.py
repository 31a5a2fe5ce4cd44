"""One forward model, one registry: an effect defined in ONE place (mrhyst.model.effects.register) flows from the
virtual rig into the diagnosis, which names and sizes it; nothing else needs an edit. Also the forward
model's physical order for any set of effects."""

import numpy as np
import pytest
from mrhyst import diagnose as dg
from mrhyst import rig
from mrhyst.model import effects as fx
from mrhyst.model import hall, ja

TRUTH = np.array([1.357e6, 2.6882e4, 1.4697e-4, 0.4199, 5.6943e3])
NLE = 3026.4
SIGMA = 1.5e-4


def _alternating(t):
    return (-1.0) ** np.arange(np.asarray(t).size)


@pytest.fixture
def pickup():
    """A toy effect: interference aliased to the sampling rate, B_obs[j] = B[j] + A (-1)^j."""
    e = fx.register(fx.Effect(
        "pickup", "amp_T", "zero", "toy: interference aliased to alternate samples",
        signal=lambda B, v, t: B + np.asarray(v, dtype=float)[..., None] * _alternating(t),
        coord="pickup_mT", unit=lambda ctx: 1e-3, bounds=lambda ctx: (-ctx.span_mT, ctx.span_mT),
        starts=lambda ctx, r: [0.0, float(np.mean((r * _alternating(r))[ctx.mask]))],
        grid=lambda ctx: [-0.05 * ctx.span_mT, 0.05 * ctx.span_mT],
        # the blind benchmark: 8-20 sigma of pickup per case; the key's reference fit starts from the residual
        draw=lambda rng, m, c: ({"amp_T": float(rng.uniform(8.0, 20.0)) * c["sigma_T"]}, {}),
        ref_starts=lambda c: ([0.0, float(np.mean(c["resid_T"] * _alternating(c["resid_T"])))],
                              (-c["peak_T"], c["peak_T"]))))
    yield e
    fx.unregister("pickup")


def test_a_registered_toy_effect_flows_rig_to_diagnosis(pickup):
    assert "pickup" in fx.VOCABULARY and "pickup" in dg.candidates()
    current = ja.paper_current_path()
    peak = float(np.max(ja.simulate(TRUTH, current, NLE, form="physical", substeps=8)[0]))
    v, t, cur, side = rig.simulate_case(TRUTH, [("pickup", {"amp_T": 1.5e-3})], SIGMA, 4, current, n_over_le=NLE,
                                        dwell_s=0.1, sensitivity_V_per_T=min(5.0, 1.3 / peak), declare_limits=False)
    s = side["sensors"]["hall1"]
    B = hall.volts_to_tesla(v["hall1"], s["sensitivity_V_per_T"], s["quiescent_V"])
    d = dg.diagnose(dg.sweep_from_arrays(cur, t, B, NLE), {"budget_seeds": 1, "n_random": 600, "series": False})
    assert d["effect"] == "pickup", d["verdict"]
    assert d["effect_size"]["param"] == "amp_T"
    assert abs(d["effect_size"]["value"] - 1.5e-3) < max(4 * d["effect_size"]["stderr"], 1e-4)
    assert d["rms_after_T"] <= 1.5 * d["noise_floor_T"]


def test_unregistered_effect_is_refused_by_the_rig():
    with pytest.raises(ValueError, match="unknown effect 'pickup'"):
        rig.observe(TRUTH, ja.paper_current_path(), np.arange(53.0), NLE, [("pickup", {"amp_T": 1e-3})])


def test_a_set_of_effects_acts_in_physical_order_whatever_order_it_is_given():
    """core (remanent start) -> flux (eddy lag) -> Hall zero (offset, drift) -> output limit (saturation)."""
    current = ja.paper_current_path()
    t = rig.sample_times(current.size, 0.1)
    eff = {"sensor_saturation": {"B_sat_T": 0.06}, "hall_offset": {"offset_T": 2e-3}, "eddy_lag": {"lag": 0.3},
           "remanent_start": {"M0_A_per_m": 4e3}, "thermal_drift": {"drift_T_per_s": 1e-4}}
    B, ok = fx.forward(TRUTH, current, t, NLE, list(reversed(list(eff.items()))), form="physical",
                       substeps=4)
    B0, _ = ja.simulate(TRUTH, current, NLE, form="physical", substeps=4, M0=4e3)
    ref = np.minimum(fx.eddy_filter(B0, 0.3) + 2e-3 + 1e-4 * (t - t[0]), 0.06)
    assert ok
    np.testing.assert_allclose(B, ref, rtol=0, atol=1e-15)


def test_forward_is_batched_over_parameter_sets():
    current = ja.paper_current_path()
    t = rig.sample_times(current.size, 0.1)
    P = np.vstack([TRUTH, TRUTH * [1.1, 1, 1, 1, 1]])
    B, ok = fx.forward(P, current, t, NLE, {"hall_offset": {"offset_T": np.array([0.0, 1e-3])}}, form="physical",
                       substeps=2)
    for i in range(2):
        Bi, _ = fx.forward(P[i], current, t, NLE, "hall_offset", {"offset_T": [0.0, 1e-3][i]}, form="physical",
                           substeps=2)
        np.testing.assert_array_equal(B[i], Bi)
    assert ok.all()


def test_the_toy_effect_flows_on_into_the_blind_benchmark(pickup, tmp_path, config):
    """The same single registry entry makes it a blind class: the rig draws cases of it, the key's independent
    reference fit judges them detectable, the diagnosis names it, and blind_score counts it right."""
    import copy

    from mrhyst import blind

    b = copy.deepcopy(config["blind"])
    b.update(classes=["none", "pickup"], counts={}, n_per_class=2, noise_sigma_T=[1.5e-4])
    key = blind.generate(b, tmp_path / "cases", tmp_path / "key.json")
    assert sorted(c["class"] for c in key["cases"].values()) == ["none", "none", "pickup", "pickup"]
    fast = {"budget_seeds": 1, "n_random": 600, "series": False}
    paths = []
    for csv in sorted((tmp_path / "cases").glob("*.csv")):
        out = tmp_path / "diag" / (csv.stem + ".json")
        out.parent.mkdir(exist_ok=True)
        dg.diagnose_file(csv, blind.SENSOR, out=out, config=fast)
        paths.append(str(out))
    s = blind.score(paths, tmp_path / "key.json", b)
    assert s["per_class"]["pickup"]["top1_strict"] == 1.0, s["per_class"]
    assert s["overall"]["false_alarm_none"] == 0.0


@pytest.mark.parametrize("declared,B_sat_T,ok", [
    ({}, 0.124, True),                                            # no declared limits: any clip above 0.5 Vcc
    ({"output_min_V": 0.2, "output_max_V": 3.1}, 0.124, False),   # 2.27 V: 0.83 V inside the declared 3.1 V
    ({"output_min_V": 0.2, "output_max_V": 3.1}, 0.285, True),    # 3.075 V: at the declared limit
    ({"output_max_V": 3.1}, 0.40, True),                          # beyond it: the declared limit clips first
    ({"output_min_V": 0.2}, 0.124, False),                        # 1.03 V low side, 0.83 V above 0.2 V
])
def test_a_clip_well_inside_the_declared_output_limits_is_implausible(declared, B_sat_T, ok, config):
    """sensor_saturation's size check: where the sidecar declares the sensor's output limits, one side of the
    (symmetric) clip must reach one of them within saturation_declared_tol_frac_supply of the supply."""
    ctx = fx.Context(span_mT=100.0, duration_s=10.0, B_mT=np.zeros(3), t_rel=np.zeros(3), mask=np.ones(3, bool),
                     sensor={"sensitivity_V_per_T": 5.0, "quiescent_V": 1.65, "supply_V": 3.3, **declared})
    good, why = fx.REGISTRY["sensor_saturation"].plausible(B_sat_T, ctx, config["diagnose"]["plausible"])
    assert good is ok, why
