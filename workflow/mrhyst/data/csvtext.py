"""Reading a CSV as labs and spreadsheets write it, with one-line errors naming the file's own line.

Tolerated where the meaning is unambiguous (issue 25): a UTF-8 BOM, CRLF or CR-only line ends, blank lines,
whole-line ``#`` comments anywhere (a logger's preamble; the one right above the data is the header when the
file has no other and it names as many columns as the data has, as numpy.savetxt writes it), comma,
semicolon or tab separators, and decimal commas in a semicolon- or tab-separated file in which no number has
a decimal point. Every message names the line of the file as a text editor counts it (blank and comment
lines included).

A well-formed file (every row as many fields as the header, no quotes) is read with the csv module into a
:class:`Table` of text columns, without pandas (its import is a third of a warm fit's start-up, issue 26); any
other file goes through pandas' reader, whose one-line messages (and reading of short rows) it keeps.
"""

from __future__ import annotations

import contextlib
import csv
import io as _io
import math
import re
import warnings
from pathlib import Path

import numpy as np

from mrhyst.data.errors import InputError

SEPARATORS = (";", "\t", ",")  # tried in this order on the first line: ';' or tab if present, else ','
# Column names that say B or H is in another unit than the contract's T and A/m (case-insensitive).
UNIT_COLUMNS = (
    (re.compile(r"^b(\s*[_(\[]\s*|\s+)(mt|millitesla|g|gs|gauss|kg|kgauss)\s*[)\]]?$", re.I), "B",
     "tesla (column B_T)"),
    (re.compile(r"^h(\s*[_(\[]\s*|\s+)(ka[_/ ]?(per_)?m|oe|oersted|a[_/ ]?(per_)?cm)\s*[)\]]?$", re.I), "H",
     "A/m (column H_A_per_m)"),
)
_COMMA_NUMBER = re.compile(r"^\s*[-+]?\d*,\d+([eE][-+]?\d+)?\s*$")
_POINT_NUMBER = re.compile(r"^\s*[-+]?\d*\.\d+([eE][-+]?\d+)?\s*$")


def read_text(path: Path) -> str:
    if path.is_dir():
        raise InputError(f"{path}: is a folder; expected a CSV file")
    if not path.is_file():
        raise InputError(f"{path}: file not found")
    data = path.read_bytes()
    if b"\x00" in data:
        raise InputError(f"{path}: binary data (NUL bytes); expected a CSV text file")
    try:
        text = data.decode("utf-8-sig")
    except UnicodeDecodeError as e:
        raise InputError(f"{path}: not UTF-8 text (byte {e.start}); expected a CSV text file") from None
    if not text.strip():
        raise InputError(f"{path}: empty file; expected a CSV header and data rows")
    return text


def data_lines(text: str) -> tuple[list[str], list[int]]:
    """The lines that carry a header or data (not blank, not a whole-line ``#`` comment) and their line
    numbers in the file (1-based; any of LF, CRLF, CR ends a line)."""
    kept, numbers = [], []
    for k, ln in enumerate(text.replace("\r\n", "\n").replace("\r", "\n").split("\n"), start=1):
        s = ln.strip()
        if s.strip(",;\t ") and not s.startswith("#"):  # a row of separators only (a spreadsheet's ",,,,") is blank
            kept.append(ln)
            numbers.append(k)
    return kept, numbers


def separator(first: str) -> str:
    """The field separator of a header (or first data) line: ';' or tab when it has one, else ','."""
    return next((s for s in SEPARATORS[:2] if s in first), ",")


def split(line: str, sep: str) -> list[str]:
    return [f.strip() for f in next(csv.reader([line], delimiter=sep), [])]


def decimal_commas(lines: list[str], sep: str) -> list[str]:
    """Lines with decimal commas made points, when that is unambiguous: the separator is not a comma and no
    field is a number with a decimal point (a file with both marks is left alone; :func:`numeric` names the
    first comma number then)."""
    if sep == ",":
        return lines
    fields = [split(ln, sep) for ln in lines]
    if not any(_COMMA_NUMBER.match(f) for row in fields for f in row):
        return lines
    if any(_POINT_NUMBER.match(f) for row in fields for f in row):
        return lines
    return [sep.join(f.replace(",", ".") if _COMMA_NUMBER.match(f) else f for f in row) for row in fields]


def is_number(text: str) -> bool:
    try:
        return math.isfinite(float(text))
    except ValueError:
        return False


def check_header(header: list[str], path: Path) -> None:
    """Duplicate column names (pandas would rename the second one ``X.1``) and columns that name another unit
    for B or H are errors."""
    seen, dup = set(), []
    for c in header:
        if c in seen and c not in dup:
            dup.append(c)
        seen.add(c)
    if dup:
        raise InputError(f"{path}: duplicate column(s) {', '.join(dup)}")
    for c in header:
        for rx, qty, unit in UNIT_COLUMNS:
            if rx.match(c):
                raise InputError(f"{path}: column {c!r}: {qty} must be in {unit}; convert the values and rename it")


class Table:
    """A CSV's columns as text, in file order (what the readers need of a data frame, without pandas).

    ``attrs["lines"]``: each data row's line in the file (a slice keeps the whole file's: :func:`row_of`)."""

    def __init__(self, data: dict, lines=None):
        self.data = data
        self.attrs = {"lines": lines}

    @property
    def columns(self) -> list:
        return list(self.data)

    def __len__(self) -> int:
        return len(next(iter(self.data.values()), ()))

    def __getitem__(self, col: str) -> list:
        return self.data[col]

    def rows(self, a: int, b: int) -> Table:
        """Data rows a..b-1 (their file lines still counted over the whole file)."""
        return Table({k: v[a:b] for k, v in self.data.items()}, self.attrs["lines"])


def _fields(lines: list[str], sep: str, n: int) -> list | None:
    """The rows' fields by the csv module, or None when pandas must read them (a quote, or a row without
    exactly ``n`` fields: pandas' messages and its reading of short rows are kept)."""
    if any('"' in ln for ln in lines):
        return None
    rows = list(csv.reader(lines, delimiter=sep, skipinitialspace=True))
    return rows if all(len(r) == n for r in rows) else None


def _long_row(lines: list[str], numbers: list[int], sep: str, header: list[str], path: Path) -> None:
    """A row with more fields than the header, named by its line in the file (pandas counts only the lines it
    kept, and its message names no column), with the likely cause: decimal commas in a comma-separated file."""
    for ln, k in zip(lines[1:], numbers[1:]):  # quoted fields too (a quoted line break would span lines: rare)
        f = next(csv.reader([ln], delimiter=sep, skipinitialspace=True), [])
        if len(f) > len(header):
            hint = (" (decimal commas in a comma-separated file? use points as decimal marks, or ';' between the "
                    "columns)") if sep == "," and "." not in ln and re.search(r"\d,\d", ln) else ""
            raise InputError(f"{path}: row {k}: {len(f)} fields, more fields than the header ({len(header)} "
                             f"columns: {', '.join(header)}){hint}")


def _frame(lines: list[str], sep: str, header: list[str], path: Path, numbers: list[int] | None = None) -> Table:
    """The table of ``lines`` (header first); ``numbers``: each line's line in the file (default: 1, 2, ...)."""
    rows = _fields(lines[1:], sep, len(header)) if all(header) else None
    if rows is not None:
        return Table({c.strip(): [r[j] for r in rows] for j, c in enumerate(header)})
    _long_row(lines, numbers or list(range(1, len(lines) + 1)), sep, header, path)
    import pandas as pd  # only for a file the csv module does not read as it is (above)

    try:
        with warnings.catch_warnings():
            warnings.simplefilter("error", pd.errors.ParserWarning)
            df = pd.read_csv(_io.StringIO("\n".join(lines) + "\n"), dtype=str, keep_default_na=False,
                             skipinitialspace=True, index_col=False, sep=sep, skip_blank_lines=False)
    except pd.errors.ParserWarning:
        raise InputError(f"{path}: some rows have more fields than the header ({len(header)} columns: "
                         f"{', '.join(header)})") from None
    except pd.errors.ParserError as e:
        raise InputError(f"{path}: not a well-formed CSV ({str(e).strip().splitlines()[-1]})") from None
    return Table({str(c).strip(): [v if isinstance(v, str) else str(v) for v in df[c].tolist()] for c in df.columns})


def _commented_header(text: str, line: int, sep: str, n: int) -> str | None:
    """The header of a file that writes it as a comment right above the data (``# step,time_s,...``, as
    numpy.savetxt does): that line without its '#', when it has ``n`` fields and none is a number."""
    if line < 2:
        return None
    prev = text.replace("\r\n", "\n").replace("\r", "\n").split("\n")[line - 2].strip()
    if not prev.startswith("#"):
        return None
    head = prev.lstrip("#").strip()
    fields = split(head, sep)
    return head if len(fields) == n and not any(is_number(f) for f in fields) and all(fields) else None


def read_csv(path, required, aliases=None, headerless=None) -> Table:
    """Read a CSV whose ``required`` columns must all be finite numbers (module text: what is tolerated).

    ``headerless``: the column names of a file whose first row is all numbers (None: a header is required).
    Rows with more fields than the header are an error (pandas would otherwise quietly take the first
    column as the index and shift every value one column to the left). ``df.attrs["lines"]``: each data
    row's line in the file (:func:`row_of`).
    """
    path = Path(path)
    text = read_text(path)
    if text.lstrip("\ufeff \t\r\n").startswith(("{", "[")):
        raise InputError(f"{path}: a JSON file, not a CSV (a raw sweep's sidecar? give the sweep's CSV: its "
                         f"sidecar is read from beside it)")
    lines, numbers = data_lines(text)
    if not lines:
        raise InputError(f"{path}: only comment lines; expected a CSV header and data rows")
    sep = separator(lines[0])
    lines = decimal_commas(lines, sep)
    first = split(lines[0], sep)
    head = _commented_header(text, numbers[0], sep, len(first)) if all(is_number(f) for f in first) else None
    if head is not None:  # numpy.savetxt's "# H,B" right above the data
        lines, numbers = [head] + lines, [numbers[0] - 1] + numbers
        first = split(head, sep)
    if first and all(is_number(f) for f in first):  # no header
        if headerless is None:
            raise InputError(f"{path}: row {numbers[0]}: no header (the first row is all numbers); this file needs "
                             f"a header line")
        if len(first) != len(headerless):
            raise InputError(f"{path}: row {numbers[0]}: no header and {len(first)} columns; a file without a "
                             f"header must have exactly {len(headerless)} ({', '.join(headerless)}); otherwise "
                             f"add a header line")
        lines, numbers = [sep.join(headerless)] + lines, [0] + numbers
    header = split(lines[0], sep)
    check_header(header, path)
    df = _frame(lines, sep, header, path, numbers)
    if aliases:
        df.data = {aliases[c] if c in aliases and aliases[c] not in df.data else c: v for c, v in df.data.items()}
    df.attrs["lines"] = np.asarray(numbers[1:], dtype=np.int64)
    if len(df) == 0:
        raise InputError(f"{path}: header only, no data rows")
    missing = [c for c in required if c not in df.columns]
    if missing:
        raise InputError(f"{path}: missing column(s) {', '.join(missing)}; header has {', '.join(df.columns)}"
                         f"{_missing_hint(missing, df.columns)}")
    return df


_UNIT_SUFFIX = re.compile(r"^(?P<name>[^\[(]*?)\s*[\[(][^\])]*[\])]$")  # "current_A [A]", "B_T (T)"


def _missing_hint(missing: list[str], columns: list[str]) -> str:
    """Why the header lacks ``missing`` when the likely cause can be told from it: another separator, a raw
    Hall sweep given where a B(H) loop is read, a unit written after a name that already carries it, another
    letter case."""
    if len(columns) == 1 and any(ch in columns[0] for ch in "| "):
        return " (separator looks like '|' or spaces; expected commas, semicolons or tabs)"
    if "B_T" in missing and "current_A" in columns and any(c.endswith("_V") for c in columns):
        return (" (a raw Hall sweep: `mrhyst diagnose` reads it with --sensor NAME, its NAME_V column; "
                "`mrhyst convert` makes it a loop for `fit`)")
    bare = {m.group("name").strip(): c for c in columns if (m := _UNIT_SUFFIX.match(c))}
    if any(m in bare for m in missing):  # every such column, the Hall channels' too: one round, not two
        return (" (the names carry their unit already: rename " + ", ".join(f"{c!r} to {b!r}" for b, c in
                                                                              bare.items()) + ")")
    lower = {c.lower(): c for c in columns}
    if any(m.lower() in lower for m in missing):
        return (" (names are case-sensitive: rename " + ", ".join(f"{lower[m.lower()]!r} to {m!r}" for m in missing
                                                                   if m.lower() in lower) + ")")
    return ""


def row_of(df: Table, r: int) -> int:
    """The file line of data row ``r`` (0-based, counted over the whole file, also in a slice of it)."""
    lines = df.attrs.get("lines")
    return int(lines[r]) if lines is not None and r < len(lines) else r + 2


def _floats(texts: list[str]) -> np.ndarray:
    """Numbers read as pandas.to_numeric(errors="coerce") reads them (NaN where not a number): numpy's and
    float()'s reading without their extras (digit underscores, non-ASCII digits)."""
    if "_" not in "".join(texts) and all(t.isascii() for t in texts):
        with contextlib.suppress(ValueError):
            return np.asarray(texts, dtype=str).astype(float) if texts else np.empty(0)

    def one(t: str) -> float:
        if "_" in t or not t.isascii():
            return math.nan
        try:
            return float(t)
        except ValueError:
            return math.nan

    return np.array([one(t) for t in texts], dtype=float)


def numeric(df: Table, col: str, path, row0=None) -> np.ndarray:
    """Column as float; the first non-number or non-finite value is reported with its file line.

    ``row0``: each frame row's 0-based data row in the file (when ``df`` is a slice of it)."""
    s = [t.strip() for t in df[col]]
    vals = _floats(s)
    bad = ~np.isfinite(vals)
    if bad.any():
        i = int(np.argmax(bad))
        r = i if row0 is None else int(row0[i])
        got = s[i]
        why = (" (a decimal comma in a file that also has decimal points: use one decimal mark)"
               if _COMMA_NUMBER.match(got) else "")
        raise InputError(f"{path}: row {row_of(df, r)}, column {col}: expected a finite number, got {got!r}{why}")
    return vals
