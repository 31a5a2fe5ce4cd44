"""A B(H) loop's fault masked by the coarse flexible base is judged again on a finer one (issue 23: the real-cores
benchmark's one miss, Hiperco 50 with a 1 % B offset). The cases come from the benchmark's generator (the injected
offset is its key's size, not the diagnosis's); the loop is the real Hiperco 50 loop of data/external."""

import pytest
import yaml
from mrhyst import diagnose as dg
from mrhyst.blind import realcores
from workflow_util import ROOT


@pytest.fixture(scope="module")
def hiperco(tmp_path_factory):
    d = tmp_path_factory.mktemp("hiperco")
    rc = yaml.safe_load((ROOT / "config.yaml").read_text())["realcores"]
    cfg = realcores.resolve(dict(rc, sources={"hiperco50": str(ROOT / "data/external/hiperco50-pyjam/loop.csv")},
                                 cores=["hiperco50_L0"]))
    key = realcores.generate(cfg, d / "cases", d / "key.json")
    return d, {v["fault"]: (c, v) for c, v in key.items() if v["protocol"] == "bh"}


def test_a_one_percent_b_offset_on_the_square_hiperco_loop_is_named_with_its_size(hiperco):
    d, bh = hiperco
    case, truth = bh["hall_offset"]
    out = dg.diagnose_bh_file(d / "cases" / f"{case}.csv")
    assert out["effect"] == "hall_offset"
    assert abs(out["effect_size"]["value"] - truth["size"]) <= 0.25 * abs(truth["size"])
    # judged on the finer base: the 10-field one leaves 25 mT, more than the 19 mT offset
    assert out["layers"]["evidence"]["everett"]["refined_from"] < out["layers"]["evidence"]["everett"]["grid"]


def test_the_clean_hiperco_loop_stays_clean(hiperco):
    d, bh = hiperco
    case, _ = bh["none"]
    out = dg.diagnose_bh_file(d / "cases" / f"{case}.csv")
    assert out["effect"] in ("unexplained", "model_form", "none")
    assert not set(out["ambiguous_with"]) & {"hall_offset", "sensor_saturation"}
