"""A second look on a finer base for a third-party B(H) loop (issue 23: the Hiperco 50 loop with a 1 % B offset).

A measured B(H) loop has hundreds of distinct H levels; the flexible base (:mod:`.everett`) places ``layers.grid``
(10) switching fields per sign. On a square loop (Hiperco 50: 0.08 T per A/m at its switching fields) that base
leaves 24 mT, ten times the noise floor, and a 19 mT B offset on top is masked: its increment earns (BIC gain 11)
but removes too small a share of what the base leaves and does not predict held-out samples better (the base
re-centres in H instead). Fitting the H offset finely does not help: the base's RSS is a staircase in h0 (flat
between the data's levels), its best step is one the four-point grid already has (measured: 23.0 mT with the offset,
h0 0.57 A/m, at any of 11 h0 from -0.29 to 1.15 A/m). A base of ``layers.fine_grid`` (16) fields resolves the loop to
19.5 mT (clean: 14.3 mT), and the offset increment on it is 20.3 mT (truth 19.1), removes 43 % of what is left,
gains 76 BIC and predicts; on the clean loop it is 0.8 mT and earns nothing.

The finer base costs ~7x the coarse one, so it is paid for only where the coarse one may mislead: a B(H) loop
whose plain verdict is material, where no increment passes on the coarse base but one earns there. Its evidence
replaces the coarse one only when the layered rule then names an effect (``everett.refined_from`` records the coarse
grid); otherwise the coarse evidence stands, with ``second_look`` saying what the finer base found.
"""

from __future__ import annotations

from mrhyst.diagnose import layered, layerfit
from mrhyst.diagnose.lagres import finer_grid


def second_look(prob, ev: dict, skipped: dict, sigs, material: bool, lay_ev: dict, th: dict) -> dict:
    """The layers' evidence to decide on (``lay_ev`` or the finer base's, see the module docstring). ``th``: the
    layered thresholds (:data:`mrhyst.diagnose.layered.LAYER_KEYS`)."""
    sw, lcfg = prob.sw, prob.cfg["layers"]
    if sw.kind != "bh" or not material:
        return lay_ev
    lay = layered.decide(lay_ev, th)
    if lay["effect"] is not None or not any(c.get("earns") for c in lay["checks"].values()):
        return lay_ev
    G2 = finer_grid(sw, int(lcfg["grid"]), int(lcfg["fine_grid"]))
    if G2 is None:
        return lay_ev
    fine = layerfit.evidence(prob, ev, skipped, sigs, material, grid=G2)
    named = layered.decide(fine, th)["effect"]
    if named is None:
        return dict(lay_ev, second_look={"grid": G2, "effect": None})
    fine["everett"] = dict(fine["everett"], grid=G2, refined_from=int(lcfg["grid"]))
    return fine
