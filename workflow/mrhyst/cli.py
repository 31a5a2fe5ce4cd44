"""``mrhyst``: the command line for a lab's own files (ARCHITECTURE section 4).

    mrhyst convert RAW.csv --sensor hall1 --out LOOP.csv
    mrhyst simulate (--params FIT.json | --Ms .. --a .. --alpha .. --c .. --k ..) [--path paper|fig2|FILE.csv]
                    --n-over-le X [--form paper|physical] --out LOOP.csv
    mrhyst fit LOOP.csv --method pso|lsm [--form paper|physical] [--seed N] [--pso-setting NAME]
               [--loop-index N|all|0,2] [--model ja|...|auto] [--joint-weight W]
               [--start demagnetised|first_sample|fit|cyclic] [--quiet]
               [--config config.yaml] --out FIT.json       (model curves: FIT.curve.csv)
    mrhyst diagnose RAW.csv --sensor hall1 [--config config.yaml] [--figure D.png] [--quiet] --out DIAG.json
    mrhyst diagnose RAW.csv --sensor hall1 | BH.csv [--loop-index N]  --reference FIT.json|table1:SET --out DIAG.json
    mrhyst fit FILE.csv --loop-index all --temperature-laws --method lsm --out FIT.json
    mrhyst blind generate --config config.yaml --cases DIR --key KEY.json [--n-per-class N] [--seed N]
    mrhyst blind score DIAG.json|DIR ... --key KEY.json --config config.yaml --out SCORE.json

Exit 0 on success; on a user error one line on stderr and exit 2, with no
output file written (all writers are atomic). Everything a user gives is checked
before the work starts (the output folder is writable, the config is valid, the
input can be fitted), so a mistake costs no computing time and leaves nothing behind.
"""

from __future__ import annotations

import argparse
import contextlib
import math
import os
import sys
import tempfile
from pathlib import Path

from mrhyst import __version__
from mrhyst.config import load_config
from mrhyst.errors import ConfigError, InputError
from mrhyst.model import names


class _Lazy:
    """A module imported on first use: the command line starts without numpy, pandas or numba (`mrhyst --help`
    at once, issue 26); a command imports what it uses when it runs."""

    def __init__(self, name: str):
        self._name = name

    def __getattr__(self, attr):
        import importlib

        return getattr(importlib.import_module(self._name), attr)


np = _Lazy("numpy")
ja = _Lazy("mrhyst.model.ja")


def _io(name: str):
    """mrhyst.data.io's function ``name``, imported when first called (pandas and numpy with it)."""

    def call(*args, **kw):
        from mrhyst.data import io

        return getattr(io, name)(*args, **kw)

    return call


(check_fittable, check_out_target, raw_to_loop, read_json, read_loop, read_raw, sidecar_path, write_csv,
 write_json) = map(_io, ("check_fittable", "check_out_target", "raw_to_loop", "read_json", "read_loop", "read_raw",
                         "sidecar_path", "write_csv", "write_json"))

START_STATES = ("demagnetised", "first_sample", "fit", "cyclic")  # = identify.START_STATES


class _Parser(argparse.ArgumentParser):
    def error(self, message):  # one line, exit 2 (argparse prints usage too; keep it to one line)
        sys.stderr.write(f"mrhyst: error: {message}\n")
        raise SystemExit(2)


def _int_in(lo: int, hi: int | None = None):
    """argparse type: a whole number in [lo, hi] (hi None: no upper limit)."""
    want = f"a whole number >= {lo}" if hi is None else f"a whole number in {lo} .. {hi}"

    def parse(text: str) -> int:
        try:
            v = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected {want}, got {text!r}") from None
        if v < lo or (hi is not None and v > hi):
            raise argparse.ArgumentTypeError(f"expected {want}, got {v}")
        return v

    return parse


_positive_int = _int_in(1)
_nonneg_int = _int_in(0, 2**32 - 1)


def _finite_float(text: str) -> float:
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None
    if not math.isfinite(v):
        raise argparse.ArgumentTypeError(f"expected a finite number, got {text!r}")
    return v


def _loop_selection(text: str) -> str:
    """argparse type of --loop-index: N, 'all', or a comma list of whole numbers (checked, kept as text)."""
    t = text.strip()
    if t != "all":
        try:
            [int(v) for v in t.split(",")]
        except ValueError:
            raise argparse.ArgumentTypeError(
                f"expected a whole number, 'all' or a list like 0,2; got {text!r}") from None
    return t


def _out_path(p: str, *inputs, flag: str = "--out", others: dict | None = None) -> Path:
    """Check an output (``flag``: --out, --figure, or a side file such as FIT.curve.csv) before any work: a file
    path (not a folder), a regular file or absent (never a device, FIFO or socket: the atomic writer's rename would
    replace it), none of ``inputs`` (every file the command reads: the CSV, a raw sweep's sidecar, the config, a
    reference), none of the command's ``others`` outputs ({flag: path}; compared as paths, so also before either
    exists: one would overwrite the other), in a writable folder.

    The folder may not exist yet (the writer creates it); then its nearest existing ancestor must be a
    writable folder. Writability is probed with a temporary file (os.access says yes to root even on a
    read-only file system), which is removed at once.
    """
    path = Path(p)
    if str(p).endswith(("/", os.sep)) or (path.exists() and path.is_dir()):
        raise InputError(f"{path}: is a folder; {flag} needs a file path")
    check_out_target(path, inputs, flag)
    for f, o in (others or {}).items():
        if o is not None and Path(o).resolve() == path.resolve():
            raise InputError(f"{path}: {flag} is also {f}; one would overwrite the other, choose another path")
    anc = path.parent if str(path.parent) else Path(".")
    while not anc.exists():
        if anc.is_symlink():
            raise InputError(f"{path}: output folder {anc} is a broken link")
        anc = anc.parent
    if not anc.is_dir():
        raise InputError(f"{path}: output folder {anc} is a file, not a folder")
    try:
        fd, probe = tempfile.mkstemp(prefix=".mrhyst-probe-", dir=anc)
    except OSError as e:
        raise InputError(f"{path}: output folder {anc} is not writable ({e.strerror})") from None
    os.close(fd)
    with contextlib.suppress(OSError):
        os.unlink(probe)
    return path


def _fit_config(path) -> dict:
    """config.yaml for `fit --config`, checked before any work: the schema and semantic checks of
    mrhyst.config (unknown keys, types, box lower < upper), plus the fit's own, one line each."""
    cfg = load_config(path)
    src = str(path)
    m0 = (cfg.get("pso") or {}).get("m0_range")
    if isinstance(m0, (list, tuple)) and len(m0) == 2 and not m0[0] < m0[1]:
        raise ConfigError(f"{src}: pso.m0_range: lower ({m0[0]}) must be below upper ({m0[1]})")
    from mrhyst.materials.extsettings import external_config

    external_config(cfg, src)  # the external section merged over its defaults and range-checked
    return cfg


def cmd_convert(args) -> None:
    out = _out_path(args.out, args.raw, sidecar_path(args.raw))
    raw = read_raw(args.raw)
    df = raw_to_loop(raw, args.sensor)
    write_csv(df, out)


def _params_from_args(args) -> np.ndarray:
    if args.params:
        d = read_json(args.params)
        d = d.get("params", d) if isinstance(d, dict) else d
        if not isinstance(d, dict):
            raise InputError(f"{args.params}: expected an object with {', '.join(ja.PARAM_NAMES)} (or 'params')")
        missing = [n for n in ja.PARAM_NAMES if n not in d]
        if missing:
            raise InputError(f"{args.params}: missing parameter(s) {', '.join(missing)}")
        vals = {n: d[n] for n in ja.PARAM_NAMES}
        src = str(args.params)
    else:
        vals = {n: getattr(args, n) for n in ja.PARAM_NAMES}
        missing = [n for n, v in vals.items() if v is None]
        if missing:
            raise InputError("simulate: give --params FILE or all of --Ms --a --alpha --c --k "
                             f"(missing {', '.join(missing)})")
        src = "command line"
    from mrhyst.data.io import json_number

    for n, v in vals.items():
        if not json_number(v) or not np.isfinite(v):
            raise InputError(f"{src}: parameter {n} must be a finite number, got {v!r}")
    p = np.array([float(vals[n]) for n in ja.PARAM_NAMES])
    if not (p[0] > 0 and p[1] > 0 and p[4] > 0 and 0 <= p[3] < 1):
        raise InputError(f"{src}: parameters outside the physical range (Ms, a, k > 0; 0 <= c < 1): "
                         + ", ".join(f"{n}={v:g}" for n, v in zip(ja.PARAM_NAMES, p)))
    return p


def cmd_simulate(args) -> None:
    from mrhyst.paper.fig2 import fig2_current_path, loop_frame

    # resolved once: a flag given > the --config file's simulate section > the schema's defaults
    given = {"path": args.path, "i_max_A": args.i_max, "form": args.form, "substeps": args.substeps}
    cfg = resolve_section("simulate", load_config(args.config).get("simulate") if args.config else None, given)
    path = None if cfg["path"] in ("paper", "fig2") else cfg["path"]
    if not float(cfg["i_max_A"]) > 0:  # a flag given is not checked against the schema's range
        raise InputError(f"simulate: --i-max must be > 0 A (the peak of the sweep), got {cfg['i_max_A']:g}")
    out = _out_path(args.out, args.params, args.config, path, path and sidecar_path(path))
    p = _params_from_args(args)
    if not (args.n_over_le > 0 and np.isfinite(args.n_over_le)):
        raise InputError(f"simulate: --n-over-le must be > 0, got {args.n_over_le}")
    if cfg["path"] == "paper":
        current = ja.paper_current_path(cfg["i_max_A"], 27)
    elif cfg["path"] == "fig2":
        current = fig2_current_path(cfg["i_max_A"], 0.01)
    else:
        path = Path(cfg["path"])
        if path.with_suffix(".json").is_file():
            current = read_raw(path).current_A
        else:
            loop = read_loop(path)
            if loop.current_A is None:
                raise InputError(f"{path}: no current_A column; --path takes paper, fig2, a raw sweep or a loop file")
            current = loop.current_A
    B, ok = ja.simulate(p, current, args.n_over_le, form=cfg["form"], substeps=int(cfg["substeps"]))
    if not ok:
        raise InputError("simulate: the J-A integration failed for these parameters "
                         "(Eq. 8 denominator reached 0: alpha |Man - Mirr| >= k); no output written")
    write_csv(loop_frame(current, args.n_over_le, B), out)


def cmd_fit(args) -> None:
    from mrhyst import startup
    from mrhyst.data.io import loop_indices, read_loops
    from mrhyst.fit import identify

    startup.imported()

    out = _out_path(args.out, args.loop, args.config)
    from mrhyst.data.curves import curve_path

    _out_path(str(curve_path(out)), args.loop, args.config, flag="the model curves beside --out",
              others={"--out": out})
    if args.temperature_laws:  # issue 24: one material, J-A parameters as laws of the loops' temperature_C
        from mrhyst.materials import templaws

        templaws.check_cli(args)
        templaws.fit_file(args.loop, loop_index=args.loop_index, form=args.form,
                          config=_fit_config(args.config) if args.config else None, start=args.start, out=out)
        return
    settings = fit_settings(args)
    unused = [f for f, v in (("--seed", args.seed), ("--pso-setting", args.pso_setting)) if v is not None]
    if args.method == "lsm" and unused:  # said, not silently dropped (the JSON records seed: null, setting: lsm)
        print(f"mrhyst fit: note: {' and '.join(unused)} {'is' if len(unused) == 1 else 'are'} for --method pso; "
              "the least-squares fit starts from its fixed start and draws no random numbers", file=sys.stderr)
    if args.model not in (None, "auto"):
        identify.model_spec(args.model)  # an unknown variant: one line before any work
    # PSO: --pso-setting, else config pso.cli_setting (a convergent swarm + least-squares polish, issue 14);
    # the paper's own setting (pso.setting, used by Tables 1-3) is `--pso-setting paper`
    setting = settings.pso.cli_setting if args.method == "pso" else None
    sel = args.loop_index
    if sel is not None and sel.strip() != "all" and "," not in sel:
        sel = identify.parse_loop_selection(sel, [])
        read_loop(args.loop, sel)  # a file with several loops needs --loop-index
    elif sel is None:
        check_fittable(read_loop(args.loop))
    else:
        sel = identify.parse_loop_selection(sel, loop_indices(read_loops(args.loop)))
    if args.joint_weight is not None and not isinstance(sel, list):
        raise InputError(f"{args.loop}: --joint-weight is for a joint fit (--loop-index all or a list like 0,2)")
    res = identify.fit_file(args.loop, method=args.method, out=out, config=settings, loop_index=sel, setting=setting)
    if not args.quiet:
        from mrhyst.report.summary import fit_summary

        print(fit_summary(res, out))


def fit_settings(args):
    """The fit's settings, resolved once: each flag given (--form, --model, --joint-weight, --seed, --start,
    --pso-setting) > the --config file > the schema's defaults (:class:`mrhyst.fit.settings.FitSettings`)."""
    from mrhyst.fit import identify

    settings = identify.resolve_config(_fit_config(args.config) if args.config else None)
    ja_flags = {"form": args.form, "model": args.model, "joint_weight": args.joint_weight}
    pso_flags = {"seeds": None if args.seed is None else [args.seed], "cli_setting": args.pso_setting,
                 "start": None if args.start is None else {"loop": args.start, "bh": args.start}}
    if args.pso_setting is not None and args.pso_setting not in settings.pso.settings:
        raise InputError(f"PSO setting {args.pso_setting!r} not in config pso.settings "
                         f"({', '.join(settings.pso.settings)})")
    return settings.replace(ja={k: v for k, v in ja_flags.items() if v is not None},
                            pso={k: v for k, v in pso_flags.items() if v is not None})


def resolve_section(name: str, config: dict | None, flags: dict) -> dict:
    """Config section ``name`` as it runs: the flags given (not None) > ``config`` (the section) > the schema."""
    from mrhyst.config import resolve

    given = {**(config or {}), **{k: v for k, v in flags.items() if v is not None}}
    return resolve({name: given}, [name])[name]


def _section(path, name: str) -> dict:
    """One section of a validated config.yaml (schema + semantic checks of mrhyst.config)."""
    return load_config(path)[name]


def cmd_diagnose(args) -> None:
    from mrhyst import diagnose, startup
    from mrhyst.report.summary import finish_diagnosis

    startup.imported()

    ref_file = args.reference if args.reference and not args.reference.startswith("table1:") else None
    inputs = (args.raw, args.config, args.sensor and sidecar_path(args.raw), ref_file)
    out = _out_path(args.out, *inputs)
    if args.figure and Path(args.figure).suffix.lower() != ".png":  # the figure is written as PNG bytes
        raise InputError(f"{args.figure}: --figure writes a PNG; give a path ending in .png")
    fig = _out_path(args.figure, *inputs, flag="--figure", others={"--out": out}) if args.figure else None
    if args.reference is not None:  # issue 24: a calibrated model held (mrhyst.diagnose.refdiag)
        for flag, given in (("--form", args.form), ("--seed", args.seed)):  # not silently ignored (issue 22)
            if given is not None:
                raise InputError(f"{flag}: reference mode runs the reference's J-A form and no random starts; drop "
                                 f"{flag} or --reference")
        from mrhyst.diagnose import refdiag

        refdiag.cli(args, out, load_config(args.config) if args.config else None, fig)
        return
    # resolved once: a flag given (--form, --seed) > the --config file's diagnose section > the schema's defaults
    settings = diagnose.resolve_config(_section(args.config, "diagnose") if args.config else None,
                                       form=args.form, seed=args.seed)
    if args.sensor is None:  # a third-party B(H) loop (H_A_per_m,B_T[,loop_index]): no Hall chain
        d = diagnose.diagnose_bh_file(args.raw, args.loop_index, config=settings, material=args.config)
    elif args.loop_index is not None:
        raise InputError(f"{args.raw}: --loop-index is for B(H) loop files; a raw sweep takes --sensor only")
    else:
        d = diagnose.diagnose_file(args.raw, sensor=args.sensor, config=settings)
    finish_diagnosis(d, out, fig, args.quiet)  # the figure, then the JSON, then the summary (issue 26)


def _inside(path: Path, folder: Path) -> bool:
    p, f = path.resolve(), folder.resolve()
    return p == f or f in p.parents


def cmd_blind_generate(args) -> None:
    """Cases with a withheld effect (the rig) into --cases, the key apart in --key (ARCHITECTURE 6).

    Everything is written into a temporary folder beside --cases and moved into place at the end, so an
    error or Ctrl-C leaves neither cases nor key behind."""
    import shutil

    from mrhyst import blind
    from mrhyst.blind.settings import blind_settings

    # resolved once: --seed > the config's blind section > the schema (the key's reference fit is independent of
    # the diagnose section, issue 11 pt 5)
    bcfg = blind_settings(_section(args.config, "blind"), seed=args.seed)
    if args.n_per_class is not None:  # every class, also those blind.counts sets
        bcfg = bcfg.replace(n_per_class=args.n_per_class, counts={})
    cases = Path(args.cases)
    if cases.exists() and not (cases.is_dir() and not any(cases.iterdir())):
        raise InputError(f"{cases}: --cases must be a new or empty folder (cases are never mixed or overwritten)")
    key = _out_path(args.key, args.config)
    if _inside(key, cases):
        raise InputError(f"{key}: the key must live outside the case folder {cases}, where a diagnosis could read it")
    _out_path(str(cases / "case.csv"))  # the case folder's parent is writable
    cases.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=f".{cases.name}.", dir=cases.parent))
    try:
        blind.generate(bcfg, tmp / "cases", tmp / "key.json")
        if cases.exists():
            cases.rmdir()  # empty (checked above)
        os.replace(tmp / "cases", cases)
        key.parent.mkdir(parents=True, exist_ok=True)
        shutil.move(str(tmp / "key.json"), str(key))
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    n = sum(1 for _ in cases.glob("*.csv"))
    print(f"{n} cases in {cases}; key {key} (diagnose each case with: mrhyst diagnose CASE.csv --sensor "
          f"{blind.SENSOR} --config {args.config} --out DIAG/CASE.json)")


def cmd_blind_score(args) -> None:
    """Diagnoses (one JSON per case, named after it) scored against the key -> SCORE.json."""
    from mrhyst import blind

    out = _out_path(args.out, args.key, args.config, *args.diag)
    from mrhyst.blind.settings import blind_settings

    bcfg = blind_settings(_section(args.config, "blind"))  # resolved once, over the schema's defaults
    paths: list[Path] = []
    for d in map(Path, args.diag):
        if d.is_dir():
            found = sorted(d.glob("*.json"))
            if not found:
                raise InputError(f"{d}: no diagnosis files (*.json) in this folder")
            paths += found
        elif d.is_file():
            paths.append(d)
        else:
            raise InputError(f"{d}: file not found")
    check_out_target(out, paths)
    stems = [p.stem for p in paths]
    dup = sorted({s for s in stems if stems.count(s) > 1})
    if dup:
        raise InputError(f"case {dup[0]!r} is given more than once")
    s = blind.score(paths, args.key, bcfg, policy=blind.load_policy())
    write_json(s, out)
    o, w, c = s["overall"], s["open_world"], s["compound"]

    def pct(v):
        return "n/a" if v is None else f"{v:.1%}"

    print(f"{o['n']} closed-world cases: top-1 strict {pct(o['top1_strict'])}, on detectable "
          f"{pct(o['top1_detectable'])}, fair {pct(o['top1_fair'])}; false alarms on none {pct(o['false_alarm_none'])}"
          f"; {w['n']} open-world: false attribution {pct(w['false_attribution'])}, model-form recall "
          f"{pct(w['model_form_recall'])}; {c['n']} compound: one of pair {pct(c['one_of_pair'])}, both named "
          f"{pct(c['both_named'])}; score {out}")


def _lab_flags(p, figure: bool = False, help_out: str | None = None) -> None:
    """--out, [--figure,] --quiet of fit and diagnose (issue 26)."""
    p.add_argument("--out", required=True, help=help_out)
    if figure:
        p.add_argument("--figure", help="PNG: the loop and fits, the residual along the path, the gap as bars")
    p.add_argument("--quiet", action="store_true", default=None, help="no plain summary on stdout")


def _issue24_args(f, d) -> None:
    """`fit --temperature-laws` and `diagnose --reference` (issue 24; docs/reference.md)."""
    f.add_argument("--temperature-laws", dest="temperature_laws", action="store_true", default=None,
                   help="one material at several temperatures (a temperature_C column): J-A parameters as laws of "
                        "the temperature, fitted jointly (--loop-index all or a list; --method lsm)")
    d.add_argument("--reference", help="reference mode: a calibrated model held (a FIT.json of mrhyst fit, with or "
                                       "without temperature laws, or table1:group1_pso etc.); says what changed")


def build_parser() -> argparse.ArgumentParser:
    ap = _Parser(prog="mrhyst",
                 description="J-A hysteresis of MR-damper sweeps: convert, simulate, fit, diagnose, blind.")
    ap.add_argument("--version", action="version", version=f"mrhyst {__version__}")
    sub = ap.add_subparsers(dest="cmd", required=True, parser_class=_Parser)

    c = sub.add_parser("convert", help="Hall voltages of a raw sweep -> loop file (B in T)")
    c.add_argument("raw", help="raw sweep CSV (sidecar JSON beside it)")
    c.add_argument("--sensor", required=True, help="sensor name, e.g. hall1 (column hall1_V)")
    c.add_argument("--out", required=True)
    c.set_defaults(func=cmd_convert)

    s = sub.add_parser("simulate", help="J-A loop for given parameters along a current path")
    s.add_argument("--params", help="JSON with Ms, a, alpha, c, k (a fit file works)")
    for n in names.PARAM_NAMES:
        s.add_argument(f"--{n}", type=_finite_float)
    s.add_argument("--path", help="paper (53 samples), fig2, or a raw/loop CSV giving the currents "
                                   "(default: config simulate.path)")
    s.add_argument("--i-max", type=_finite_float, dest="i_max", help="default: config simulate.i_max_A")
    s.add_argument("--n-over-le", type=_finite_float, required=True, dest="n_over_le",
                   help="turns per metre, H = (N/Le) I")
    s.add_argument("--form", choices=names.FORMS, help="default: config simulate.form")
    s.add_argument("--substeps", type=_positive_int, help="default: config simulate.substeps")
    s.add_argument("--config", help="config.yaml whose simulate section to use (validated; default: built-in)")
    s.add_argument("--out", required=True)
    s.set_defaults(func=cmd_simulate)

    f = sub.add_parser("fit", help="identify J-A parameters of a loop (PSO or least squares)")
    f.add_argument("loop", help="loop CSV (mrhyst convert) or third-party B(H) CSV (H_A_per_m,B_T[,loop_index])")
    f.add_argument("--method", choices=("pso", "lsm"), required=True)
    f.add_argument("--form", choices=names.FORMS, help="J-A form (default: config ja.form)")
    f.add_argument("--seed", type=_nonneg_int, help="PSO seed (default: the first of config pso.seeds)")
    f.add_argument("--loop-index", dest="loop_index", type=_loop_selection,
                   help="which loop of a file with a loop_index column (required there): N, or 'all' / a list "
                        "like 0,2 for one parameter set fitted to those loops jointly (each its own start state)")
    f.add_argument("--model", help="J-A variant (ja.MODELS, ja = classic; auto = compare all, config ja.auto)")
    f.add_argument("--joint-weight", dest="joint_weight", choices=["none", "amplitude", "own"],
                   help="a joint fit's loop weights (default config ja.joint_weight): own = each loop scaled by "
                        "its own fit's RMS, reweighted until every loop is as close to its own fit as can be "
                        "(LSM only)")
    f.add_argument("--start", choices=START_STATES,
                   help="model's starting state: demagnetised (paper), first_sample (M0 from B[0]), fit (M0 "
                        "fitted), cyclic (path repeated, compared on the last pass = steady state); default: "
                        "config pso.start (loop file: demagnetised, B(H) file: fit)")
    f.add_argument("--pso-setting", dest="pso_setting", metavar="NAME",
                   help="PSO setting in config pso.settings: default pso.cli_setting ('converge': Clerc swarm on the "
                        "log-scaled box, then a least-squares polish); 'paper' = the paper's w = 1, c1 = c2 = 2 as in "
                        "Tables 1-3")
    f.add_argument("--config", help="config.yaml whose pso/lsm/ja/metrics sections to use (validated)")
    _lab_flags(f, help_out="FIT.json; the model curves go to FIT.curve.csv beside it")
    f.set_defaults(func=cmd_fit)

    d = sub.add_parser("diagnose", help="where the J-A fit misses, which unmodelled effect, how much it explains")
    d.add_argument("raw", help="raw sweep CSV (sidecar JSON beside it; any current path) or a B(H) loop CSV")
    d.add_argument("--sensor", help="the Hall channel of a raw sweep (omit for a third-party B(H) loop)")
    d.add_argument("--loop-index", type=_nonneg_int, default=None,
                   help="which loop of a B(H) file with a loop_index column")
    d.add_argument("--form", choices=names.FORMS, help="J-A form (default: config diagnose.form)")
    d.add_argument("--seed", type=_nonneg_int, help="seed of the random starts (default: config diagnose.seed)")
    d.add_argument("--config", help="config.yaml whose diagnose section to use (validated; default: built-in)")
    _lab_flags(d, figure=True)
    d.set_defaults(func=cmd_diagnose)
    _issue24_args(f, d)

    _blind_parser(sub)
    return ap


def _blind_parser(sub) -> None:
    """`mrhyst blind generate | score`."""
    b = sub.add_parser("blind", help="benchmark the diagnosis on rig cases whose effect is withheld")
    bsub = b.add_subparsers(dest="blind_cmd", required=True, parser_class=_Parser)
    bg = bsub.add_parser("generate", help="write cases (raw sweeps) and, apart, the key")
    bg.add_argument("--config", required=True, help="config.yaml whose blind section to use")
    bg.add_argument("--cases", required=True, help="new or empty folder for the cases (CSV + sidecar each)")
    bg.add_argument("--key", required=True, help="key JSON, outside the case folder")
    bg.add_argument("--n-per-class", type=_positive_int, dest="n_per_class",
                    help="cases per class, overriding blind.n_per_class and blind.counts")
    bg.add_argument("--seed", type=_nonneg_int, help="overrides blind.seed")
    bg.set_defaults(func=cmd_blind_generate)
    bs = bsub.add_parser("score", help="score diagnoses (one JSON per case) against the key")
    bs.add_argument("diag", nargs="+", help="diagnosis JSON files or folders of them, named <case id>.json")
    bs.add_argument("--key", required=True)
    bs.add_argument("--config", required=True, help="config.yaml whose blind section to use")
    bs.add_argument("--out", required=True)
    bs.set_defaults(func=cmd_blind_score)


def _one_line(e: BaseException) -> str:
    return " ".join(str(e).split("\n")).strip()


def main(argv=None) -> int:
    args = build_parser().parse_args(argv)
    if argv is not None:  # called in another program's process (a test): no process-level start-up or exit
        return _run(args)
    from mrhyst import startup  # the process entry (console script, python -m mrhyst): issue 26's start-up

    startup.begin(heavy=args.func in (cmd_fit, cmd_diagnose))
    code = _run(args)
    if args.func is cmd_fit:  # its output written: build the J-A kernel without numba if the fit lacked it
        from mrhyst.model import aot

        aot.build_in_background()
    return startup.finish(code)


def _run(args) -> int:
    try:
        args.func(args)
    except (InputError, ConfigError) as e:
        sys.stderr.write(f"mrhyst {args.cmd}: error: {_one_line(e)}\n")
        return 2
    except BrokenPipeError:  # stdout's reader left early (`| head`): every command prints only after its files
        from mrhyst import startup  # are written, so they stand; the lines it could not print are dropped

        startup.stdout_to_devnull()
        sys.stderr.write(f"mrhyst {args.cmd}: stdout closed by its reader; the output was written\n")
        return 0
    except OSError as e:  # e.g. the disk filled up or the folder vanished while writing (nothing is left)
        where = f"{e.filename}: " if getattr(e, "filename", None) else ""
        sys.stderr.write(f"mrhyst {args.cmd}: error: {where}{e.strerror or e}; no output written\n")
        return 2
    except KeyboardInterrupt:
        sys.stderr.write("mrhyst: interrupted; no output written\n")
        return 130
    return 0


if __name__ == "__main__":
    sys.exit(main())
