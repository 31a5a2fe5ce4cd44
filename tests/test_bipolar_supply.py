"""A sensor on a bipolar supply (sidecar supply_min_V < 0: a gaussmeter's +-10 V analog output, a Hall on +-15 V)
reads negative volts: the same field through it gives the same B and the same diagnosis as through a sensor on a
single supply of the same span, its quiescent output defaults to the rails' midpoint, and a reading or a limit
beyond its rails is one line that names them."""

import json

import numpy as np
import pytest
from mrhyst import diagnose as dg
from mrhyst import rig
from mrhyst.data import io
from mrhyst.model import hall, ja
from test_diagnose_signatures import FAST

TRUTH = {"Ms": 1.3e6, "a": 2.2e4, "alpha": 1.5e-3, "c": 0.5, "k": 5.5e3}


def _field():
    up = np.linspace(0.0, 2.0, 27)
    cur = np.concatenate([up, np.linspace(2.0, -2.0, 53)[1:], np.linspace(-2.0, 2.0, 53)[1:]])
    t = rig.sample_times(cur.size, 0.2)
    B, ok = rig.observe(ja.as_param_array(TRUTH), cur, t, 3000.0, [("hall_offset", {"offset_T": 3e-3})])
    assert ok
    return cur, t, B + 1.5e-4 * np.random.default_rng(3).standard_normal(B.size)


def _write(tmp_path, name, cur, t, V, side):
    rig.write_case(tmp_path / f"{name}.csv", {"hall1": V}, t, cur, side)
    return tmp_path / f"{name}.csv"


def _side(rail, supply, q, lo, hi, sens=10.0):
    s = {"sensitivity_V_per_T": sens, "output_min_V": lo, "output_max_V": hi}
    if q is not None:
        s["quiescent_V"] = q
    side = {"supply_V": supply, "coil_turns_per_m": 3000.0, "dwell_s": 0.2, "sensors": {"hall1": s}}
    return side | ({"supply_min_V": rail} if rail else {})


def test_the_quiescent_output_defaults_to_the_rails_midpoint():
    assert hall.quiescent_voltage(15.0, None, -15.0) == 0.0
    assert hall.quiescent_voltage(3.3) == hall.quiescent_voltage(3.3, None, 0.0) == 1.65
    assert hall.quiescent_voltage(15.0, 0.5, -15.0) == 0.5


def test_a_bipolar_supply_reads_and_diagnoses_as_a_single_one_of_the_same_span(tmp_path):
    cur, t, B = _field()
    bip = _write(tmp_path, "bip", cur, t, 10.0 * B, _side(-5.0, 5.0, None, -4.5, 4.5))
    uni = _write(tmp_path, "uni", cur, t, 5.0 + 10.0 * B, _side(0.0, 10.0, 5.0, 0.5, 9.5))
    rb, ru = io.read_raw(bip), io.read_raw(uni)
    assert rb.supply_min_V == -5.0 and rb.sensors["hall1"].quiescent_V == 0.0 and np.min(rb.volts["hall1"]) < 0
    assert np.allclose(rb.volts["hall1"] - 0.0, ru.volts["hall1"] - 5.0, atol=1e-9)
    db, du = (dg.diagnose_file(p, "hall1", config=FAST) for p in (bip, uni))
    assert db["effect"] == du["effect"] and db["ambiguous_with"] == du["ambiguous_with"]
    cb, cu = ({c["effect"]: c for c in d["candidates"]} for d in (db, du))
    assert set(cb) == set(cu)
    for e, c in cb.items():  # the plausible sizes scale with the supply's span, the same 10 V in both
        assert c.get("plausible") == cu[e].get("plausible"), e
        assert c["rms_T"] == pytest.approx(cu[e]["rms_T"], rel=1e-3, abs=1e-7), e


@pytest.mark.parametrize("side,match", [
    (_side(0.0, 15.0, None, None, None), r"row 3, column hall1_V: -4 V is outside the sensor's supply \(0 \.\. 15 V, "
                                         r"sidecar supply_V\); expected volts of a Hall output; a sensor on a bipolar "
                                         r"supply: declare supply_min_V in the sidecar"),
    (_side(-5.0, 15.0, None, None, None), r"outside the sensor's supply \(supply_min_V -5 \.\. supply_V 15 V\)"),
    (_side(-15.0, 15.0, -20.0, None, None), r"quiescent_V -20 V is outside the supply \(supply_min_V -15 \.\. "
                                            r"supply_V 15 V\)"),
    (_side(3.0, 15.0, None, None, None), r"supply_min_V"),
])
def test_a_reading_or_a_setting_beyond_the_rails_is_one_line_naming_them(tmp_path, side, match):
    cur = np.array([0.0, 0.5, 1.0, 0.5, 0.0])
    V = np.array([0.0, -4.0, -9.0, -6.0, -1.0])
    p = _write(tmp_path, "bad", cur, np.arange(5) * 0.2, V, side)
    with pytest.raises(io.InputError, match=match):
        io.read_raw(p)
    assert json.loads(p.with_suffix(".json").read_text()) == side
