"""Calibrate the diagnosis policy's thresholds on a closed AND an open world (issue 12).

`NUMBA_NUM_THREADS=1 python bench/calibrate_policy.py --out /tmp/calib.json [--n-closed 8] [--n-open 12]`
then `python bench/calibrate_policy.py --curve /tmp/calib.json` prints the trade-off table.
`python bench/calibrate_policy.py --blind SEED --blind-dir DIR` builds the project's blind benchmark (config
``blind`` with another seed) in-process, diagnoses every case (evidence kept in DIR/diag) and scores it.

* **Closed world**: cases of the project's blind generator (:func:`mrhyst.blind.draw_cases`, detectable
  effects only, every class of config ``blind``), another seed than the benchmark's.
* **Open world**: sweeps whose gap comes from OUTSIDE the vocabulary, written here with code that does not
  use the diagnosis's forward functions for those mechanisms, through the same sensor chain (A1304 transfer,
  white noise, 16-bit ADC), the paper's 0 -> 2 A -> 0 protocol:
  - ``tanh_law``: a rate-independent phenomenological loop, B = mu0 H + Bs tanh(H / H0) on the way up and
    a branch shifted by the coercive field Hc on the way down, continuous at the turning point;
  - ``two_phase``: the J-A core plus a second, softer or harder J-A phase of 5-30 % of its Ms (MR-fluid
    particles; the J-A kernel itself, but not the diagnosis's model-form code);
  - ``hall_gain``: a Hall sensor whose gain falls with |B|, B_obs = B (1 - g (B / B_peak)^2), g in 2-10 %;
  - ``preisach_mc``: a Preisach core of 3000 random hysterons (Cauchy-distributed coercive fields, normal
    interaction fields) plus a reversible susceptibility, states tracked one by one.
  A verdict of a measurement-chain effect on these is a *false attribution*; ``model_form``, ``unexplained``
  and ``none`` are not (``none`` only says that the gap is within the noise).

Every diagnosis's ``evidence`` block is kept, so that :func:`mrhyst.diagnose.policy.decide` can be re-run
with other thresholds (``--curve``). Timings are wall time per diagnosis on a shared, loaded machine.
"""

from __future__ import annotations

import argparse
import copy
import json
import math
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import yaml
from mrhyst import blind, rig
from mrhyst import diagnose as dg
from mrhyst.diagnose import policy
from mrhyst.model import effects as fx
from mrhyst.model import ja

ROOT = Path(__file__).resolve().parent.parent
OPEN = ("tanh_law", "two_phase", "hall_gain", "preisach_mc")
GAP_FACTOR = 1.5  # an open-world sweep "has a gap" when plain J-A leaves more than this x the noise floor
MEASUREMENT = tuple(fx.REGISTRY)  # the measurement-chain effects: every registered one


def _lu(rng, lo, hi):
    return float(math.exp(rng.uniform(math.log(lo), math.log(hi))))


def _preisach_mc(H, rng, scale):
    n = 3000
    hc = np.abs(rng.standard_cauchy(n)) * scale["hc"] + 1e-3 * scale["hc"]
    hu = rng.normal(0.0, scale["hu"], n)
    s = np.where(hu < 0, 1.0, -1.0)
    M = np.empty(H.size)
    for j, h in enumerate(H):
        s[hu + hc <= h] = 1.0
        s[hu - hc >= h] = -1.0
        M[j] = s.mean()
    return M


def open_B(kind, rng, truth, current, nle, time_s):
    """Noise-free B (T) of an out-of-vocabulary mechanism, and a record of its parameters."""
    H = nle * current
    hmax = float(H.max())
    B0, ok = ja.simulate(ja.as_param_array(truth), current, nle, form="physical", substeps=8)
    peak = float(np.max(B0))
    if kind == "tanh_law":
        H0, bs = hmax * _lu(rng, 0.5, 3.0), peak
        hc = H0 * _lu(rng, 0.03, 0.3)
        up = ja.MU0 * H + bs * np.tanh(H / H0)
        down = ja.MU0 * H + bs * (np.tanh((H + hc) / H0) - np.tanh((hmax + hc) / H0) + np.tanh(hmax / H0))
        ipk = int(np.argmax(current))
        B = np.where(np.arange(H.size) <= ipk, up, down)
        return B, {"H0": H0, "Hc": hc}
    if kind == "two_phase":
        frac = _lu(rng, 0.05, 0.3)
        p2 = dict(truth, Ms=truth["Ms"] * frac, a=truth["a"] * _lu(rng, 0.1, 10), k=truth["k"] * _lu(rng, 0.1, 10),
                  c=rng.uniform(0.1, 0.9), alpha=truth["alpha"] * rng.uniform(0, 1))
        B2, ok2 = ja.simulate(ja.as_param_array(p2), current, nle, form="physical", substeps=8)
        return B0 + B2 - ja.MU0 * H, {"phase2": p2, "frac": frac}
    if kind == "hall_gain":
        g = _lu(rng, 0.02, 0.1)
        return B0 * (1.0 - g * (B0 / peak) ** 2), {"g": g}
    if kind == "preisach_mc":
        sc = {"hc": hmax * _lu(rng, 0.05, 0.5), "hu": hmax * _lu(rng, 0.02, 0.3)}
        chi = peak / (ja.MU0 * hmax) * rng.uniform(0.2, 0.6)
        m = _preisach_mc(H, rng, sc)
        ms = (peak - ja.MU0 * hmax * (1 + chi)) / max(float(m.max()), 1e-3)
        return ja.MU0 * (H * (1 + chi) + max(ms, 0.0) / ja.MU0 * m), {"chi": chi, **sc}
    raise ValueError(kind)


def _drive(rng, bcfg):
    """(current, truth, N/Le, sigma, dwell, times) of one sweep, drawn like the blind benchmark's."""
    current = ja.paper_current_path(float(bcfg["i_max_A"]), int(bcfg["n_up"]))
    tb = bcfg["truth_box"]
    truth = {n: _lu(rng, *tb[n]) for n in ja.PARAM_NAMES}
    ranges = bcfg["n_over_le_ranges"]
    nle = _lu(rng, *ranges[int(rng.integers(0, len(ranges)))])
    sigma = float(rng.choice(np.asarray(bcfg["noise_sigma_T"], dtype=float)))
    dwell = _lu(rng, *bcfg["dwell_s"])
    t = rig.sample_times(current.size, dwell)
    return current, truth, nle, sigma, dwell, t


def write_open(path, kind, rng, bcfg):
    current, truth, nle, sigma, dwell, t = _drive(rng, bcfg)
    B, rec = open_B(kind, rng, truth, current, nle, t)
    sens = float(f"{min(5.0, 1.3 / float(np.max(np.abs(B)))):.2g}")
    V = rig.quantise(1.65 + sens * (B + sigma * rng.standard_normal(B.size)))
    side = {"supply_V": 3.3, "coil_turns_per_m": round(nle, 3), "dwell_s": dwell,
            "sensors": {"hall1": {"sensitivity_V_per_T": sens, "quiescent_V": 1.65}}}
    rig.write_case(path, {"hall1": V}, t, current, side)
    return {"class": kind, "world": "open", "sigma_T": sigma, "n_over_le": nle, "truth": truth, "mechanism": rec}


def load_unseen(path):
    """Another generator of out-of-vocabulary sweeps (e.g. branch openworld's mrhyst/blind/openworld.py: draw, field,
    sense), loaded from a file as mrhyst.blind.openworld so that its relative imports resolve."""
    import importlib.util

    spec = importlib.util.spec_from_file_location("mrhyst.blind.openworld", path)
    mod = importlib.util.module_from_spec(spec)
    sys.modules["mrhyst.blind.openworld"] = mod
    spec.loader.exec_module(mod)
    return mod


def write_unseen(path, kind, rng, bcfg, ow):
    current, truth, nle, sigma, dwell, t = _drive(rng, bcfg)
    mp = ow.draw(kind, rng, truth)
    B, _, ok = ow.field(kind, mp, truth, current, t, nle)
    sens = float(f"{min(5.0, 1.3 / float(np.max(np.abs(B)))):.2g}")
    v, t, cur, side = ow.sense(B, t, current, noise_sigma_T=sigma, seed=int(rng.integers(0, 2**31 - 1)),
                               n_over_le=nle, dwell_s=dwell, sensitivity_V_per_T=sens)
    rig.write_case(path, v, t, cur, side)
    return {"class": kind, "world": "unseen", "sigma_T": sigma, "n_over_le": nle, "mechanism": mp}


def run(args):
    cfg = yaml.safe_load((ROOT / "config.yaml").read_text())
    # closed-world classes only (config blind also lists compound and open-world classes, with counts)
    bcfg = dict(cfg["blind"], seed=args.seed, n_per_class=args.n_closed, classes=list(blind.CLOSED), counts={})
    dcfg = dict(cfg.get("diagnose") or {}, series=False, **json.loads(args.diag_config))
    out = []
    tmp = Path(tempfile.mkdtemp())
    if args.unseen:  # only the other generator's sweeps (validation: thresholds are not tuned on these)
        ow = load_unseen(args.unseen)
        rng = np.random.default_rng(args.seed + 2)
        for kind in ow.MECHANISMS:
            for i in range(args.n_open):
                p = tmp / f"unseen_{kind}_{i:02d}.csv"
                out.append(dict(write_unseen(p, kind, rng, bcfg, ow), path=str(p)))
        return _diagnose_all(out, dcfg, args.out)
    for spec in blind.draw_cases(bcfg):  # the key's reference fit is independent of the diagnose config
        v, t, cur, side = blind.simulate(spec, bcfg)
        p = tmp / f"{spec['id']}.csv"
        rig.write_case(p, v, t, cur, side)
        out.append({"class": spec["class"], "world": "closed", "sigma_T": spec["noise_sigma_T"], "path": str(p)})
    rng = np.random.default_rng(args.seed + 1)
    for kind in OPEN:
        for i in range(args.n_open):
            p = tmp / f"open_{kind}_{i:02d}.csv"
            out.append(dict(write_open(p, kind, rng, bcfg), path=str(p)))
    return _diagnose_all(out, dcfg, args.out)


def _diagnose_all(out, dcfg, dest):
    for k, rec in enumerate(out):
        t0 = time.perf_counter()
        d = dg.diagnose_file(rec["path"], "hall1", config=dcfg)
        rec.update(seconds=time.perf_counter() - t0, effect=d["effect"], evidence=d["evidence"],
                   rms_before_T=d["rms_before_T"], noise_floor_T=d["noise_floor_T"])
        print(f"{k + 1}/{len(out)} {rec['world']} {rec['class']}: {d['effect']} ({rec['seconds']:.1f} s)",
              file=sys.stderr, flush=True)
        Path(dest).write_text(json.dumps(out))
    return out


def blind_run(seed: int, dest: Path, kind: str = "all") -> dict:
    """The project's blind benchmark (config ``blind``, its seed replaced) built in-process: cases and key into
    ``dest`` (kept: re-running diagnoses only what is missing), one diagnosis per case into ``dest/diag`` (its
    ``evidence`` re-decidable by :func:`mrhyst.diagnose.policy.decide`), scored by :mod:`mrhyst.blind.scoring`.
    ``kind``: diagnose only the closed, compound or openworld cases (the score covers what is there)."""
    from mrhyst.blind import scoring
    from mrhyst.data import io

    cfg = yaml.safe_load((ROOT / "config.yaml").read_text())
    bcfg = dict(cfg["blind"], seed=seed)
    dcfg = dict(cfg["diagnose"], series=False)
    key_path, diag = dest / "key.json", dest / "diag"
    if not key_path.exists():
        blind.generate(bcfg, dest / "cases", key_path)
    diag.mkdir(parents=True, exist_ok=True)
    key = json.loads(key_path.read_text())["cases"]
    for cid in sorted(key):
        out = diag / f"{cid}.json"
        if out.exists() or kind not in ("all", key[cid]["kind"]):
            continue
        t0 = time.perf_counter()
        try:
            d = dg.diagnose_file(dest / "cases" / f"{cid}.csv", blind.SENSOR, config=dcfg)
        except io.InputError as e:
            d = {"effect": scoring.FAILED, "error": str(e), "ambiguous_with": [], "rms_before_T": None,
                 "rms_after_T": None, "noise_floor_T": None}
        d["seconds"] = time.perf_counter() - t0
        io.write_json(d, out)
        print(f"{cid} {key[cid]['class']}: {d['effect']} ({d['seconds']:.1f} s)", file=sys.stderr, flush=True)
    paths = sorted(diag.glob("*.json"))
    r = scoring.score(paths, key_path, bcfg)
    secs = [json.loads(p.read_text()).get("seconds") for p in paths]
    secs = [x for x in secs if x is not None]
    o, c, w = r["overall"], r["compound"], r["open_world"]
    print(f"blind seed {seed}: {r['n_cases']} cases; closed top-1 strict {o['top1_strict']}, fair {o['top1_fair']}; "
          f"compound one of pair {c['one_of_pair']}, both named {c['both_named']} (n = {c['n']}); open world false "
          f"attribution {w['false_attribution']} (n gap = {w['n_gap']}), model-form recall {w['model_form_recall']}; "
          f"seconds per verdict median {np.median(secs) if secs else None}, max {max(secs, default=None)} "
          f"(wall time on a shared machine)")
    return r


def measures(cases, th):
    """(closed top-1 (named or tied with the truth), open false attribution, open model_form-or-unexplained,
    per-class detail, closed strict top-1)."""
    closed = [c for c in cases if c["world"] == "closed"]
    opn = [c for c in cases if c["world"] in ("open", "unseen")]
    dec = [policy.decide(copy.deepcopy(c["evidence"]), th) for c in cases]
    tied = {id(c): c["class"] in [v["effect"], *v["ambiguous_with"]] for c, v in zip(cases, dec)}
    by = {id(c): v["effect"] for c, v in zip(cases, dec)}
    strict = sum(by[id(c)] == c["class"] for c in closed) / max(len(closed), 1)
    top1 = sum(tied[id(c)] for c in closed) / max(len(closed), 1)
    false = sum(by[id(c)] in MEASUREMENT for c in opn) / max(len(opn), 1)
    honest = sum(by[id(c)] in ("model_form", "unexplained") for c in opn) / max(len(opn), 1)
    gap = [c for c in opn if c["rms_before_T"] > GAP_FACTOR * c["noise_floor_T"]]
    false_gap = sum(by[id(c)] in MEASUREMENT for c in gap) / max(len(gap), 1)
    detail = {"_false_on_gap": f"{false_gap:.3f} of {len(gap)} open sweeps with plain J-A > {GAP_FACTOR} x floor"}
    for c in cases:
        detail.setdefault(f"{c['world']}:{c['class']}", {}).setdefault(by[id(c)], 0)
        detail[f"{c['world']}:{c['class']}"][by[id(c)]] += 1
    return top1, false, honest, detail, strict


def curve(paths):
    cases = [c for p in paths.split(",") for c in json.loads(Path(p).read_text())]
    from mrhyst.model import effects as fx

    for c in cases:  # evidence saved before the registry carried branch_identifiable
        for e, st in c["evidence"]["candidates"].items():
            st.setdefault("branch_identifiable", fx.REGISTRY[e].branch_identifiable)
            st.setdefault("block_identifiable", fx.REGISTRY[e].block_identifiable)
        for p in c["evidence"]["pairs"]:
            p.setdefault("branch_identifiable", all(fx.REGISTRY[e].branch_identifiable for e in p["effects"]))
            p.setdefault("block_identifiable", all(fx.REGISTRY[e].block_identifiable for e in p["effects"]))
    base = dict(policy.DEFAULT_THRESHOLDS)
    print(f"{'close':>6} {'held':>6} {'blocks':>6} {'mfm':>5}  closed_top1(tied) strict  open_false  open_mf_or_unexpl")
    for close in (1.2, 1.3, 1.4, 1.5, 2.0, 100.0):
        for held in (1.0, 1.5, 2.0, 2.5, 3.0, 5.0, 1e9):
            for blocks in (1.0, 1.5, 1e9):
                for mfm in (-1e9, 0.0, 6.0, 10.0, 15.0):
                    th = dict(base, close_factor=close, heldout_factor=held, blocks_factor=blocks,
                              model_form_margin=mfm)
                    t1, fa, hon, _, st = measures(cases, th)
                    print(f"{close:6.1f} {held:6.0g} {blocks:6.0g} {mfm:5.0f}  {t1:11.3f} {st:6.3f}  {fa:10.3f}  "
                          f"{hon:10.3f}")
    t1, fa, hon, detail, st = measures(cases, base)
    print("default thresholds:", base)
    print(f"closed top-1 {t1:.3f} (strict {st:.3f}), open false attribution {fa:.3f}, open model_form/unexplained "
          f"{hon:.3f}")
    for k, v in sorted(detail.items()):
        print(f"  {k:18s} {v}")
    secs = [c["seconds"] for c in cases]
    print(f"seconds per diagnosis: median {np.median(secs):.1f}, max {max(secs):.1f} (n = {len(secs)})")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default="/tmp/calib.json")
    ap.add_argument("--curve", help="saved run(s), comma-separated: print the trade-off table")
    ap.add_argument("--seed", type=int, default=424242)
    ap.add_argument("--n-closed", type=int, default=8)
    ap.add_argument("--n-open", type=int, default=12)
    ap.add_argument("--diag-config", default="{}", help="JSON overrides of the diagnose section")
    ap.add_argument("--unseen", help="a generator module file (draw, field, sense, MECHANISMS) to validate on")
    ap.add_argument("--blind", type=int, metavar="SEED", help="build the blind benchmark (config blind, this seed) "
                    "in-process into --blind-dir, diagnose every case, score it")
    ap.add_argument("--blind-dir", default="/tmp/blind_inprocess")
    ap.add_argument("--blind-kind", default="all", choices=("all", "closed", "compound", "openworld"))
    args = ap.parse_args(argv)
    if args.blind is not None:
        blind_run(args.blind, Path(args.blind_dir), args.blind_kind)
    elif args.curve:
        curve(args.curve)
    else:
        run(args)


if __name__ == "__main__":
    main()
