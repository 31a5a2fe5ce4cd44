"""What a person reads first (issue 26): the gap of a diagnosis split into parts, and plain-text summaries of
a diagnosis and of a fit. Shared by the CLI (``mrhyst diagnose`` / ``mrhyst fit`` on stdout), the figure
(:mod:`mrhyst.report.diagfig`) and the report; reads only the contract JSON (ARCHITECTURE 4), never refits.

The parts of the gap (all RMS, T):

* ``noise``: the noise floor of the data (``noise_floor_T``);
* ``material``: what a better material model removes from plain J-A's RMS, in quadrature;
* ``measurement``: what a measurement-chain effect removes (on top of the material part where the diagnosis
  splits them), in quadrature;
* ``left``: the RMS left after the verdict's explanation (noise included), also in multiples of the noise.

When the diagnosis carries ``budget: {material_T, measurement_T, left_T}`` (the layered diagnosis of issue
23) those are taken as they are (``source: "budget"``). Otherwise they come from the older contract fields:
the named effect's or model form's RMS after, else the best *partial* candidate of each kind (named False:
it explains that much but was not named), each measured alone against plain J-A (``source: "alone"``), so
material and measurement may overlap and need not add up.
"""

from __future__ import annotations

import math

MEASUREMENT_NONE = ("none", "unexplained", "model_form")


def _explained(before: float | None, after: float | None) -> float | None:
    if before is None or after is None:
        return None
    return math.sqrt(max(before * before - after * after, 0.0))


def final_rms(d: dict) -> float:
    """RMS after the verdict's explanation: with an accepted second effect the pair's, else rms_after_T."""
    sec = d.get("secondary") or {}
    return float(sec["rms_after_T"]) if sec.get("accepted") and sec.get("rms_after_T") is not None else float(
        d["rms_after_T"])


def gap_parts(d: dict) -> dict:
    """{"noise_T", "material_T", "material_named", "material_what", "measurement_T", "measurement_named",
    "measurement_what", "left_T", "left_over_noise", "before_T", "source"} of a diagnosis (module doc)."""
    sigma, before = float(d["noise_floor_T"]), float(d["rms_before_T"])
    eff = d["effect"]
    part = d.get("partial") or {}
    mf = d.get("model_form") or {}
    out = {"noise_T": sigma, "before_T": before}
    if eff == "model_form":
        out.update(material_T=_explained(before, d["rms_after_T"]), material_named=True, material_what=mf.get("best"))
    elif mf.get("best") is not None:
        out.update(material_T=_explained(before, mf.get("rms_after_T")), material_named=False,
                   material_what=mf.get("best"))
    else:
        out.update(material_T=None, material_named=False, material_what=None)
    if eff not in MEASUREMENT_NONE:
        sec = d.get("secondary") or {}
        what = eff + (f" + {sec['effect']}" if sec.get("accepted") else "")
        out.update(measurement_T=_explained(before, final_rms(d)), measurement_named=True, measurement_what=what)
    elif part.get("effect"):
        out.update(measurement_T=_explained(before, part.get("rms_after_T")), measurement_named=False,
                   measurement_what=part["effect"])
    else:
        out.update(measurement_T=None, measurement_named=False, measurement_what=None)
    left = final_rms(d)
    out["source"] = "alone"
    bud = d.get("budget")
    if isinstance(bud, dict) and all(k in bud for k in ("material_T", "measurement_T", "left_T")):
        out.update(material_T=bud["material_T"], measurement_T=bud["measurement_T"], source="budget")
        if bud.get("base"):  # the material part is the layered diagnosis's base, not the model-form candidate
            out.update(material_what=f"base {bud['base']}", material_named=True)
        left = bud["left_T"] if bud["left_T"] is not None else left
    out["left_T"] = left
    out["left_over_noise"] = left / sigma if sigma > 0 else None
    return out


def verdict_title(d: dict) -> str:
    """'VERDICT: hall_offset (ambiguous with remanent_start)' -- the effect and what it cannot be told from."""
    eff = d["effect"]
    if eff == "model_form" and (d.get("model_form") or {}).get("best"):
        eff = f"model_form ({d['model_form']['best']})"
    sec = d.get("secondary") or {}
    if sec.get("accepted"):
        eff += f" + {sec['effect']}"
    amb = d.get("ambiguous_with") or []
    sign = (" - sign reversed (B runs against the current)" if (d.get("sign") or {}).get("reversed") else
            " - the loop runs clockwise" if (d.get("orientation") or {}).get("clockwise") else "")
    return f"verdict: {eff}" + (f" (ambiguous with {', '.join(amb)})" if amb else "") + sign


def _mT(x) -> str:
    return "n/a" if x is None else f"{x * 1e3:.3g} mT"


def size_text(size: dict | None) -> str:
    """'Nd = 0.0123 +- 0.0004' of a reference-mode effect_size ('' without a value)."""
    if not size or size.get("value") is None:
        return ""
    se = size.get("stderr")
    return f"{size['param']} = {size['value']:.4g}" + (f" +- {se:.2g}" if se is not None else "")


def _explains(d: dict, p: dict) -> list:
    """The lines of what explains how much: a reference-mode diagnosis's named change (with its size) against the
    reference held; else the measurement and material parts against plain J-A (named, not named, or budget)."""
    if d.get("mode") == "reference":
        if d["effect"] in MEASUREMENT_NONE:
            return []
        es = d.get("effect_size") or {}
        size = size_text(es) or (f"moved: {', '.join(es['moved']) or 'none significantly'}"
                                 if es.get("moved") is not None else "")
        sec = d.get("secondary") or {}
        what = d["effect"] + (f" + {sec['effect']}" if sec.get("accepted") else "")
        split = d.get("budget") or {}  # the layered budget splits it: a core change is material, an effect not
        parts = [f"{k} {_mT(split.get(k + '_T'))}" for k in ("material", "measurement") if split.get(k + "_T")]
        return [f"  change: {what}" + (f" ({size})" if size else "")
                + f" explains {_mT(_explained(p['before_T'], final_rms(d)))} (named"
                + (f"; {', '.join(parts)}" if parts else "") + ")"]
    out = []
    for kind in ("measurement", "material"):
        if p[f"{kind}_T"] is not None and p[f"{kind}_what"]:
            tag = ("layered budget" if kind == "material" and p["source"] == "budget" else
                   "named" if p[f"{kind}_named"] else "not named")
            out.append(f"  {kind}: {p[f'{kind}_what']} explains {_mT(p[f'{kind}_T'])} ({tag})")
    return out


def diagnosis_summary(d: dict) -> str:
    """A few plain lines of any diagnosis (normal or reference mode, the same lines): the verdict (against which
    reference), how much the base misses and the noise, what explains how much, what is left (mT and x noise)
    and where the gap is largest, the ambiguity and the next measurement if any."""
    p = gap_parts(d)
    ref = d.get("mode") == "reference"
    base = f"the reference {d['reference']['source']}" if ref else "plain J-A"
    lines = [verdict_title(d) + (f" (against the reference {d['reference']['source']})" if ref else "")]
    if (d.get("sign") or {}).get("reversed"):
        lines.append(f"  sign reversed: B runs against the current over whole rising and falling branches "
                     f"({d['sign']['sigma']:.0f} sigma): no material does this; the fits below are of B as declared")
    if (d.get("orientation") or {}).get("clockwise"):
        o = d["orientation"]
        gone = f"; the fits' verdict {o['effect_withdrawn']} is withdrawn" if o.get("effect_withdrawn") else ""
        lines.append(f"  the loop runs clockwise (the integral of H dB is negative, {o['sigma']:.0f} sigma): no "
                     f"material at a fixed temperature does this{gone}")
    lines.append(f"  {base} misses by {_mT(p['before_T'])} RMS; noise floor {_mT(p['noise_T'])} "
                 f"({p['before_T'] / p['noise_T']:.1f}x noise)" if p["noise_T"] > 0 else
                 f"  {base} misses by {_mT(p['before_T'])} RMS")
    lines += _explains(d, p)
    lo = p["left_over_noise"]
    floor = d.get("floor_T") if ref else None  # reference mode: the larger of noise and the calibration RMS
    lines.append(f"  left: {_mT(p['left_T'])}" + (f" = {lo:.1f}x noise" if lo is not None else "")
                 + (f", {p['left_T'] / floor:.1f}x the reference's floor {_mT(floor)} (its RMS at calibration: a "
                    f"calibrated model keeps its own gap)" if floor and floor > p["noise_T"] else "")
                 + (f"; the largest share of the gap is in {d['where']['largest_share_before']}"
                    if (d.get("where") or {}).get("largest_share_before") else ""))
    if d.get("ambiguous_with"):
        why = d.get("ambiguity_reason") or ""
        lines.append(f"  ambiguous with {', '.join(d['ambiguous_with'])}" + (f": {why}" if why else ""))
    nm = d.get("next_measurement")
    if nm:
        sep = nm.get("separation_sigma")
        # mrhyst.diagnose.polarity: the fix (or the check of a clockwise loop), not a sweep to compare
        fix = nm.get("protocol") == "reversed_sign" or bool((d.get("orientation") or {}).get("clockwise"))
        lines.append(f"  next measurement: {nm.get('protocol')}"
                     + (f": {nm.get('why')}" if fix else
                        f" (separates the candidates by {sep:.1f} noise sigma)" if sep is not None else ""))
        for a in nm.get("also") or []:  # the other confounds' separators (issue 23)
            lines.append(f"  and {a['protocol']}: separates {' from '.join(a['separates'])}")
    return "\n".join(lines)


def fit_summary(res: dict, out=None) -> str:
    """One line of a fit: variant, method, RMS (and % of peak), the chosen variant of --model auto; then a line per
    warning of the fit (a parameter at the box edge, an integration error over its tolerance), which the JSON has."""
    peak = [e.get("B_peak_T") for e in res.get("per_loop") or [] if e.get("B_peak_T")]
    rel = f" ({100 * res['rms_T'] / max(peak):.3g} % of peak |B|)" if peak else ""
    sel = res.get("model_choice")
    model = f"{res.get('model', 'ja')}" + (f" (auto: {sel['why']})" if sel else "")
    n = len(res.get("per_loop") or [1])
    warn = list(dict.fromkeys([*(res.get("warnings") or []),
                               *(w for e in res.get("per_loop") or [] for w in (e.get("warnings") or []))]))
    return (f"fit: {model}, {res['method']}, RMS {res['rms_T'] * 1e3:.4g} mT{rel} over {n} loop(s)"
            + (f"; {out}" if out else "") + "".join(f"\n  warning: {w}" for w in warn))


def finish_diagnosis(d: dict, out, figure=None, quiet=None) -> None:
    """`mrhyst diagnose`'s outputs: the figure (if asked), then the JSON, then the plain summary on stdout
    (unless quiet). The figure first: if it cannot be drawn, no JSON is left behind either."""
    from mrhyst.data.io import write_json

    if figure is not None:
        from mrhyst.report import diagfig

        diagfig.save(d, figure)
    write_json(d, out)
    if not quiet:
        print(diagnosis_summary(d))
