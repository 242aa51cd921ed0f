"""CSV reading and writing for the command line (numbers only, SI units).

Reading is strict and fast. A file is a header line of column names followed
by rows of decimal numbers separated by commas. Every value must be a finite
decimal number (``1``, ``-0.5``, ``2.5e-3``); ``nan``, ``inf``, empty cells,
blank lines and rows with too few or too many values are errors, reported as
:class:`CsvError` naming the file, the line (1 = the header) and the column
(1-based number and name). The fast path parses the whole file in C (numpy);
only when it fails does a line-by-line scan run to find the exact cell.

Writing is exact: every float is written with enough digits (at most 17
significant) to read back to the identical double, by a vectorised formatter
(:func:`format_table`): numpy computes every value's digits and lays them
out in a fixed 48-byte template, masking the bytes its form does not use to
NUL, and ``bytes.translate`` deletes the NULs; an order of magnitude faster
than ``'%.17g'`` or ``repr`` in a Python loop. Files are written to a
temporary file in the destination directory and moved into place with
:func:`os.replace` (:func:`atomic_output`), so a failed run never leaves a
partial file and never clobbers an old one.
"""
from __future__ import annotations

import contextlib
import os
import re
import sys
from dataclasses import dataclass
from typing import IO, Iterable, Iterator, Sequence

import numpy as np

#: Header of a trajectory file (input of ``solve``), in the canonical order.
TRAJECTORY_COLUMNS = ('t', 'surge', 'heave', 'roll',
                      'surge_rate', 'heave_rate', 'roll_rate',
                      'surge_acc', 'heave_acc', 'roll_acc')


class CsvError(ValueError):
    """A CSV file cannot be read: names the file, line and column."""

    def __init__(self, message: str, *, path: str | None = None, line: int | None = None,
                 column: int | None = None, name: str | None = None) -> None:
        self.message = message
        self.path = path
        self.line = line
        self.column = column
        self.name = name
        super().__init__(self._text())

    def _text(self) -> str:
        where = [self.path if self.path is not None else '<input>']
        if self.line is not None:
            where.append(f'line {self.line}')
        if self.column is not None:
            where.append(f'column {self.column}' + (f' ({self.name})' if self.name else ''))
        return f"{', '.join(where)}: {self.message}"


@dataclass(frozen=True)
class Table:
    """A parsed CSV file: ``data[i, j]`` is the value of column ``names[j]`` in
    data row ``i``, read from line ``lines[i]`` of the file."""

    path: str
    names: tuple[str, ...]
    data: np.ndarray      # (N, ncol) float64
    lines: np.ndarray     # (N,) int, 1-based line numbers (header = 1)

    def __getitem__(self, name: str) -> np.ndarray:
        return self.data[:, self.names.index(name)]

    def __len__(self) -> int:
        return self.data.shape[0]


# ----------------------------------------------------------------------------
# Reading
# ----------------------------------------------------------------------------
_ALLOWED_BYTES = b'0123456789.eE+-, \t\r\n'
_BLANK = b' \t\r\n'
_NUMBER = re.compile(r'[ \t]*[+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?[ \t]*\Z', re.ASCII)


def _display(path: str | os.PathLike[str]) -> str:
    return '<stdin>' if os.fspath(path) == '-' else os.fspath(path)


def read_bytes(path: str | os.PathLike[str]) -> bytes:
    """The file's contents (``-``: standard input). OSError is re-raised as
    CsvError with a plain message."""
    if os.fspath(path) == '-':
        return sys.stdin.buffer.read()
    try:
        with open(path, 'rb') as f:
            return f.read()
    except IsADirectoryError:
        raise CsvError('is a directory, not a CSV file', path=_display(path)) from None
    except OSError as exc:
        raise CsvError(f'cannot read: {exc.strerror or exc}', path=_display(path)) from None


def parse_header(raw: bytes, path: str, *, required: Sequence[str],
                 allow_extra: bool) -> tuple[str, ...]:
    """Column names of header line ``raw``; checks empty, duplicate, missing
    and (unless ``allow_extra``) unknown names."""
    try:
        text = raw.decode('utf-8')
    except UnicodeDecodeError:
        raise CsvError('header is not valid UTF-8 text', path=path, line=1) from None
    text = text.lstrip('\ufeff').rstrip('\r')
    names = tuple(cell.strip() for cell in text.split(','))
    expected = ','.join(required)
    if not text.strip():
        raise CsvError(f'empty header line; expected column names {expected}',
                       path=path, line=1)
    for j, name in enumerate(names):
        if not name:
            raise CsvError('empty column name in the header', path=path, line=1, column=j + 1)
    seen: dict[str, int] = {}
    for j, name in enumerate(names):
        if name in seen:
            raise CsvError(f"duplicate column '{name}' (also column {seen[name] + 1})",
                           path=path, line=1, column=j + 1, name=name)
        seen[name] = j
    missing = [n for n in required if n not in seen]
    if not allow_extra:
        unknown = [(j, n) for j, n in enumerate(names) if n not in required]
        if unknown:
            j0, _ = unknown[0]
            listed = ', '.join(f"'{n}' (column {j + 1})" + _did_you_mean(n, missing)
                               for j, n in unknown)
            also = (f"; missing {', '.join(repr(m) for m in missing)}" if missing else '')
            raise CsvError(f'unknown column{"s" if len(unknown) > 1 else ""} {listed}{also}; '
                           f'expected exactly the columns {expected} (any order)',
                           path=path, line=1, column=j0 + 1, name=unknown[0][1])
    if missing:
        raise CsvError(f'missing column{"s" if len(missing) > 1 else ""} '
                       f"{', '.join(repr(m) for m in missing)}; "
                       f'the header must name {expected} (any order)', path=path, line=1)
    return names


def _did_you_mean(name: str, candidates: Sequence[str]) -> str:
    lowered = {c.lower(): c for c in candidates}
    if name.lower() in lowered:
        return f" (did you mean '{lowered[name.lower()]}'?)"
    import difflib      # only for this error message

    close = difflib.get_close_matches(name, candidates, n=1)
    return f" (did you mean '{close[0]}'?)" if close else ''


def read_csv(path: str | os.PathLike[str], *, required: Sequence[str],
             allow_extra: bool = False, text_columns: Sequence[str] = ()) -> Table:
    """Read a numeric CSV file with a header naming at least ``required``
    (exactly those, in any order, unless ``allow_extra``).

    Raises :class:`CsvError` naming the line and column of the first problem.
    """
    display = _display(path)
    data = read_bytes(path)
    return parse_csv(data, display, required=required, allow_extra=allow_extra,
                     text_columns=text_columns)


def parse_csv(data: bytes, path: str = '<input>', *, required: Sequence[str],
              allow_extra: bool = False, text_columns: Sequence[str] = ()) -> Table:
    """:func:`read_csv` on the bytes of a file. Columns named in ``text_columns``
    (words such as ``status``) are skipped, not parsed as numbers."""
    if data.startswith(b'\xef\xbb\xbf'):
        data = data[3:]
    if not data or data.isspace():
        raise CsvError('the file is empty; expected a header line '
                       f"{','.join(required)} and rows of numbers", path=path, line=1)
    end = data.find(b'\n')
    header = data if end < 0 else data[:end]
    names = parse_header(header, path, required=required, allow_extra=allow_extra)
    skip = [j for j, name in enumerate(names) if name in text_columns]
    # Trailing blank lines at the end of the file are fine; any other blank
    # line is a row with every value missing.
    if skip:
        keep = [j for j in range(len(names)) if j not in skip]
        names = tuple(names[j] for j in keep)
        body = b'\n'.join(b','.join(f for j, f in enumerate(line.split(b',')) if j not in skip)
                          for line in (data[end + 1:] if end >= 0 else b'').split(b'\n'))
        body = body.rstrip(_BLANK)
    else:       # one copy of the rows, without the trailing blanks
        body = data[end + 1:_content_end(data)] if end >= 0 else b''
    ncol = len(names)
    if not body:
        raise CsvError('no data rows after the header', path=path, line=2)
    nrows = _count(body, b'\n') + 1
    values = _parse_fast(body, nrows, ncol)
    if values is None:
        values = _parse_slow(body, names, path)  # raises on the first bad cell
    bad = ~np.isfinite(values)
    if bad.any():  # e.g. 1e999: a valid literal, but not a finite double
        i, j = np.argwhere(bad)[0]
        cell = body.split(b'\n')[i].split(b',')[j].decode().strip()
        raise CsvError(f"'{cell}' is not a finite number", path=path, line=int(i) + 2,
                       column=int(j) + 1, name=names[j])
    return Table(path=path, names=names, data=values, lines=np.arange(2, nrows + 2))


def _content_end(data: bytes) -> int:
    """len(data.rstrip(_BLANK)), without copying a large file."""
    tail = data[-4096:]
    kept = len(tail.rstrip(_BLANK))
    return len(data) - len(tail) + kept if kept else len(data.rstrip(_BLANK))


def _count(data: bytes, byte: bytes) -> int:
    """data.count(byte) for a single byte, about twice as fast (numpy)."""
    return int(np.count_nonzero(np.frombuffer(data, dtype=np.uint8) == byte[0]))


def _parse_fast(body: bytes, nrows: int, ncol: int) -> np.ndarray | None:
    """Parse ``body`` (the rows) in C; None if anything looks wrong (then the
    slow scan finds and reports the offending cell)."""
    if body.translate(None, _ALLOWED_BYTES):   # letters, quotes, NUL, non-ASCII...
        return None
    if b'\r' in body:
        body = body.replace(b'\r\n', b'\n')
    if _count(body, b',') != nrows * (ncol - 1):
        return None
    # numpy's C parser accepts, on these characters, exactly the cells _NUMBER
    # accepts (test_cli checks it). It refuses a row whose number of cells
    # differs from the first row's and skips blank lines: so with nrows rows
    # read and nrows * (ncol - 1) commas in all, every row has ncol cells.
    try:
        values = np.loadtxt(body.decode('ascii').split('\n'), delimiter=',', comments=None,
                            dtype=np.float64, ndmin=2)
    except ValueError:
        return None
    if values.shape != (nrows, ncol):
        return None
    return values


def _parse_slow(body: bytes, names: Sequence[str], path: str) -> np.ndarray:
    """Line-by-line parse that raises CsvError at the first malformed cell."""
    ncol = len(names)
    rows = body.split(b'\n')
    out = np.empty((len(rows), ncol))
    for i, raw in enumerate(rows):
        line = i + 2
        try:
            text = raw.decode('utf-8').rstrip('\r')
        except UnicodeDecodeError:
            raise CsvError('not valid UTF-8 text', path=path, line=line) from None
        if not text.strip():
            raise CsvError(f'empty line; expected {ncol} values', path=path, line=line)
        cells = text.split(',')
        for j, cell in enumerate(cells[:ncol]):
            shown = cell.strip()
            if not shown:
                raise CsvError('missing value', path=path, line=line, column=j + 1,
                               name=names[j])
            try:
                value = float(cell)
            except ValueError:
                value = None
            if value is None or not _NUMBER.match(cell) or not np.isfinite(value):
                if value is not None and not np.isfinite(value):
                    msg = f"'{shown}' is not a finite number"
                else:
                    msg = f"'{shown}' is not a number"
                raise CsvError(msg, path=path, line=line, column=j + 1, name=names[j])
            out[i, j] = value
        if len(cells) < ncol:
            raise CsvError(f'missing value (the row has {len(cells)} values, '
                           f'the header {ncol} columns)', path=path, line=line,
                           column=len(cells) + 1, name=names[len(cells)])
        if len(cells) > ncol:
            raise CsvError(f'extra value (the row has {len(cells)} values, '
                           f'the header {ncol} columns)', path=path, line=line,
                           column=ncol + 1)
    return out


# ----------------------------------------------------------------------------
# Writing: exact, vectorised float formatting
# ----------------------------------------------------------------------------
_RANGE = (1e-250, 1e250)    # vectorised path; outside it (and nan/inf): Python's '%.17g'
_P10_MIN, _P10_MAX = -270, 270


def _pow10_table() -> tuple[np.ndarray, np.ndarray]:
    """10**k as unevaluated sums hi + lo of two doubles (|error| < 2**-106);
    exact integer arithmetic, rounded once (int / int rounds correctly)."""
    ks = range(_P10_MIN, _P10_MAX + 1)
    hi = np.empty(len(ks))
    lo = np.empty(len(ks))
    for i, k in enumerate(ks):
        num, den = (10 ** k, 1) if k >= 0 else (1, 10 ** -k)
        hi[i] = num / den
        p, q = hi[i].as_integer_ratio()
        lo[i] = (num * q - p * den) / (den * q)          # 10**k - hi, rounded
    return hi, lo


_P10_HI, _P10_LO = _pow10_table()
_SPLITTER = 134217729.0     # 2**27 + 1 (Dekker)
_TEN16 = 10 ** 16
_TEN17 = 10 ** 17
_U10 = np.uint64(10)
_U10000 = np.uint64(10000)
_EXP_BITS = np.int64(0x7FF0000000000000)    # exponent field of a double
_MANT_BITS = np.int64(0x000FFFFFFFFFFFFF)   # its fraction field
_ULP_SHIFT = np.int64(52 << 52)             # exponent field - 52: the unit in the last place
_SHORT_BOUND = 0.5 * (1.0 - 1e-9)


def _scaled(ax: np.ndarray, i: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """ax * 10**p as a double-double (hi, lo), relative error < 2**-100
    (Dekker's exact product; no overflow for ax in _RANGE, |p| <= 270), where
    i = p - _P10_MIN indexes the table of powers of ten. In place where it
    can be (fewer temporaries): the operations are those of
    prod = ax * th;  ah, al = split(ax);  bh, bl = split(th)
    err = ((ah * bh - prod) + ah * bl + al * bh) + al * bl + ax * tl
    hi = prod + err;  lo = err - (hi - prod)."""
    th = _P10_HI.take(i)
    prod = ax * th
    bh = _SPLITTER * th                    # Dekker's split: bh = c - (c - th), c = S * th
    t = bh - th
    np.subtract(bh, t, out=bh)
    bl = np.subtract(th, bh, out=th)
    ah = _SPLITTER * ax
    np.subtract(ah, ax, out=t)
    np.subtract(ah, t, out=ah)
    al = ax - ah
    err = ah * bh
    err -= prod
    err += np.multiply(ah, bl, out=t)
    err += np.multiply(al, bh, out=t)
    err += np.multiply(al, bl, out=t)
    err += np.multiply(ax, _P10_LO.take(i), out=t)
    hi = prod + err
    np.subtract(hi, prod, out=t)
    lo = np.subtract(err, t, out=err)
    return hi, lo


def _round_int(hi: np.ndarray, lo: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Nearest integer to hi + lo (int64) and the residual int - (hi + lo)."""
    rh = np.rint(hi)
    frac = (hi - rh) + lo
    rf = np.rint(frac)
    return rh.astype(np.int64) + rf.astype(np.int64), rf - frac


def _decimal(ax: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """For positive finite ax in _RANGE (C-contiguous; m and e come out 1-D):
    (m, e) with 10**16 <= m < 10**17 and m * 10**(e - 16) a decimal that
    reads back exactly as ax, with 16 significant digits (m a multiple of 10;
    the nearest, an exact tie rounded down) when they suffice, else 17 (the
    nearest, ties to even).

    Why exact: the scaled value carries a relative error below 2**-100, so m
    is within 0.5 + 1e-13 units of the 17th digit of ax, i.e. within
    5.01e-17 * ax, less than half the gap to either neighbouring double
    (> 5.55e-17 * ax). The 16-digit candidate is kept only when its computed
    distance is below half the gap on its side, with a 1e-9 relative margin
    that dwarfs every rounding error of the test.
    """
    ax = ax.reshape(-1)
    e = np.floor(np.log10(ax)).astype(np.int64)
    m, resid = _round_int(*_scaled(ax, (16 - _P10_MIN) - e))   # resid = m - ax * 10**(16 - e)
    for _ in range(2):  # log10 may be off by one next to a power of ten
        fix = (m - _TEN16).view(np.uint64) >= np.uint64(_TEN17 - _TEN16)    # m out of range
        if not fix.any():
            break
        fix = np.flatnonzero(fix)
        e[fix] += np.where(m[fix] >= _TEN17, 1, -1)
        m[fix], resid[fix] = _round_int(*_scaled(ax[fix], (16 - _P10_MIN) - e[fix]))
    # 16 digits: v = ax * 10**(15 - e) = (m - resid) / 10 = a + (b - resid) / 10
    # with m = 10 a + b; the nearest integer m16 is a or a + 1, and its
    # distance to v (resid16 = m16 - v) follows exactly from small integers.
    a = (m.view(np.uint64) // _U10).view(np.int64)
    m16 = a + ((m - 10 * a - resid) > 5.0)
    resid16 = ((10 * m16 - m) + resid) * 0.1
    # Half the gap to the neighbouring double on the side of the candidate, in
    # units of the 16th digit: one unit in the last place, 2**(E - 52), read
    # off the exponent bits (ax is normal here), half that below a power of two.
    bits = ax.view(np.int64)
    ulp = ((bits & _EXP_BITS) - _ULP_SHIFT).view(np.float64)
    bound = _SHORT_BOUND * (ulp * _P10_HI.take((15 - _P10_MIN) - e))
    below = np.flatnonzero((bits & _MANT_BITS) == 0)     # powers of two: rare
    if below.size:
        below = below[resid16[below] < 0]
        bound[below] *= 0.5
    short = np.abs(resid16) < bound
    m = np.where(short, m16 * 10, m)
    carry = np.flatnonzero(m == _TEN17)          # rounded up to the next power of ten
    if carry.size:
        m[carry] = _TEN16
        e[carry] += 1
    return m, e


# Each value is first written into six 64-bit words (48 bytes) holding every
# character any of its forms could need:
#   byte 0: '-'   1-2: '0.'   3-5: '000'   (fixed notation, exponent -4..-1)
#   6 + 2i: digit i (i = 0..16)   7 + 2i: '.' after digit i
#   40-44: 'e', exponent sign, 3 exponent digits   45-46: unused   47: separator
# A byte mask chosen by the value's form (0xFF: keep, 0: drop) then zeroes the
# bytes it does not use, and bytes.translate deletes the zeros: the text of
# a value is its 48 bytes without the NULs.
_SLOT = 48
_WORDS = _SLOT // 8
_DELETE = b'\0'


def _u64(rows: list[bytes]) -> np.ndarray:
    return np.frombuffer(b''.join(rows), dtype=np.uint64).copy()


def _digit_words() -> np.ndarray:
    """'d.d.d.d.' for every group of 4 digits 0000..9999, as uint64."""
    g = np.arange(10000)
    chars = np.full((10000, 8), ord('.'), dtype=np.uint8)
    for i, p in enumerate((1000, 100, 10, 1)):
        chars[:, 2 * i] = ord('0') + g // p % 10
    return chars.view(np.uint64).ravel().copy()


_WORD0 = _u64([b'-0.000' + bytes([48 + d]) + b'.' for d in range(10)])
_WORD_DIGITS = _digit_words()
_EXP_MIN = -400


def _exponent_words() -> np.ndarray:
    """'e+XXX  ,' (sign, 3 digits, 2 unused bytes, separator) for every decimal
    exponent _EXP_MIN..-_EXP_MIN, as uint64."""
    e = np.arange(_EXP_MIN, -_EXP_MIN + 1)
    chars = np.empty((e.size, 8), dtype=np.uint8)
    chars[:, 0] = ord('e')
    chars[:, 1] = np.where(e < 0, ord('-'), ord('+'))
    for i, p in enumerate((100, 10, 1)):
        chars[:, 2 + i] = ord('0') + np.abs(e) // p % 10
    chars[:, 5:7] = ord(' ')
    chars[:, 7] = ord(',')
    return chars.view(np.uint64).ravel().copy()


_WORD_EXP = _exponent_words()
_G = np.arange(10000)
#: 4 * the trailing zeros of each group of 4 digits (4 * 4 for 0000).
_TRAILING4 = 4 * ((_G % 10 == 0).astype(np.int64) + (_G % 100 == 0) + (_G % 1000 == 0)
                  + (_G % 10000 == 0))
del _G
_I17 = np.arange(17)
_NEWLINE_XOR = np.uint64((ord(',') ^ ord('\n')) << 56)   # separator byte 47: ',' -> '\n'


_SCI = 21   # format class of scientific notation; classes 0..20: fixed, exponent e = class - 4


def _keep_rules(e: np.ndarray, nd: np.ndarray, neg: np.ndarray) -> np.ndarray:
    """Which template bytes a value keeps, from its decimal exponent e, its
    number of significant digits nd and its sign (see the layout above)."""
    n = e.size
    fixed = (e >= -4) & (e <= 16)
    sci = ~fixed
    fneg = fixed & (e < 0)
    keep = np.zeros((n, _SLOT), dtype=bool)
    keep[:, 0] = neg
    keep[:, 1] = fneg
    keep[:, 2] = fneg
    for z in range(3):
        keep[:, 3 + z] = fneg & (e <= -2 - z)
    int_digits = np.where(fixed & (e >= 0), e, -1)
    keep[:, 6:40:2] = (_I17 < nd[:, None]) | (_I17 <= int_digits[:, None])
    dot = np.where(fixed, np.where(nd > e + 1, e, -1), np.where(nd > 1, 0, -1))
    dot[fneg] = -1
    keep[:, 7:40:2] = _I17 == dot[:, None]
    keep[:, 40] = sci
    keep[:, 41] = sci
    keep[:, 42] = sci & (np.abs(e) >= 100)
    keep[:, 43] = sci
    keep[:, 44] = sci
    keep[:, 47] = True
    return keep


def _keep_table() -> np.ndarray:
    """Byte masks (rows of 6 uint64) of _keep_rules for every (class, nd,
    3-digit exponent, sign), indexed by ((class * 17 + nd - 1) * 2 + hundreds) * 2
    + negative."""
    cls, nd, hundreds, neg = np.meshgrid(np.arange(_SCI + 1), np.arange(1, 18), [0, 1], [0, 1],
                                         indexing='ij')
    cls, nd, hundreds, neg = (a.ravel() for a in (cls, nd, hundreds, neg))
    e = np.where(cls == _SCI, np.where(hundreds == 1, 100, 20), cls - 4)
    keep = _keep_rules(e, nd, neg.astype(bool))
    return np.ascontiguousarray(keep.astype(np.uint8) * 0xFF).view(np.uint64).copy()


_KEEP_MASKS = _keep_table()


def _exponent_patterns() -> np.ndarray:
    """The part of the _KEEP_MASKS index set by the decimal exponent e, for
    e = _EXP_MIN.. -_EXP_MIN, with nd = 17 (each trailing zero takes 4 off,
    a minus sign adds 1)."""
    e = np.arange(_EXP_MIN, -_EXP_MIN + 1)
    cls = np.where((e >= -4) & (e <= 16), e + 4, _SCI)
    return (cls * 17 + 16) * 4 + 2 * (np.abs(e) >= 100)


_PATTERN_E = _exponent_patterns()


def _special_words(v: float) -> np.ndarray:
    """The six words of a value outside the vectorised range: 0, nan, inf and
    the tiny or huge (Python's '%.17g')."""
    chars = bytearray(_SLOT)
    if v == 0:
        text = b'0'
    elif v != v:
        text = b'nan'
    else:
        text = ('%.17g' % abs(v)).encode()
    if v == v and np.signbit(v):
        chars[0] = ord('-')
    chars[1:1 + len(text)] = text
    chars[_SLOT - 1] = ord(',')
    return np.frombuffer(bytes(chars), dtype=np.uint64)


_ZERO_WORDS = np.stack([_special_words(0.0), _special_words(-0.0)])


def _format_into(x: np.ndarray, out: np.ndarray) -> None:
    """Write the six words of every value of x (float64, C-contiguous, any
    shape) into out (uint64, shape x.shape + (6,), may be a view), with the
    unused bytes zeroed and ',' as separator (see the layout above)."""
    shape = x.shape
    ax = np.abs(x)
    fast = (ax >= _RANGE[0]) & (ax <= _RANGE[1])      # false for 0, nan, inf
    all_fast = bool(fast.all())
    if not all_fast:
        ax = np.where(fast, ax, 1.0)
    m, e = _decimal(ax)
    # digits: m = g * 10**16 + four groups r[3], r[2], r[1], r[0] of 4 digits
    g = m.view(np.uint64)
    r = []
    for col in (4, 3, 2, 1):
        q = g // _U10000
        r.append((g - q * _U10000).view(np.int64))
        g = q
        out[..., col] = _WORD_DIGITS.take(r[-1]).reshape(shape)
    out[..., 0] = _WORD0.take(g.view(np.int64)).reshape(shape)
    ei = e - _EXP_MIN
    out[..., 5] = _WORD_EXP.take(ei).reshape(shape)
    # 4 * the trailing zeros of m: those of r[0], unless r[0] = 0000
    tz4 = _TRAILING4.take(r[0])
    more = np.flatnonzero(r[0] == 0)
    if more.size:
        t = _TRAILING4.take(r[3][more])
        for rk in (r[2][more], r[1][more]):
            t = _TRAILING4.take(rk) + (rk == 0) * t
        tz4[more] += t
    pattern = _PATTERN_E.take(ei) - tz4 + np.signbit(x).reshape(-1)
    out &= _KEEP_MASKS.take(pattern, axis=0).reshape(out.shape)
    if not all_fast:
        special = np.flatnonzero(~fast)
        values = x.reshape(-1)[special]
        zero = values == 0
        out[np.unravel_index(special[zero], shape)] = _ZERO_WORDS.take(
            np.signbit(values[zero]).astype(np.intp), axis=0)
        for i in np.flatnonzero(~zero):            # nan, inf, tiny, huge: rare
            out[np.unravel_index(special[i], shape)] = _special_words(float(values[i]))


def format_values(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Format doubles as text, vectorised.

    Returns ``(chars, keep)``, both of shape (n, 48): the text of value i is
    ``chars[i, :47][keep[i, :47]]``; ``chars[:, 47]`` is a separator slot
    (',' and kept). The text follows ``'%.17g'`` (fixed notation for decimal
    exponents -4..16, else ``d.ddde+XX``) but uses 16 significant digits
    whenever 16 read back exactly: ``float(text) == x`` always, the sign of
    zero included (``nan``, ``inf``, ``-inf`` for the non-finite)."""
    x = np.ascontiguousarray(x, dtype=np.float64).ravel()
    words = np.empty((x.size, _WORDS), dtype=np.uint64)
    _format_into(x, words)
    chars = words.view(np.uint8)
    return chars, chars != 0


def format_value(x: float) -> str:
    """The text :func:`format_values` gives one value."""
    chars, keep = format_values(np.array([x]))
    return chars[0, :-1][keep[0, :-1]].tobytes().decode()


def _format_chunks(data: np.ndarray, chunk_values: int = 8192,
                   text: tuple[np.ndarray, np.ndarray] | None = None) -> Iterator[bytes]:
    """The rows of ``data`` (2-D float64) as text, in blocks of about
    ``chunk_values`` numbers (cache-sized). ``text = (slots, codes)`` ends
    row i with the words ``slots[codes[i]]`` (NUL-padded text of its last
    column and the newline; shape (k, 6) each) after the numbers' ','."""
    nrows, ncol = data.shape
    step = max(1, chunk_values // max(ncol, 1))
    k = 0 if text is None else text[0].shape[1]
    if ncol + k == 0:                   # no columns at all: empty lines
        yield b'\n' * nrows
        return
    for start in range(0, nrows, step):
        block = np.ascontiguousarray(data[start:start + step])
        nb = block.shape[0]
        buf = np.empty((nb, ncol + k, _WORDS), dtype=np.uint64)
        _format_into(block, buf[:, :ncol])
        if text is not None:
            buf[:, ncol:] = text[0].take(text[1][start:start + nb], axis=0)
        else:
            buf[:, ncol - 1, _WORDS - 1] ^= _NEWLINE_XOR
        # bytes.translate deletes the NULs fastest (a bytearray's is slower, and
        # its results keep the whole input's size allocated)
        yield buf.tobytes().translate(None, _DELETE)


def format_table(data: np.ndarray, *, chunk_values: int = 8192) -> bytes:
    """Rows of comma-separated exact decimals, each row ending in a newline.
    Works in blocks of about ``chunk_values`` numbers (cache-sized)."""
    data = np.asarray(data, dtype=np.float64)
    if data.ndim != 2:
        raise ValueError(f'expected a 2-D array, got shape {data.shape}')
    return b''.join(_format_chunks(data, chunk_values))


@contextlib.contextmanager
def atomic_output(path: str | os.PathLike[str]) -> Iterator[IO[bytes]]:
    """Open ``path`` for binary writing so that it appears complete or not at
    all: the data goes to a temporary file in the same directory, which
    replaces ``path`` only when the block finishes without an exception (the
    old file, if any, is untouched otherwise). ``-`` writes to standard output."""
    if os.fspath(path) == '-':
        yield sys.stdout.buffer
        sys.stdout.buffer.flush()
        return
    path = os.fspath(path)
    directory = os.path.dirname(os.path.abspath(path))
    if os.path.isdir(path):
        raise CsvError('is a directory; cannot write a file there', path=path)
    if not os.path.isdir(directory):
        raise CsvError(f"cannot write: directory '{os.path.dirname(path) or '.'}' does not exist",
                       path=path)
    import tempfile

    fd, tmp = tempfile.mkstemp(prefix='.' + os.path.basename(path) + '.', suffix='.tmp',
                               dir=directory)
    try:
        with os.fdopen(fd, 'wb') as f:
            yield f
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise


def _text_slots(index: dict[str, int]) -> np.ndarray | None:
    """The slots of :func:`_format_chunks` for the words of ``index`` (word ->
    its number): its text and the newline, NUL-padded to whole 48-byte slots.
    None if a word holds a NUL (then the rows are joined one by one)."""
    words = [v.encode() + b'\n' for v in index]
    if any(_DELETE in w for w in words):
        return None
    width = -(-max(len(w) for w in words) // _SLOT)
    slots = b''.join(w.ljust(width * _SLOT, _DELETE) for w in words)
    return np.frombuffer(slots, dtype=np.uint64).reshape(len(words), width, _WORDS)


def write_csv(path: str | os.PathLike[str], names: Sequence[str], data: np.ndarray,
              text: tuple[str, Sequence[str]] | None = None) -> None:
    """Write a header and the rows of ``data`` (N, len(names)), exactly, atomically;
    ``text = (name, values)`` appends one column of plain words (no commas)."""
    data = np.asarray(data, dtype=np.float64)
    if data.ndim != 2 or data.shape[1] != len(names):
        raise ValueError(f'{len(names)} column names for data of shape {data.shape}')
    header = ','.join(names)
    if text is None:
        body: Iterable[bytes] = _format_chunks(data)
    else:
        name, values = text
        index: dict[str, int] = {}      # the distinct words (a handful, e.g. statuses)
        codes = np.fromiter((index.setdefault(v, len(index)) for v in values), dtype=np.intp,
                            count=len(values)) if len(values) == data.shape[0] else None
        if codes is None or any(',' in v or '\n' in v for v in index):
            raise ValueError(f'text column {name!r}: one word per row expected')
        header += ',' + name
        slots = _text_slots(index) if index else None
        if slots is not None:
            body = _format_chunks(data, text=(slots, codes))
        else:                           # no rows, or a NUL in a word: row by row
            rows = format_table(data).split(b'\n')[:-1]
            body = [b''.join(row + b',' + v.encode() + b'\n' for row, v in zip(rows, values))]
    with atomic_output(path) as f:
        f.write((header + '\n').encode())
        for part in body:               # written as formatted: the memory is reused
            f.write(part)
