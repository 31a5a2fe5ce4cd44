"""Reading, validating and writing the contract files (ARCHITECTURE section 4).

Every user mistake raises :class:`InputError` whose message is one line naming
the file (and row/column where there is one) and what was expected. Writers
are atomic (temporary file in the same folder, then ``os.replace``), so an
interrupted run leaves either the old file or the new one, never half of one.
"""

from __future__ import annotations

import contextlib
import functools
import json
import math
import os
import tempfile
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from mrhyst.data import csvtext, sanity
from mrhyst.data.errors import InputError
from mrhyst.data.shape import path_shape
from mrhyst.model import hall

MIN_SAMPLES = 5
RAW_REQUIRED = ("step", "time_s", "current_A")
LOOP_COLUMNS = ("step", "current_A", "H_A_per_m", "B_T", "branch")
BH_COLUMNS = ("H_A_per_m", "B_T")
# Third-party loops often label their columns plainly; accepted as aliases of BH_COLUMNS (units A/m, T).
BH_ALIASES = {"H": "H_A_per_m", "B": "B_T", "H (A/m)": "H_A_per_m", "B (T)": "B_T"}
# A Hall output above this many volts cannot come from a 3.3 V / 5 V sensor: likely millivolts.
MAX_PLAUSIBLE_V = 12.0
# |B| above this many tesla is not a flux density a core reaches: mT or gauss.
MAX_PLAUSIBLE_T = 10.0
# Fewest valid (unsaturated) samples a fit accepts: 5 J-A parameters + 1 (identify.Problem asks the same).
MIN_FIT_SAMPLES = 6
_read_csv, _numeric, _row = csvtext.read_csv, csvtext.numeric, csvtext.row_of


# --------------------------------------------------------------------------
# atomic writers
# --------------------------------------------------------------------------
def check_out_target(path, inputs=(), flag: str = "--out") -> None:
    """An output must be a regular file or absent (a rename onto a device, FIFO or socket would replace it,
    e.g. /dev/null), and none of ``inputs`` (the files the command reads; None entries are skipped)."""
    path = Path(path)
    if path.exists() and not path.is_file():
        raise InputError(f"{path}: not a regular file (a device, FIFO or socket); an output must be a regular file "
                         f"or a new path")
    for i in inputs:
        if i is not None and path.exists() and Path(i).exists() and os.path.samefile(path, i):
            raise InputError(f"{path}: {flag} is the input file {Path(i).name} (this command reads it); choose "
                             f"another output path")


@contextlib.contextmanager
def atomic_path(path):
    """Yield a temporary path beside ``path``; move it into place only on success (never onto a non-regular
    file: :func:`check_out_target`)."""
    path = Path(path)
    check_out_target(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    os.close(fd)
    umask = os.umask(0)
    os.umask(umask)
    os.chmod(tmp, 0o666 & ~umask)  # mkstemp makes 0600; give the file ordinary permissions
    try:
        yield Path(tmp)
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(FileNotFoundError):
            os.unlink(tmp)
        raise


def _jsonable(obj):
    if isinstance(obj, Mapping):  # a dict, or frozen settings (mrhyst.settings)
        return {str(k): _jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_jsonable(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return [_jsonable(v) for v in obj.tolist()]
    if isinstance(obj, (np.bool_, bool)):
        return bool(obj)
    if isinstance(obj, (np.integer,)):
        return int(obj)
    if isinstance(obj, (float, np.floating)):
        v = float(obj)
        if not math.isfinite(v):
            raise ValueError(f"refusing to write a non-finite number ({v}) to JSON")
        return v
    return obj


def write_json(obj, path) -> None:
    """Deterministic JSON (sorted keys, fixed indent, repr floats), written atomically."""
    text = json.dumps(_jsonable(obj), indent=2, sort_keys=True) + "\n"
    with atomic_path(path) as tmp:
        tmp.write_text(text)


def read_json(path) -> dict:
    path = Path(path)
    if path.is_dir():
        raise InputError(f"{path}: is a folder; expected a JSON file")
    if not path.is_file():
        raise InputError(f"{path}: file not found")
    try:  # a BOM is fine, as in a CSV; a whole number every reader can take as a float (JSON's own limit is none)
        return json.loads(path.read_bytes().decode("utf-8-sig"), parse_int=_json_int, object_pairs_hook=_no_twice)
    except UnicodeDecodeError:
        raise InputError(f"{path}: not a text file (expected JSON)") from None
    except json.JSONDecodeError as e:
        raise InputError(f"{path}: not valid JSON (line {e.lineno}, column {e.colno}: {e.msg})") from None
    except _HugeInt as e:
        raise InputError(f"{path}: the number {e.args[0][:12]}... ({len(e.args[0])} digits) is beyond any physical "
                         f"value (expected a number below 1e308)") from None
    except RecursionError:
        raise InputError(f"{path}: nested too deeply to be a sidecar, config or fit file") from None
    except _TwiceKey as e:
        raise InputError(f"{path}: key {e.args[0]!r} is given twice in one object (which one holds?)") from None


class _TwiceKey(ValueError):
    pass


def _no_twice(pairs) -> dict:
    """A JSON object whose keys are distinct (json keeps the last of two silently)."""
    out = {}
    for k, v in pairs:
        if k in out:
            raise _TwiceKey(k)
        out[k] = v
    return out


def json_number(v) -> bool:
    """A JSON number: int or float, not true/false (bool is an int in Python), not a string that reads as one."""
    return isinstance(v, (int, float)) and not isinstance(v, bool)


class _HugeInt(ValueError):
    pass


def _json_int(text: str) -> int:
    """A JSON whole number, refused where a float cannot hold it (a 400-digit number is a typo, not a value)."""
    if len(text.lstrip("-")) > 308:
        raise _HugeInt(text)
    return int(text)


def write_csv(df, path) -> None:
    """A pandas DataFrame as CSV with a fixed float format (repr-exact), written atomically."""
    with atomic_path(path) as tmp:
        df.to_csv(tmp, index=False, float_format="%.10g", lineterminator="\n")


# --------------------------------------------------------------------------
# raw sweep (CSV + JSON sidecar)
# --------------------------------------------------------------------------
@dataclass
class Sensor:
    name: str
    sensitivity_V_per_T: float
    quiescent_V: float
    output_min_V: float | None = None
    output_max_V: float | None = None


@dataclass
class RawSweep:
    path: Path
    step: np.ndarray
    time_s: np.ndarray
    current_A: np.ndarray
    volts: dict  # sensor name -> np.ndarray of volts
    supply_V: float
    coil_turns_per_m: float
    dwell_s: float | None
    sensors: dict = field(default_factory=dict)  # name -> Sensor
    sidecar: dict = field(default_factory=dict)
    lines: np.ndarray | None = None  # each reading's line in the CSV (for messages)
    supply_min_V: float = 0.0  # the supply's lower rail (negative: a bipolar supply)

    def row(self, i: int) -> int:
        return int(self.lines[i]) if self.lines is not None else i + 2

    @property
    def H_A_per_m(self) -> np.ndarray:
        return self.coil_turns_per_m * self.current_A


def sidecar_path(csv_path) -> Path:
    """The JSON beside a raw sweep's CSV (same name, .json); a path with no file name ('.', '/') is not a sweep."""
    p = Path(csv_path)
    if not p.name or p.name in (".", ".."):
        raise InputError(f"{csv_path or '(empty path)'}: not a file (expected a raw sweep's CSV)")
    return p.with_suffix(".json")


SIDECAR_SCHEMA_PATH = Path(__file__).resolve().parents[1] / "schemas" / "sidecar.schema.json"


@functools.lru_cache(maxsize=1)
def _sidecar_validator():
    import jsonschema  # only for a raw sweep's sidecar (~0.1 s of imports a loop file does not need)

    return jsonschema.Draft202012Validator(json.loads(SIDECAR_SCHEMA_PATH.read_text()))


def _sidecar_problem(e) -> str:
    """One schema violation of a sidecar as '[sensors.NAME: ]what', naming the key and what was expected."""
    path = [str(p) for p in e.absolute_path]
    obj = ".".join(path[:-1])  # the object holding the offending key
    where, key = (f"{obj}: " if obj else ""), (path[-1] if path else "")
    if e.validator == "required":
        missing = next(k for k in e.validator_value if k not in e.instance)
        if missing != "sensors":
            return f"{'.'.join(path)}: missing key {missing!r}" if path else f"missing key {missing!r}"
    if path in ([], ["sensors"]):
        return "missing or empty 'sensors' object"
    if e.validator == "type" and e.validator_value == "object":
        return f"{'.'.join(path)}: expected an object"
    if e.validator == "type":
        want = {"integer": "a whole number", "boolean": "true or false", "string": "text"}.get(
            e.validator_value if isinstance(e.validator_value, str) else "", "a number")
        return f"{where}{key} must be {want}, got {e.instance!r}"
    if e.validator == "not" and key == "sensitivity_V_per_T":
        return (f"{where}{key} must be non-zero (negative for a sensor mounted the other way round), "
                f"got {e.instance!r}")
    if e.validator == "exclusiveMinimum":
        return f"{where}{key} must be > {e.validator_value}, got {e.instance!r}"
    return f"{'.'.join(path)}: {e.message}"


def _check_sidecar(side: dict, jpath: Path) -> None:
    """The sidecar against workflow/mrhyst/schemas/sidecar.schema.json, then finite numbers: one InputError line."""
    errors = sorted(_sidecar_validator().iter_errors(side), key=lambda e: (len(e.absolute_path), str(e.absolute_path)))
    if errors:
        raise InputError(f"{jpath}: {sanity.unknown_key(errors[0]) or _sidecar_problem(errors[0])}")
    sensors = side["sensors"].items()
    for where, d in [("", side)] + [(f"sensors.{n}: ", s) for n, s in sensors]:
        for key, v in d.items():
            if isinstance(v, float) and not math.isfinite(v):
                raise InputError(f"{jpath}: {where}{key} must be a number, got {v!r}")


def _read_sidecar(csv_path: Path) -> tuple[Path, dict]:
    jpath = sidecar_path(csv_path)
    if not jpath.is_file():
        raise InputError(f"{csv_path}: sidecar {jpath.name} not found (expected JSON beside the CSV)")
    side = read_json(jpath)
    if not isinstance(side, dict):
        raise InputError(f"{jpath}: expected a JSON object at the top level")
    return jpath, side


def read_raw(csv_path) -> RawSweep:
    """Read and validate a raw sweep and its sidecar; raise InputError on any problem."""
    path = Path(csv_path)
    jpath, side = _read_sidecar(path) if path.is_file() else (None, None)
    if jpath is None:
        raise InputError(f"{path}: file not found")
    _check_sidecar(side, jpath)
    df = _read_csv(path, RAW_REQUIRED)
    # Hall channels: the NAME_V columns of the sidecar's sensors; any other column is a lab's own log, ignored
    hall_cols = [c for c in df.columns if c.endswith("_V") and c[:-2] in side["sensors"]]
    if not any(c.endswith("_V") and c != "supply_V" for c in df.columns):
        raise InputError(f"{path}: no Hall voltage column (expected e.g. hall1_V after {', '.join(RAW_REQUIRED)})")
    if len(df) < MIN_SAMPLES:
        raise InputError(f"{path}: {len(df)} data rows; at least {MIN_SAMPLES} samples are needed")
    step = _numeric(df, "step", path)
    if np.any(step != np.round(step)):
        i = int(np.argmax(step != np.round(step)))
        raise InputError(f"{path}: row {_row(df, i)}, column step: expected a whole number, got {df['step'][i]!r}")
    d = np.diff(step)
    if np.any(d == 0):
        i = int(np.argmax(d == 0)) + 1
        raise InputError(f"{path}: row {_row(df, i)}, column step: duplicate step {int(step[i])} (one row per "
                         f"reading: several readings at one current are rows of their own, each with its own step)")
    if np.any(d < 0):
        i = int(np.argmax(d < 0)) + 1
        raise InputError(f"{path}: row {_row(df, i)}, column step: steps must increase (got {int(step[i])} after "
                         f"{int(step[i - 1])}); rows are in the order applied")
    t = _numeric(df, "time_s", path)
    if np.any(np.diff(t) < 0):
        i = int(np.argmax(np.diff(t) < 0)) + 1
        raise InputError(f"{path}: row {_row(df, i)}, column time_s: time goes backwards ({t[i]} after {t[i - 1]})")
    cur = _numeric(df, "current_A", path)
    supply, turns = float(side["supply_V"]), float(side["coil_turns_per_m"])
    rail = float(side.get("supply_min_V") or 0.0)
    sanity.check_field(turns, cur, path, lambda i: _row(df, i))
    volts = {}
    for col in hall_cols:
        v = _numeric(df, col, path)
        if np.max(np.abs(v)) > MAX_PLAUSIBLE_V:
            i = int(np.argmax(np.abs(v) > MAX_PLAUSIBLE_V))
            raise InputError(f"{path}: row {_row(df, i)}, column {col}: {v[i]} V is not a Hall output voltage "
                             f"(looks like millivolts; expected volts)")
        sanity.check_readings(v, col, supply, path, lambda i: _row(df, i), rail)
        volts[col[:-2]] = v
    dwell = None if side.get("dwell_s") is None else float(side["dwell_s"])
    sanity.check_time_scale(t, dwell, path)
    sensors = {}
    for name, s in side["sensors"].items():
        where = f"sensors.{name}: "
        S, q = float(s["sensitivity_V_per_T"]), s.get("quiescent_V")
        lims = [None if s.get(k) is None else float(s[k]) for k in ("output_min_V", "output_max_V")]
        if lims[0] is not None and lims[1] is not None and lims[0] >= lims[1]:
            raise InputError(f"{jpath}: {where}output_min_V ({lims[0]}) must be below output_max_V ({lims[1]})")
        sensors[name] = Sensor(name, S, hall.quiescent_voltage(supply, q, rail), lims[0], lims[1])
        sanity.check_sensor(name, sensors[name], supply, jpath, rail)
    return RawSweep(path, step.astype(int), t, cur, volts, supply, turns, dwell, sensors, side, df.attrs["lines"],
                    rail)


def branches(current: np.ndarray, shape=None) -> np.ndarray:
    """'up'/'down' per sample from the direction of the current change (:meth:`PathShape.branches`; ``shape``:
    the current's :class:`mrhyst.data.shape.PathShape` when known, so that it is not derived again).

    A sample belongs to the branch it was reached on; the first sample takes
    the direction of the first change; a repeated current keeps the branch (a current that never changes: up).
    """
    if shape is not None:
        return shape.branches()
    try:
        return path_shape(current).branches()
    except ValueError:
        return np.full(np.size(current), "up", dtype=object)


def raw_to_loop(raw: RawSweep, sensor: str, shape=None):
    """Convert one Hall channel of a raw sweep to the loop format (a pandas DataFrame; ``shape``: of its
    current, when known)."""
    import pandas as pd  # a command that only reads files starts without it (issue 26)

    if sensor not in raw.sensors:
        raise InputError(f"{sidecar_path(raw.path)}: sensor {sensor!r} not in 'sensors' "
                         f"(have {', '.join(raw.sensors)})")
    if sensor not in raw.volts:
        raise InputError(f"{raw.path}: no column {sensor}_V (have {', '.join(k + '_V' for k in raw.volts)})")
    s = raw.sensors[sensor]
    V = raw.volts[sensor]
    B = hall.volts_to_tesla(V, s.sensitivity_V_per_T, s.quiescent_V)
    sat = hall.saturated_mask(V, s.output_min_V, s.output_max_V)  # at a limit, to within one reading step
    valid = ~sat
    sanity.check_channel(V, B, valid, f"{sensor}_V", s.sensitivity_V_per_T, raw.path, raw.row)
    sanity.check_permeability(raw.H_A_per_m, B, valid, raw.path, raw=True)
    df = pd.DataFrame({
        "step": raw.step,
        "current_A": raw.current_A,
        "H_A_per_m": raw.H_A_per_m,
        "B_T": B,
        "branch": branches(raw.current_A, shape),
    })
    if s.output_min_V is not None or s.output_max_V is not None:
        df["saturated"] = sat.astype(int)
    return df


def write_raw(path, step, time_s, current_A, volts: dict, sidecar: dict) -> None:
    """Write a raw sweep CSV (volts: name -> array) and its JSON sidecar."""
    import pandas as pd

    path = Path(path)
    cols = {"step": np.asarray(step, dtype=int), "time_s": time_s, "current_A": current_A}
    for name, v in volts.items():
        cols[f"{name}_V"] = v
    write_csv(pd.DataFrame(cols), path)
    write_json(sidecar, sidecar_path(path))


# --------------------------------------------------------------------------
# loop files and third-party B(H) loops
# --------------------------------------------------------------------------
@dataclass
class Loop:
    """A measured loop ready for fitting: H and B per sample, in the order applied."""

    path: Path
    H_A_per_m: np.ndarray
    B_T: np.ndarray
    current_A: np.ndarray | None = None
    branch: np.ndarray | None = None
    saturated: np.ndarray | None = None
    loop_index: np.ndarray | None = None
    kind: str = "loop"  # "loop" (our format) or "bh" (third-party)

    @property
    def valid(self) -> np.ndarray:
        """Samples usable as B (not saturated)."""
        if self.saturated is None:
            return np.ones(self.B_T.size, dtype=bool)
        return ~self.saturated.astype(bool)


def _loop_from_frame(df: csvtext.Table, path: Path, row0: np.ndarray) -> Loop:
    """One loop from its rows; ``row0`` = each row's 0-based data row in the file (for messages)."""

    def num(col):
        return _numeric(df, col, path, row0)

    H = num("H_A_per_m")
    B = num("B_T")
    if np.max(np.abs(B)) > MAX_PLAUSIBLE_T:
        i = int(np.argmax(np.abs(B) > MAX_PLAUSIBLE_T))
        raise InputError(f"{path}: row {_row(df, int(row0[i]))}, column B_T: {B[i]} T is not "
                         f"a plausible flux density "
                         f"(expected tesla, not mT or gauss)")
    loop = Loop(path, H, B)
    own = ("step", "current_A", "branch")  # a loop file's columns beyond H and B
    part = [c for c in own if c in df.columns]
    if len(part) >= 2 and len(part) < 3:  # a loop file (mrhyst convert's) that lost a column
        gone = next(c for c in own if c not in part)
        raise InputError(f"{path}: has {', '.join(part)} but no {gone} column: a loop file needs all of "
                         f"{','.join(LOOP_COLUMNS)}, a third-party B(H) loop only H_A_per_m,B_T[,loop_index] (drop "
                         f"{', '.join(part)} to fit it as one: its start state is then fitted)")
    if all(c in df.columns for c in LOOP_COLUMNS):
        loop.kind = "loop"
        loop.current_A = num("current_A")
        step = num("step")
        if np.any(np.diff(step) <= 0):
            i = int(np.argmax(np.diff(step) <= 0)) + 1
            raise InputError(f"{path}: row {_row(df, int(row0[i]))}, column step: steps must strictly increase "
                             f"(got {step[i]:g} after {step[i - 1]:g}); rows are in the order applied")
        br = np.array([b.strip() for b in df["branch"]], dtype=object)
        badb = ~np.isin(br, ["up", "down"])
        if badb.any():
            i = int(np.argmax(badb))
            raise InputError(f"{path}: row {_row(df, int(row0[i]))}, column branch: expected 'up' or 'down', "
                             f"got {br[i]!r}")
        loop.branch = br
    else:
        loop.kind = "bh"
    if "sample_index" in df.columns:
        si = num("sample_index")
        if np.any(np.diff(si) <= 0):
            i = int(np.argmax(np.diff(si) <= 0)) + 1
            raise InputError(f"{path}: row {_row(df, int(row0[i]))}, column sample_index: samples must be in the order "
                             f"measured (got {si[i]:g} after {si[i - 1]:g})")
    if "saturated" in df.columns:
        sat = num("saturated")
        if not np.all(np.isin(sat, (0, 1))):
            i = int(np.argmax(~np.isin(sat, (0, 1))))
            raise InputError(f"{path}: row {_row(df, int(row0[i]))}, column saturated: expected 0 or 1")
        loop.saturated = sat.astype(bool)
    return loop


def read_loops(path, only: int | None = None) -> list[Loop]:
    """Every loop in a loop file or third-party B(H) file, in file order.

    A file with a ``loop_index`` column holds one loop per index (e.g. shared/data/real's ferrite file:
    four major loops): each becomes its own Loop (``loop.loop_index`` = that index), never one path
    through all of them. A file without it is one loop. ``only``: of a file with a ``loop_index`` column, the
    loop of that index alone is read and checked (the file's layout is checked whole); the others' numbers are
    not converted (the gadolinium file: 18 loops of 5000-5555 rows, one loop 0.34 -> 0.20 CPU s, min of 5, load ~1,
    2026-11-27; read_loop 0.24 s, 02538ca's 0.32 -> 0.25).
    """
    path = Path(path)
    df = _read_csv(path, BH_COLUMNS, aliases=BH_ALIASES, headerless=BH_COLUMNS)
    if "loop_index" not in df.columns:
        if only is not None:
            raise InputError(f"{path}: no loop_index column; --loop-index applies only to files with several loops")
        if len(df) < MIN_SAMPLES:
            raise InputError(f"{path}: {len(df)} data rows; at least {MIN_SAMPLES} samples are needed")
        return [_loop_from_frame(df, path, np.arange(len(df)))]
    li = _numeric(df, "loop_index", path)
    if np.any(li != np.round(li)):
        i = int(np.argmax(li != np.round(li)))
        raise InputError(f"{path}: row {_row(df, i)}, column loop_index: expected a whole number, "
                         f"got {df['loop_index'][i]!r}")
    li = li.astype(np.int64)
    # each loop's rows must be one contiguous block (a loop_index that reappears later is a mixed-up file)
    starts = np.flatnonzero(np.r_[True, li[1:] != li[:-1]])
    vals = li[starts]
    if len(set(vals.tolist())) != vals.size:
        j = next(k for k in range(1, vals.size) if vals[k] in vals[:k])
        raise InputError(f"{path}: row {_row(df, int(starts[j]))}, column loop_index: loop {int(vals[j])} appears "
                         f"again after other loops; each loop's rows must be together and in order")
    if only is not None and int(only) not in vals:
        raise InputError(f"{path}: no loop_index {only} (have {', '.join(map(str, vals.tolist()))})")
    loops = []
    for k, v in enumerate(vals):
        if only is not None and int(v) != int(only):
            continue
        a, b = int(starts[k]), int(starts[k + 1]) if k + 1 < starts.size else len(df)
        if b - a < MIN_SAMPLES:
            raise InputError(f"{path}: loop_index {int(v)} has {b - a} rows; at least {MIN_SAMPLES} samples are needed")
        loop = _loop_from_frame(df.rows(a, b), path, np.arange(a, b))
        loop.loop_index = np.full(b - a, int(v))
        loops.append(loop)
    return loops


def loop_indices(loops: list[Loop]) -> list[int | None]:
    return [None if lp.loop_index is None else int(lp.loop_index[0]) for lp in loops]


def read_loop(path, loop_index: int | None = None) -> Loop:
    """Read a loop file (step,current_A,H_A_per_m,B_T,branch[,saturated]) or a third-party B(H) loop.

    A file with several loops (``loop_index`` column) needs ``loop_index``: mixing its loops into one
    path would be wrong, so that is an error, not a silent concatenation.
    """
    path = Path(path)
    loops = read_loops(path, only=loop_index)
    idx = loop_indices(loops)
    if loop_index is None:
        if len(loops) > 1:
            raise InputError(f"{path}: holds {len(loops)} loops (loop_index {', '.join(map(str, idx))}); "
                             f"choose one with --loop-index N (mrhyst fit also takes --loop-index all: one "
                             f"parameter set for all of them)")
    return loops[0]  # with loop_index: that loop alone (read_loops says when the file has none of it)


def check_fittable(loop: Loop, min_valid: int = MIN_FIT_SAMPLES, sign: bool = True) -> None:
    """Raise InputError (naming the file) if a loop cannot be fitted: too few valid samples, all
    saturated, no change of H, a constant B, or (``sign``) B falling as H rises over whole branches or the loop running
    clockwise (the diagnosis passes False: it names a reversed sign or a clockwise loop instead of refusing)."""
    where = f"{loop.path}" + ("" if loop.loop_index is None else f" (loop_index {int(loop.loop_index[0])})")
    n = loop.B_T.size
    valid = loop.valid
    nv = int(valid.sum())
    if nv == 0:
        raise InputError(f"{where}: all {n} samples are flagged saturated; no valid B to fit")
    if nv < min_valid:
        raise InputError(f"{where}: {nv} valid (unsaturated) samples of {n}; a fit needs at least {min_valid}")
    if np.ptp(loop.H_A_per_m) == 0:
        raise InputError(f"{where}: H does not change (all samples at {loop.H_A_per_m[0]:g} A/m); nothing to fit")
    if np.ptp(loop.B_T[valid]) == 0:
        raise InputError(f"{where}: B is constant ({loop.B_T[valid][0]:g} T) over the valid samples; nothing to fit")
    sanity.check_reversal(loop.H_A_per_m, where)
    sanity.check_permeability(loop.H_A_per_m, loop.B_T, valid, where)
    if sign:
        sanity.check_sign(loop.H_A_per_m, loop.B_T, valid, where)
        sanity.check_orientation(loop.H_A_per_m, loop.B_T, valid, where)
