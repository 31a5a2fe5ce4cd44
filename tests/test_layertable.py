"""The declared table of what the layered rule can judge on which protocol (issue 23; mrhyst.diagnose.layertable),
and how its confounds reach the verdict (mrhyst.diagnose.layerfit.attach_confounds). No fitting."""

from mrhyst.diagnose import layerfit, layertable, protocols
from mrhyst.model import effects as fx


def test_every_row_names_vocabulary_effects_and_a_protocol_variant_that_exists():
    for r in layertable.TABLE:
        e = r.effect
        assert e in fx.REGISTRY and (r.partner == "model_form" or r.partner in fx.REGISTRY)
        assert r.separated_by in protocols.VARIANTS and r.protocols and r.why


def test_a_bipolar_loop_and_a_bh_loop_judge_every_effect_a_unipolar_sweep_only_with_a_signature():
    for proto in ("bipolar_repeated", "no_time"):
        assert all(layertable.separable(e, proto, []) for e in fx.REGISTRY)
    assert all(layertable.separable(e, "bipolar_single", []) for e in fx.REGISTRY if e != "hall_offset")
    # one bipolar cycle: a drift is judged, and one that fails only its signature is the drift-or-shape confound
    assert layertable.confounded("thermal_drift", "bipolar_single", ["signature"]).separated_by == "repeat"
    assert layertable.confounded("thermal_drift", "bipolar_single", ["signature", "earns"]) is None
    assert layertable.confounded("thermal_drift", "unipolar_single", ["separable", "signature"]).partner == "model_form"
    assert not layertable.separable("hall_offset", "bipolar_single", [])  # one cycle may sit off centre
    assert layertable.separable("hall_offset", "bipolar_single", [{"kind": "first_zero"}])
    assert not layertable.separable("eddy_lag", "unipolar_single", [{"kind": "first_zero"}])
    assert layertable.separable("eddy_lag", "unipolar_single", [{"kind": "held_current"}])
    assert not layertable.separable("hall_offset", "unipolar_single", [{"kind": "first_zero"}])
    assert layertable.separable("sensor_saturation", "unipolar_single", [])
    assert layertable.separable("thermal_drift", "unipolar_repeated", [])  # a repeat shows a drift by itself


def diag(effect, unsep, judged_on=None, nm=None):
    return {"effect": effect, "ambiguous_with": [], "verdict": effect, "confounds": [],
            **({"next_measurement": nm} if nm else {}),
            "layers": {"judged_on": judged_on, "evidence": {"protocol": "unipolar_single"},
                       "verdict": {"unseparated": unsep}}}


U = {"effect": "eddy_lag", "partner": "model_form", "separated_by": "long_dwell", "why": "w"}


def test_an_unseparated_lag_on_a_material_verdict_is_named_with_its_separating_sweep():
    d = diag("unexplained", [U])
    layerfit.attach_confounds(d)
    assert d["ambiguous_with"] == ["eddy_lag"] and d["next_measurement"]["protocol"] == "long_dwell"
    assert d["confounds"][0]["effects"] == ["eddy_lag", "model_form"] and "long_dwell" in d["verdict"]


def test_a_none_verdict_names_an_unseparated_effect_but_no_other_layer_row():
    """Plain J-A within the floor, yet the flexible base reads a measurement effect it cannot separate from the
    material (held-out: a real ferrite loop with a Hall offset, 'none' before): named with its separating sweep.
    Nothing else of a material verdict's rows (a first-zero pair, an effect beyond its bound) joins a 'none'."""
    d = diag("none", [U])
    layerfit.attach_confounds(d)
    assert d["ambiguous_with"] == ["eddy_lag"] and d["next_measurement"]["protocol"] == "long_dwell"
    assert "on the flexible base the data read as eddy_lag as well as model_form" in d["verdict"]
    d = diag("none", [])
    d["layers"]["verdict"]["beyond_bound"] = [dict(U, beyond_bound="tau 9 s")]
    d["signatures"] = [{"kind": "first_zero", "sigma": 30.0, "supports": ["hall_offset", "remanent_start"]}]
    layerfit.attach_confounds(d)
    assert d["ambiguous_with"] == [] and d["confounds"] == [] and "next_measurement" not in d


def test_a_measurement_verdict_keeps_its_own_and_a_simulated_next_measurement_stays():
    d = diag("hall_offset", [U])
    layerfit.attach_confounds(d)
    assert d["ambiguous_with"] == [] and d["confounds"] == []
    d = diag("model_form", [U], nm={"protocol": "repeat", "variants": {"long_dwell": 12.0}})
    layerfit.attach_confounds(d)
    assert d["next_measurement"]["protocol"] == "repeat" and d["confounds"][0]["separation_sigma"] == 12.0


def test_an_effect_the_layer_named_carries_its_declared_confound_unless_the_partner_cannot_be_judged():
    d = diag("hall_offset", [], judged_on="everett")
    layerfit.attach_confounds(d)
    assert d["ambiguous_with"] == ["remanent_start"] and d["next_measurement"]["protocol"] == "bipolar"
    d = diag("hall_offset", [], judged_on="everett")
    layerfit.attach_confounds(d, skipped={"remanent_start": "a B(H) loop's start"})
    assert d["ambiguous_with"] == [] and "next_measurement" not in d


def test_a_bipolar_lag_that_fails_only_stability_is_the_lag_or_wider_loop_confound():
    from mrhyst.diagnose import layered

    passing = {"separable": True, "earns": True, "predicts": True, "substantial": True, "plausible": True,
               "signature": None}
    inc = {"size": 0.13, "param": "lag", "base": {"bic": 0.0}, "bic": -35.0}
    for proto in ("bipolar_repeated", "bipolar_single"):
        u = layered.unseparated({"eddy_lag": {**passing, "stable": False}}, {"eddy_lag": inc}, proto)
        assert [(x["effect"], x["partner"], x["separated_by"]) for x in u] == [("eddy_lag", "model_form", "long_dwell")]
        # a lag that also fails to earn is rejected, not a confound; one that passes everything is judged
        assert layered.unseparated({"eddy_lag": {**passing, "stable": False, "earns": False}}, {"eddy_lag": inc},
                                   proto, 10.0) == []
        # unless J-A + the lag earns on its own: the flexible base took the whole lag as a wider loop
        for db, confound in ((30.0, True), (10.0, False)):
            u = layered.unseparated({"eddy_lag": {**passing, "substantial": False, "earns": False}},
                                    {"eddy_lag": {**inc, "ja": {"delta_bic": db}}}, proto, 10.0)
            assert [x["separated_by"] for x in u] == (["long_dwell"] if confound else [])
        assert layered.unseparated({"eddy_lag": {**passing, "stable": True}}, {"eddy_lag": inc}, proto) == []
    # an unstable offset on a bipolar loop is no declared confound: rejected as before
    assert layered.unseparated({"hall_offset": {**passing, "stable": False}}, {"hall_offset": inc},
                               "bipolar_repeated") == []


def test_every_confound_of_the_verdict_carries_its_separating_measurement():
    d = diag("unexplained", [U], nm={"protocol": "repeat", "separation_sigma": 9.0, "variants": {"long_dwell": 12.0}})
    layerfit.attach_confounds(d)
    nm = d["next_measurement"]
    assert nm["protocol"] == "repeat" and "eddy_lag" in d["ambiguous_with"]
    assert nm["also"] == [{"protocol": "long_dwell", "separates": ["eddy_lag", "model_form"],
                           "separation_sigma": 12.0, "why": "w"}]
    d = diag("unexplained", [U], nm={"protocol": "long_dwell", "variants": {"long_dwell": 12.0}})
    layerfit.attach_confounds(d)
    assert "also" not in d["next_measurement"]  # its own protocol separates it already


def test_the_veto_s_separator_comes_from_the_table_where_a_row_limits_the_effect():
    """One place for what separates a measurement effect from a material shape: the table's model_form row on that
    protocol (a first bipolar cycle: repeat it), else the protocol-free default (an offset: a full reversal)."""
    assert layertable.shape_separator("hall_offset", "bipolar_single")[0] == "repeat"
    assert layertable.shape_separator("hall_offset", "unipolar_single")[0] == "bipolar"
    assert layertable.shape_separator("eddy_lag", "unipolar_single")[0] == "long_dwell"
    assert layertable.shape_separator("thermal_drift", None) == layertable.SHAPE_SEPARATORS["thermal_drift"]
    assert layertable.shape_separator("sensor_saturation", "bipolar_single") is None
    # any effect has a separator for an increment beyond its size bound; a clip's is not a shape's (no veto reads it)
    assert layertable.separator("sensor_saturation", "unipolar_single")[0] == "half_amplitude"
    assert layertable.separator("eddy_lag", "unipolar_single")[0] == "long_dwell"
    assert layertable.separator("remanent_start", "unipolar_single")[0] == "repeat"


def test_a_rival_beyond_its_size_bound_reaches_the_verdict_with_the_bound_and_its_separating_sweep():
    """layered.beyond_bound: a drift that gains as much as the offset named but is fitted beyond its rate bound is in
    ambiguous_with, its sentence gives the bound's reason, and its separating sweep is a next measurement."""
    rival = {"effect": "thermal_drift", "partner": "model_form", "separated_by": "repeat", "why": "w",
             "beyond_bound": "drift rate 0.224 mT/s vs at most 0.198 mT/s"}
    d = diag("hall_offset", [], judged_on="everett", nm={"protocol": "saturating", "variants": {"repeat": 98.0}})
    d["layers"]["evidence"]["protocol"] = "bipolar_single"
    d["layers"]["verdict"]["rivals"] = [rival]
    layerfit.attach_confounds(d)
    assert "thermal_drift" in d["ambiguous_with"]
    assert "beyond the physical bound (drift rate 0.224 mT/s vs at most 0.198 mT/s)" in d["verdict"]
    assert {"protocol": "repeat", "separates": ["hall_offset", "thermal_drift"], "separation_sigma": 98.0,
            "why": "w"} in d["next_measurement"]["also"]
    assert all("rival" not in c for c in d["confounds"])


def test_a_material_verdict_names_the_layers_confound_even_where_a_partial_row_has_the_same_pair():
    """bench/heldout_openworld.py: a -7 mT Hall offset on a Rayleigh core, 0 -> 2 -> 0 A. J-A + the offset leaves
    1.9x the floor (a pair with an implausible drift closes it), the flexible base from a negative start 1.3x: the
    verdict is material (unexplained), and the offset was unseparated on the layers. The plain rule's partial row
    for the same pair (added: False, of the partial leader) used to dedupe the layers' row, so the verdict named
    neither an offset nor a remanent start: both are in ambiguous_with now, with the bipolar sweep that separates
    them, beside the partial's row."""
    u = {"effect": "hall_offset", "partner": "remanent_start", "separated_by": "bipolar", "why": "w"}
    d = diag("unexplained", [u], nm={"protocol": "repeat", "variants": {"bipolar": 300.0}})
    d["confounds"] = [{"effects": ["hall_offset", "remanent_start"], "of": "partial", "protocol": "unipolar_single",
                       "separated_by": "bipolar", "why": "p", "added": False}]
    layerfit.attach_confounds(d)
    assert d["ambiguous_with"] == ["hall_offset", "remanent_start"]
    assert [c["of"] for c in d["confounds"]] == ["partial", "layers"]
    assert "could be hall_offset or remanent_start" in d["verdict"]
    assert d["next_measurement"]["also"][0]["protocol"] == "bipolar"
    # a row of the same origin is still not repeated
    layerfit.attach_confounds(d)
    assert [c["of"] for c in d["confounds"]] == ["partial", "layers"]


FIRST_ZERO = [{"kind": "first_zero", "size_T": 0.0118, "sigma": 47.7, "samples": [0]}]


def test_b_at_the_first_zero_reading_names_offset_and_remanent_start_beside_a_material_verdict():
    """bench/heldout_openworld.py: a +12 mT Hall offset on a Stoner-Wohlfarth core, 0 -> 2 -> 0 A, undeclared start:
    B at the first reading 48 sigma, J-A + the offset 55 BIC better than J-A, yet 'unexplained' named neither (the
    layers' offset failed its stability too, so it was no unseparated increment). One unipolar sweep cannot tell the
    two (issue 23, item 3): both are named, with the bipolar sweep that separates them."""
    def material(**kw):
        d = diag("unexplained", [])
        d.update({"signatures": FIRST_ZERO, "start_state": {"source": "assumed", "state": "demagnetised"}, **kw})
        return d

    d = material()
    layerfit.attach_confounds(d)
    assert d["ambiguous_with"] == ["hall_offset", "remanent_start"] and d["next_measurement"]["protocol"] == "bipolar"
    assert [c["of"] for c in d["confounds"]] == ["signature"]
    assert "B at the first 0 A reading is a remanent start or a Hall offset" in d["verdict"]
    # open at its turning point: the saturating sweep too, said once as the pair's other separator
    d = material(unswitched={"open": True})
    layerfit.attach_confounds(d)
    assert [c["separated_by"] for c in d["confounds"]] == ["bipolar", "saturating"]
    assert d["verdict"].count("B at the first 0 A reading") == 1 and "; or a saturating sweep" in d["verdict"]
    # not where the start is declared, the sweep shows no B at 0 A, a B(H) loop cannot judge a start, the verdict is
    # a measurement effect, or the layers said the same pair already
    for d, skipped in ((material(start_state={"source": "sidecar", "state": "demagnetised"}), ()),
                       (material(signatures=[]), ()), (material(), {"remanent_start": "a B(H) loop's start"})):
        layerfit.attach_confounds(d, skipped)
        assert d["ambiguous_with"] == [] and d["confounds"] == []
    d = material(effect="hall_offset")
    layerfit.attach_confounds(d)
    assert all(c["of"] != "signature" for c in d["confounds"])
    u = {"effect": "hall_offset", "partner": "remanent_start", "separated_by": "bipolar", "why": "w"}
    d = material()
    d["layers"]["verdict"]["unseparated"] = [u]
    layerfit.attach_confounds(d)
    assert [c["of"] for c in d["confounds"]] == ["layers"] and "B at the first 0 A" not in d["verdict"]
    # one bipolar cycle: the reversal wipes a J-A-like remanent start, but the loop's centre is no proof of an offset
    # on a core the models do not follow (bench/heldout_takacs.py: an offset cancelled its off-centre first cycle);
    # a repeat separates them. Repeated cycles: the layers judge an offset on the settled loop
    d = material()
    d["layers"]["evidence"]["protocol"] = "bipolar_single"
    layerfit.attach_confounds(d)
    assert d["ambiguous_with"] == ["hall_offset", "remanent_start"] and d["next_measurement"]["protocol"] == "repeat"
    assert [c["of"] for c in d["confounds"]] == ["signature"] and "first cycle may be off centre" in d["verdict"]
    d = material()
    d["layers"]["evidence"]["protocol"] = "bipolar_repeated"
    layerfit.attach_confounds(d)
    assert d["confounds"] == []


def test_a_material_verdict_lists_an_increment_beyond_its_bound_that_shows_its_signature():
    """layered.decide's ``beyond_bound`` (no effect named): the clip goes into ambiguous_with and confounds
    (``"of": "layers"``) with its separating sweep, and the verdict says it was not named for its size alone."""
    u = {"effect": "sensor_saturation", "partner": None, "separated_by": "half_amplitude", "why": "w",
         "beyond_bound": "clips at 4.04 V vs the declared 4.8 V"}
    d = diag("unexplained", [])
    d["layers"]["verdict"]["beyond_bound"] = [u]
    layerfit.attach_confounds(d)
    assert d["ambiguous_with"] == ["sensor_saturation"] and d["next_measurement"]["protocol"] == "half_amplitude"
    assert d["confounds"][0]["effects"] == ["sensor_saturation", "model_form"] and "rival" not in d["confounds"][0]
    assert "beyond the physical bound (clips at 4.04 V vs the declared 4.8 V): not named, not ruled out" in d["verdict"]
    d = diag("unexplained", [])
    d["layers"]["verdict"]["beyond_bound"] = [u]
    layerfit.attach_confounds(d, skipped={"sensor_saturation": "no sensor"})
    assert d["ambiguous_with"] == [] and d["confounds"] == []
