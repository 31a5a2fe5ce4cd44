"""The figure of one diagnosis (issue 26): where the fit misses, which explanation, how much.

One row of three panels under the verdict as the title:

1. the loop: measured points, plain J-A, J-A with the named effect (or model form), the best candidates
   not named (``partial``) where the diagnosis recorded their curves, the budget's material base (e.g. the flexible
   base's ``B_everett_T``), and an inset zoomed on the largest miss (:func:`mrhyst.report.placement.zoom_inset`);
2. the residual along the path (sample index) of plain J-A and of the verdict's fit, the regions of the loop
   shaded with their share of the squared gap, the noise band, and the model-free signatures when the JSON
   has a ``signatures`` list ([{"kind", "size_T", "sigma", "samples"}], issue 23) marked at their samples;
3. the gap as bars (:func:`mrhyst.report.summary.gap_parts`): noise floor, material, measurement, left.

In reference mode (``mode: "reference"``, ``mrhyst diagnose ... --reference FIT.json``, issue 24) the base is the
calibrated reference model held, the named fit is the reference with the named change, and panel 3 says how
much: the RMS of the reference, of the named change and the floor, with the size of the change
(``effect_size``: e.g. Nd +- stderr), or, for ``material_changed``, each J-A parameter's ratio to the
reference with its standard error (significant ones filled).

The legends and the inset are placed once the figure is laid out, where they cover no label, no largest-miss mark
and the fewest plotted points (:mod:`mrhyst.report.placement`). Drawn from the contract JSON only (ARCHITECTURE 4;
the CLI's ``--figure``, rule ``diagnosis_figure`` and the external diagnoses share it). Byte-stable: Agg, fixed
size and dpi, no date or software in the PNG's metadata.
"""

from __future__ import annotations

import textwrap

import numpy as np

from mrhyst.report.placement import MISS, place_legend, zoom_inset
from mrhyst.report.summary import final_rms, gap_parts, verdict_title
from mrhyst.report.summary import size_text as _size_text

SHORT = {"asc": "up", "desc": "down"}


def _arr(s: dict, k: str):
    v = s.get(k)
    return None if v is None else np.array([np.nan if x is None else x for x in v], dtype=float)


def _runs(labels: np.ndarray, idx: np.ndarray) -> list:
    """[(label, first index, last index)] of the contiguous runs of one label along idx."""
    out = []
    for j, i in enumerate(idx):
        if out and out[-1][0] == labels[i] and idx[j - 1] == i - 1:
            out[-1][2] = i
        else:
            out.append([labels[i], i, i])
    return out


def _region_colors(d: dict, region: np.ndarray) -> dict:
    order = d["where"].get("region_order") or sorted(set(region.tolist()))
    return {r: f"C{k % 10}" for k, r in enumerate(order)}


def _base(d: dict) -> str:
    return "reference model (held)" if d.get("mode") == "reference" else "plain J-A"


BASE_WHAT = {"everett": "a Preisach model with free weights", "ja": "plain J-A"}
EVERETT_COLOR = "C5"  # brown: the flexible base in panels 1 and 2


def budget_base(d: dict) -> tuple[str | None, str | None]:
    """(the material base the layered budget names, where panel 1 draws it): "plain" (plain J-A, ``ja``), "named"
    (the verdict's fit: J-A + a core effect, or the model form named), "model_form" (the best model form, not
    named, drawn dash-dot), "everett" (the flexible base, ``series.B_everett_T``, drawn brown) or None (not in the
    JSON's series, e.g. a JSON written before ``B_everett_T``: panel 1 then says so, and which curve is which)."""
    base = (d.get("budget") or {}).get("base")
    if not base:
        return None, None
    mf = (d.get("model_form") or {}).get("best")
    if base in ("ja", "reference"):  # plain J-A, or the calibrated model held (reference mode)
        return base, "plain"
    if base in ("ja+" + d["effect"], "reference+" + d["effect"]) or (d["effect"] == "model_form" and base == mf):
        return base, "named"
    if base == mf and (d.get("series") or {}).get("B_model_form_T") is not None:
        return base, "model_form"
    if base == "everett" and (d.get("series") or {}).get("B_everett_T") is not None:
        return base, "everett"
    return base, None


def _partial_tag(d: dict, part: dict) -> str:
    """The plain rule's candidate on J-A: "not named", or, where the layers named the same effect on another base
    (a real-cores build: 19 of 88), not named on J-A only."""
    return "on J-A: not named" if part.get("effect") == d.get("effect") else "not named"


def _base_rms(d: dict, base: str) -> float | None:
    b = (((d.get("layers") or {}).get("evidence") or {}).get("bases") or {}).get(base) or {}
    return b.get("rms_T")


def _worst(d: dict, s: dict, v: np.ndarray) -> int:
    """The sample where plain J-A misses most (first of ties)."""
    r = np.abs(_arr(s, "B_T") - _arr(s, "B_before_T"))[v]
    return int(np.flatnonzero(v)[int(np.nanargmax(r)) if np.isfinite(r).any() else 0])


def _loop_panel(ax, d: dict, s: dict, v: np.ndarray) -> None:
    bh = d["input"].get("kind") == "bh"
    x = _arr(s, "current_A")
    B = _arr(s, "B_T") * 1e3
    region = np.array(s.get("region") or [""] * B.size)
    colors = _region_colors(d, region)
    ax.scatter(x[v], B[v], s=9, c=[colors.get(r, "k") for r in region[v]], edgecolors="k", linewidths=0.3,
               label="measured (colour: region, as in 2)", zorder=3)
    k = _worst(d, s, v)
    ax.plot(x[k], B[k], "o", ms=11, mfc="none", mec="r", mew=1.5, zorder=4, label="largest miss (also in 2)",
            gid=MISS)
    ax.plot(x[v], _arr(s, "B_before_T")[v] * 1e3, "-", lw=1.3, color="C0",
            label=f"{_base(d)}: {d['rms_before_T'] * 1e3:.3g} mT RMS")
    eff = d["effect"]
    if eff not in ("none", "unexplained"):
        name = f"model form {d['model_form']['best']}" if eff == "model_form" else f"J-A + {eff}"
        if (d.get("layers") or {}).get("judged_on") == "everett" and s.get("B_everett_T") is not None:
            name = f"flexible base + {eff}"  # series.B_after_T is the base + the effect (mrhyst.diagnose.layerfit)
        veto = (d.get("layers") or {}).get("veto")
        if veto:  # series.B_after_T is that material base's (layerfit.material_veto)
            name = f"material base {veto['material_base']} ({veto['effect']} withdrawn)"
        if d.get("mode") == "reference":
            size = _size_text(d.get("effect_size"))
            name = f"reference + {eff}" + (f" ({size})" if size else "")
        ax.plot(x[v], _arr(s, "B_after_T")[v] * 1e3, "--", lw=1.4, color="C3",
                label=f"{name} (named): {d['rms_after_T'] * 1e3:.3g} mT")
    sec = d.get("secondary") or {}
    if s.get("B_with_secondary_T") is not None and sec.get("accepted"):
        ax.plot(x[v], _arr(s, "B_with_secondary_T")[v] * 1e3, ":", lw=1.6, color="C2",
                label=f"J-A + {eff} + {sec['effect']}: {sec['rms_after_T'] * 1e3:.3g} mT")
    part = d.get("partial") or {}
    if s.get("B_partial_T") is not None:
        ax.plot(x[v], _arr(s, "B_partial_T")[v] * 1e3, ":", lw=1.5, color="C1",
                label=f"J-A + {part.get('effect')} ({_partial_tag(d, part)}): "
                      f"{part.get('rms_after_T', 0) * 1e3:.3g} mT")
    base, drawn = budget_base(d)
    if s.get("B_model_form_T") is not None:
        m = part.get("model_form") or {}
        tag = "not named; the budget's material base (3)" if drawn == "model_form" else (
            "not named" + ("; not the budget's base" if base and base != "ja" else ""))
        ax.plot(x[v], _arr(s, "B_model_form_T")[v] * 1e3, "-.", lw=1.3, color="C4",
                label=f"model form {m.get('best')} ({tag}): {m.get('rms_after_T', 0) * 1e3:.3g} mT")
    if drawn == "everett":  # the flexible base the budget credits (series.B_everett_T)
        r = _base_rms(d, base)
        ax.plot(x[v], _arr(s, "B_everett_T")[v] * 1e3, "-", lw=1.2, color=EVERETT_COLOR,
                label="budget's material base (3): everett (Preisach, free weights)"
                + (f": {r * 1e3:.3g} mT" if r is not None else ""))
    if base and drawn is None:  # the base the budget credits is not a curve of the JSON: say which is which
        r = _base_rms(d, base)
        ax.plot([], [], " ", label=f"budget's material base (3): {base}" + (f", {r * 1e3:.3g} mT" if r is not None
                                                                             else "")
                + f" (not drawn):\n{BASE_WHAT.get(base, 'a material base')}, not a curve of the JSON")
    ax.set_xlabel("H (A/m)" if bh else "current I (A)")
    ax.set_ylabel("B (mT)")
    ax.set_title("1  the loop: data and fits", fontsize=9, loc="left")
    h, labels = ax.get_legend_handles_labels()  # narrow: a loop leaves two corners free, not a panel's width
    labels = ["\n".join(textwrap.fill(p, 30, subsequent_indent="  ") for p in t.split("\n")) for t in labels]
    ax.legend(h, labels, fontsize=6.8, loc="lower right", framealpha=0.85, handlelength=1.6, handletextpad=0.5,
              labelspacing=0.35, borderpad=0.3)  # placed once laid out (placement.place_legend)


def _signatures(ax, d: dict, resid: np.ndarray) -> None:
    for j, sg in enumerate(d.get("signatures") or []):
        idx = np.array([i for i in sg.get("samples") or [] if 0 <= int(i) < resid.size], dtype=int)
        if idx.size == 0:
            continue
        c = f"C{(5 + j) % 10}"
        ax.plot(idx, resid[idx], "D", ms=6, mfc="none", mec=c, mew=1.4, zorder=5)
        size = sg.get("size_T")
        sig = sg.get("sigma")
        lab = f"{sg.get('kind')}" + (f" {size * 1e3:.3g} mT" if size is not None else "") + (
            f" ({sig:.1f} sigma)" if sig is not None else "")
        k = idx[int(np.nanargmax(np.abs(resid[idx])))] if np.isfinite(resid[idx]).any() else idx[0]
        ax.annotate(lab, (k, resid[k]), xytext=(6, 10 + 11 * j), textcoords="offset points", fontsize=7, color=c,
                    fontweight="bold", arrowprops={"arrowstyle": "-", "color": c, "lw": 0.8})


def _residual_panel(ax, d: dict, s: dict, v: np.ndarray) -> None:
    B = _arr(s, "B_T")
    i = np.arange(B.size)
    r0 = (B - _arr(s, "B_before_T")) * 1e3
    best = _arr(s, "B_with_secondary_T") if (d.get("secondary") or {}).get("accepted") else None
    best = best if best is not None else (_arr(s, "B_after_T") if d["effect"] not in ("none", "unexplained")
                                          else None)
    region = np.array(s.get("region") or ["" for _ in i])
    regs = d["where"].get("regions") or {}
    colors = _region_colors(d, region)
    iv = np.flatnonzero(v)
    for lab, a, b in _runs(region, iv):
        share = (regs.get(lab) or {}).get("share_before")
        ax.axvspan(a - 0.5, b + 0.5, color=colors.get(lab, "0.8"), alpha=0.10 + 0.35 * (share or 0.0), lw=0)
        if b - a + 1 >= 0.06 * max(iv.size, 1):
            short = lab.replace("_", "\n")  # narrow: neighbouring runs' labels do not run into each other
            ax.text(0.5 * (a + b), 1.0, f"{short}\n{100 * share:.0f}%" if share is not None else short,
                    transform=ax.get_xaxis_transform(), ha="center", va="top", fontsize=6.2, color="0.25")
    sig = d["noise_floor_T"] * 1e3
    ax.axhspan(-sig, sig, color="0.6", alpha=0.25, lw=0, label=f"noise floor +-{sig:.3g} mT")
    ax.axhline(0, color="0.4", lw=0.6)
    ax.plot(i[v], r0[v], ".-", ms=3, lw=0.7, color="C0", label=_base(d))
    if best is not None:
        ax.plot(i[v], ((B - best) * 1e3)[v], ".-", ms=2.5, lw=0.7, color="C3", label="with the verdict's fit")
    base, drawn = budget_base(d)
    if drawn in ("model_form", "everett"):  # the budget's material base, where it still misses (its curve in 1)
        rb = (B - _arr(s, "B_model_form_T" if drawn == "model_form" else "B_everett_T")) * 1e3
        ax.plot(i[v], rb[v], "-." if drawn == "model_form" else "-", lw=0.8,
                color="C4" if drawn == "model_form" else EVERETT_COLOR, label=f"the budget's material base ({base})")
        both_extra = rb[v]
    else:
        both_extra = np.array([])
    _signatures(ax, d, r0)
    k = _worst(d, s, v)
    ax.plot(k, r0[k], "o", ms=11, mfc="none", mec="r", mew=1.5, zorder=4, gid=MISS)
    right = k - iv[0] < 0.7 * (iv[-1] - iv[0] + 1)  # the label beside the circle, inside the axes
    ax.annotate(f"largest miss {r0[k]:.3g} mT", (k, r0[k]), xytext=(8 if right else -8, -4),
                textcoords="offset points", fontsize=7, color="r", ha="left" if right else "right", zorder=6,
                bbox={"boxstyle": "round,pad=0.15", "fc": "w", "ec": "none", "alpha": 0.8}, gid=MISS)
    both = r0[v] if best is None else np.concatenate([r0[v], ((B - best) * 1e3)[v]])
    both = np.concatenate([both, both_extra])
    lo, hi = float(np.nanmin(both)), float(np.nanmax(both))
    ax.set_ylim(lo - 0.12 * (hi - lo + 1e-12), hi + 0.30 * (hi - lo + 1e-12))
    ax.set_xlim(iv[0] - 0.5, iv[-1] + 0.5)
    ax.set_xlabel("sample index along the path")
    ax.set_ylabel("residual B - model (mT)")
    ax.set_title("2  where it misses (shade: share of the squared gap)", fontsize=9, loc="left")
    ax.legend(fontsize=6.8, loc="lower left", framealpha=0.85)  # placed again once laid out (placement.place_legend)


def _budget_panel(ax, d: dict) -> None:
    p = gap_parts(d)
    names = ["noise\nfloor", "material", "measure-\nment", "left"]
    vals = [p["noise_T"], p["material_T"], p["measurement_T"], p["left_T"]]
    named = [True, p["material_named"], p["measurement_named"], True]
    what = ["", p["material_what"] or "", p["measurement_what"] or "", ""]
    cols = ["0.55", "C4", "C1", "C3" if p["left_over_noise"] and p["left_over_noise"] > 1.5 else "C2"]
    x = np.arange(4)
    h = [0.0 if v is None else v * 1e3 for v in vals]
    bars = ax.bar(x, h, 0.62, color=cols, edgecolor="k", lw=0.6)
    for b, nm in zip(bars, named):
        if not nm:
            b.set_hatch("///")
            b.set_alpha(0.55)
    top = max(h + [p["before_T"] * 1e3]) or 1.0
    ax.axhline(p["before_T"] * 1e3, color="C0", lw=1.0, ls="--",
               label=f"plain J-A misses by {p['before_T'] * 1e3:.3g} mT")
    ax.legend(fontsize=6.8, loc="upper left", framealpha=0.85)
    for k, (v, w, nm) in enumerate(zip(vals, what, named)):
        t = "n/a" if v is None else f"{v * 1e3:.3g} mT"
        if k == 3 and p["left_over_noise"] is not None:
            t += f"\n{p['left_over_noise']:.1f}x noise"
        if w:
            t += "\n" + "\n".join(textwrap.wrap(w, 12, break_long_words=False)) + ("" if nm else "\n(not named)")
            if k == 1 and p["source"] == "budget":
                t += "\n" + _drawn_as(d)
        ax.text(k, h[k] + 0.02 * top, t, ha="center", va="bottom", fontsize=6.5,
                bbox={"boxstyle": "round,pad=0.1", "fc": "w", "ec": "none", "alpha": 0.75})  # over the dashed line
    ax.set_ylim(0, 1.45 * top)
    ax.set_xticks(x, names, fontsize=7.5)
    ax.set_ylabel("RMS (mT)")
    how = "layered budget" if p["source"] == "budget" else "each part alone"
    ax.set_title(f"3  how much ({how})", fontsize=9, loc="left")


def _drawn_as(d: dict) -> str:
    """Where panel 1 shows the budget's material base (a line under its bar)."""
    drawn = budget_base(d)[1]
    return {"plain": "(= plain J-A)", "named": "(red dashed in 1)", "model_form": "(dash-dot in 1)",
            "everett": "(brown in 1)"}.get(drawn, "(not drawn in 1)")


def _moves_bars(ax, moves: dict) -> None:
    """Each J-A parameter's refit / reference - 1 (%) with its standard error; significant ones filled. The axis
    spans the significant moves (at least +-10 %): a parameter the loop does not fix (huge stderr) is clipped."""
    names = list(moves)
    y = np.arange(len(names))[::-1]
    labels, span = [], 10.0
    for yy, n in zip(y, names):
        m = moves[n]
        r, z, se = m.get("ratio"), m.get("z"), m.get("stderr")
        labels.append(f"{n}\n" + ("n/a" if r is None else f"x{r:.3g}") + (f", z {z:+.1f}" if z is not None else ""))
        if r is None:
            continue
        err = None if se is None or not m.get("reference") else 100 * se / abs(m["reference"])
        ax.barh(yy, 100 * (r - 1), 0.6, xerr=err, color="C3" if m.get("significant") else "none", edgecolor="C3",
                lw=1.0, capsize=3)
        if m.get("significant"):
            span = max(span, 1.5 * abs(100 * (r - 1)))
    ax.axvline(0, color="0.3", lw=0.8)
    ax.set_xlim(-span, span)
    ax.set_yticks(y, labels, fontsize=7.5)
    ax.set_xlabel("refit / reference - 1 (%)  (filled: significant)")


def _moved_panel(ax, d: dict) -> None:
    """Reference mode: what moved (material_changed: each parameter) or how much the named change removes."""
    size = d.get("effect_size") or {}
    if size.get("moves"):
        _moves_bars(ax, size["moves"])
        moved = size.get("moved") or []
        ax.set_title(f"3  what moved (a refit of the material)\nRMS {1e3 * d['rms_before_T']:.3g} -> "
                     f"{1e3 * final_rms(d):.3g} mT; " + (f"moved: {', '.join(moved)}" if moved else
                                                         "none significant"), fontsize=9, loc="left")
        return
    vals = [d["rms_before_T"], final_rms(d), d["noise_floor_T"]]
    eff = d["effect"] if d["effect"] not in ("none", "unexplained") else "no change"
    names = ["reference\nmodel", "with\n" + "\n".join(textwrap.wrap(eff.replace("_", " "), 12)), "noise\nfloor"]
    h = [v * 1e3 for v in vals]
    ax.bar(np.arange(3), h, 0.62, color=["C0", "C3", "0.55"], edgecolor="k", lw=0.6)
    top = max(h) or 1.0
    for k, v in enumerate(h):
        ax.text(k, v + 0.02 * top, f"{v:.3g} mT", ha="center", va="bottom", fontsize=7)
    what = _size_text(size)
    also = ", ".join(f"{k} = {a['value']:.3g}" for k, a in (size.get("also") or {}).items()
                     if a.get("value") is not None)
    text = "\n".join(t for t in (what, also) if t)
    if text:
        ax.text(0.97, 0.97, text, transform=ax.transAxes, ha="right", va="top", fontsize=8.5, fontweight="bold",
                color="C3", bbox={"boxstyle": "round", "fc": "w", "ec": "C3", "lw": 0.8})
    ax.set_ylim(0, 1.45 * top)
    ax.set_xticks(np.arange(3), names, fontsize=7.5)
    ax.set_ylabel("RMS (mT)")
    ax.set_title("3  how much (against the reference)", fontsize=9, loc="left")


def draw(d: dict, name: str = ""):
    """The matplotlib Figure of diagnosis ``d`` (a contract dict with ``series``); ``name`` heads the title."""
    import matplotlib

    matplotlib.use("agg")
    from matplotlib.figure import Figure

    from mrhyst.report.plotstyle import mark_synthetic, sidecar_synthetic

    s = d.get("series")
    if not s:
        from mrhyst.data.io import InputError

        raise InputError("the diagnosis has no 'series' (config diagnose.series: false): no figure to draw")
    v = _arr(s, "valid").astype(bool) & np.isfinite(_arr(s, "B_T"))
    fig = Figure(figsize=(15.0, 5.0), dpi=100)
    gs = fig.add_gridspec(1, 3, width_ratios=[1.15, 1.55, 0.8])
    _loop_panel(fig.add_subplot(gs[0]), d, s, v)
    _residual_panel(fig.add_subplot(gs[1]), d, s, v)
    (_moved_panel if d.get("mode") == "reference" else _budget_panel)(fig.add_subplot(gs[2]), d)
    p = gap_parts(d)
    head = (f"{name}: " if name else "") + verdict_title(d)
    if d.get("mode") == "reference":
        head += f" (against the reference {d['reference']['source']})"
    base = budget_base(d)[0]
    on = f" on the material base {base}" + (f" ({BASE_WHAT[base]})" if base in BASE_WHAT and base != "ja" else "")
    sub = (f"{_base(d)} {d['rms_before_T'] * 1e3:.3g} mT -> {p['left_T'] * 1e3:.3g} mT left"
           + (on if base and base != "ja" and p["source"] == "budget" else "")
           + f" ({p['left_over_noise']:.1f}x the noise floor {d['noise_floor_T'] * 1e3:.3g} mT)"
           if p["left_over_noise"] is not None else "")
    nm = d.get("next_measurement")
    where = d["where"].get("largest_share_before")
    if where:
        sub += f"; the largest share of the gap is in {where.replace('_', ' ')}"
    if nm:
        sub += f"; next measurement: {nm.get('protocol')}"
    fig.suptitle(head, fontsize=12, fontweight="bold", x=0.01, ha="left", y=0.995)
    fig.text(0.01, 0.945, sub, fontsize=9, ha="left", va="top")
    fig.tight_layout(rect=(0, 0, 1, 0.92))
    raw = str(d["input"].get("raw") or d["input"].get("source") or "").split(" (loop_index")[0]  # reference: source
    mark_synthetic(fig, bool(raw) and sidecar_synthetic(raw))
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    renderer = FigureCanvasAgg(fig).get_renderer()
    ax1, ax2 = fig.axes[:2]
    _zoom(ax1, d, s, v, renderer)
    for ax in (ax1, ax2):  # once laid out: the legends where they cover no label (panel 3's has its corner)
        place_legend(ax, renderer)
    return fig


ZOOM_MAX = 0.5  # panel 1 zooms on its largest miss only where the window is under this share of its B range


def _zoom(ax, d: dict, s: dict, v: np.ndarray, renderer) -> None:
    """Panel 1's inset around the largest miss (a miss of 1 % of the loop is invisible at the loop's scale): B
    within 2.5 misses (at least 2 noise floors) of the sample, H or I over the span the data's local slope needs
    for that (at most a quarter of the axis). None where that window is not smaller than ``ZOOM_MAX`` of the panel's
    own B range: the miss shows at the loop's scale already (a sensor mounted the other way round misses by the
    loop itself; a zoom larger than the panel drew its frame and connectors across panels 1 and 2)."""
    k = _worst(d, s, v)
    x, B = _arr(s, "current_A"), _arr(s, "B_T") * 1e3
    miss = abs(B[k] - _arr(s, "B_before_T")[k] * 1e3)
    hy = max(2.5 * miss, 2e3 * d["noise_floor_T"], 1e-9)
    if 2 * hy >= ZOOM_MAX * abs(np.subtract(*ax.get_ylim())):
        return
    nb = [j for j in (k - 1, k + 1) if 0 <= j < B.size and v[j] and x[j] != x[k]]
    slope = max((abs((B[j] - B[k]) / (x[j] - x[k])) for j in nb), default=0.0)
    span = np.ptp(x[v])
    hx = min(hy / slope if slope > 0 else span, 0.25 * span)
    zoom_inset(ax, renderer, (x[k] - max(hx, 0.01 * span), x[k] + max(hx, 0.01 * span)), (B[k] - hy, B[k] + hy))


def save(d: dict, path, name: str = "") -> None:
    """Draw ``d`` and write a PNG to ``path`` atomically, the same bytes for the same input."""
    from mrhyst.data.io import atomic_path

    fig = draw(d, name)
    with atomic_path(path) as tmp:
        fig.savefig(tmp, format="png", metadata={"Software": None})
