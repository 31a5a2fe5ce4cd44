"""Reading a CSV as labs and spreadsheets write it, with one-line errors naming the file's own line.

Tolerated where the meaning is unambiguous (issue 25): a UTF-8 BOM, CRLF or CR-only line ends, blank lines,
whole-line ``#`` comments anywhere (a logger's preamble; the one right above the data is the header when the
file has no other and it names as many columns as the data has, as numpy.savetxt writes it), comma,
semicolon or tab separators, and decimal commas in a semicolon- or tab-separated file in which no number has
a decimal point. Every message names the line of the file as a text editor counts it (blank and comment
lines included).
"""

from __future__ import annotations

import csv
import io as _io
import math
import re
import warnings
from pathlib import Path

import numpy as np
import pandas as pd

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
        if s and not s.startswith("#"):
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


def _frame(lines: list[str], sep: str, header: list[str], path: Path) -> pd.DataFrame:
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
    df.columns = [str(c).strip() for c in df.columns]
    return df


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


def read_csv(path, required, aliases=None, headerless=None) -> pd.DataFrame:
    """Read a CSV whose ``required`` columns must all be finite numbers (module text: what is tolerated).

    ``headerless``: the column names of a file whose first row is all numbers (None: a header is required).
    Rows with more fields than the header are an error (pandas would otherwise quietly take the first
    column as the index and shift every value one column to the left). ``df.attrs["lines"]``: each data
    row's line in the file (:func:`row_of`).
    """
    path = Path(path)
    text = read_text(path)
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
    df = _frame(lines, sep, header, path)
    if aliases:
        df = df.rename(columns={c: aliases[c] for c in df.columns if c in aliases and aliases[c] not in df.columns})
    df.attrs["lines"] = np.asarray(numbers[1:], dtype=np.int64)
    if len(df) == 0:
        raise InputError(f"{path}: header only, no data rows")
    missing = [c for c in required if c not in df.columns]
    if missing:
        hint = ""
        if len(df.columns) == 1 and any(ch in df.columns[0] for ch in "| "):
            hint = " (separator looks like '|' or spaces; expected commas, semicolons or tabs)"
        raise InputError(f"{path}: missing column(s) {', '.join(missing)}; header has {', '.join(df.columns)}{hint}")
    return df


def row_of(df: pd.DataFrame, r: int) -> int:
    """The file line of data row ``r`` (0-based, counted over the whole file, also in a slice of it)."""
    lines = df.attrs.get("lines")
    return int(lines[r]) if lines is not None and r < len(lines) else r + 2


def numeric(df: pd.DataFrame, col: str, path, row0=None) -> np.ndarray:
    """Column as float; the first non-number or non-finite value is reported with its file line.

    ``row0``: each frame row's 0-based data row in the file (when ``df`` is a slice of it)."""
    s = df[col].astype(str).str.strip()
    vals = pd.to_numeric(s, errors="coerce").to_numpy(dtype=float)
    bad = ~np.isfinite(vals)
    if bad.any():
        i = int(np.argmax(bad))
        r = i if row0 is None else int(row0[i])
        got = s.iloc[i]
        why = (" (a decimal comma in a file that also has decimal points: use one decimal mark)"
               if _COMMA_NUMBER.match(got) else "")
        raise InputError(f"{path}: row {row_of(df, r)}, column {col}: expected a finite number, got {got!r}{why}")
    return vals
