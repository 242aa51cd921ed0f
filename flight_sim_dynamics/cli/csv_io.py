"""CSV reading and writing for the command line (numbers only, SI units).

Reading is strict and fast. A file is a header line of column names followed
by rows of decimal numbers separated by commas. Every value must be a finite
decimal number (``1``, ``-0.5``, ``2.5e-3``); ``nan``, ``inf``, empty cells,
blank lines and rows with too few or too many values are errors, reported as
:class:`CsvError` naming the file, the line (1 = the header) and the column
(1-based number and name). The fast path parses the whole file in C (numpy);
only when it fails does a line-by-line scan run to find the exact cell.

Writing is exact: every float is written as Python's ``repr`` gives it (the
shortest decimal that reads back as the identical double; an integral value
without its ``.0``), see :func:`format_value`. For large batches the binary
``.npz`` output of ``solve`` is the faster choice (benchmarks/csv_output.py).
Files are written to a temporary file in the destination directory and moved
into place with :func:`os.replace` (:func:`atomic_output`), so a failed run
never leaves a partial file and never clobbers an old one.
"""
from __future__ import annotations

import contextlib
import os
import signal
import stat
import tempfile
import threading
import re
import sys
from dataclasses import dataclass
from typing import IO, Iterator, Sequence

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
    data row ``i``, read from line ``lines[i]`` of the file; ``skipped``: the
    columns of the file not read (``skip_extra``).
    """

    path: str
    names: tuple[str, ...]
    data: np.ndarray      # (N, ncol) float64
    lines: np.ndarray     # (N,) int, 1-based line numbers (header = 1)
    skipped: tuple[str, ...] = ()     # columns of the file left out (skip_extra)

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
    CsvError with a plain message.
    """
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
    and (unless ``allow_extra``) unknown names.
    """
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
        near = [f"'{n}' (column {j + 1}){_did_you_mean(n, missing)}"
                for j, n in enumerate(names) if n not in required and _did_you_mean(n, missing)]
        raise CsvError(f'missing column{"s" if len(missing) > 1 else ""} '
                       f"{', '.join(repr(m) for m in missing)}; "
                       f'the header must name {expected} (any order)'
                       + (f"; it has {', '.join(near)}" if near else ''), path=path, line=1)
    return names


def _did_you_mean(name: str, candidates: Sequence[str]) -> str:
    lowered = {c.lower(): c for c in candidates}
    if name.lower() in lowered:
        return f" (did you mean '{lowered[name.lower()]}'?)"
    import difflib      # only for this error message

    close = difflib.get_close_matches(name, candidates, n=1)
    return f" (did you mean '{close[0]}'?)" if close else ''


def read_csv(path: str | os.PathLike[str], *, required: Sequence[str],
             allow_extra: bool = False, text_columns: Sequence[str] = (),
             skip_extra: bool = False) -> Table:
    """Read a numeric CSV file with a header naming at least ``required``
    (exactly those, in any order, unless ``allow_extra`` or ``skip_extra``).

    Raises :class:`CsvError` naming the line and column of the first problem.
    """
    display = _display(path)
    data = read_bytes(path)
    return parse_csv(data, display, required=required, allow_extra=allow_extra,
                     text_columns=text_columns, skip_extra=skip_extra)


def parse_csv(data: bytes, path: str = '<input>', *, required: Sequence[str],
              allow_extra: bool = False, text_columns: Sequence[str] = (),
              skip_extra: bool = False) -> Table:
    """:func:`read_csv` on the bytes of a file. Columns named in ``text_columns``
    (words such as ``status``) are skipped, not parsed as numbers; with
    ``skip_extra`` so is every column not in ``required`` (any content), and
    ``Table.skipped`` names them. Errors name the file's own column numbers.
    """
    if data.startswith(b'\xef\xbb\xbf'):
        data = data[3:]
    if not data or data.isspace():
        raise CsvError('the file is empty; expected a header line '
                       f"{','.join(required)} and rows of numbers", path=path, line=1)
    end = data.find(b'\n')
    header = data if end < 0 else data[:end]
    all_names = parse_header(header, path, required=required,
                             allow_extra=allow_extra or skip_extra)
    skip = frozenset(j for j, name in enumerate(all_names)
                     if name in text_columns or (skip_extra and name not in required))
    keep = [j for j in range(len(all_names)) if j not in skip]
    names = tuple(all_names[j] for j in keep)
    # one copy of the rows, without the trailing blank lines (they are fine;
    # any other blank line is a row with every value missing)
    body = data[end + 1:_content_end(data)] if end >= 0 else b''
    if not body:
        raise CsvError('no data rows after the header', path=path, line=2)
    nrows = _count(body, b'\n') + 1
    values = None
    if skip:
        rows = [line.split(b',') for line in body.split(b'\n')]
        if all(len(cells) == len(all_names) for cells in rows):
            kept = b'\n'.join(b','.join(cells[j] for j in keep) for cells in rows)
            values = _parse_fast(kept, nrows, len(keep))
    else:
        values = _parse_fast(body, nrows, len(keep))
    if values is None:
        values = _parse_slow(body, all_names, path, skip)  # raises on the first bad cell
    bad = ~np.isfinite(values)
    if bad.any():  # e.g. 1e999: a valid literal, but not a finite double
        i, j = np.argwhere(bad)[0]
        cell = body.split(b'\n')[i].split(b',')[keep[j]].decode().strip()
        raise CsvError(f"'{cell}' is not a finite number", path=path, line=int(i) + 2,
                       column=keep[j] + 1, name=names[j])
    skipped = tuple(all_names[j] for j in sorted(skip) if all_names[j] not in text_columns)
    return Table(path=path, names=names, data=values, lines=np.arange(2, nrows + 2),
                 skipped=skipped)


def text_column(data: bytes, name: str) -> list[str] | None:
    """The words of column ``name`` (e.g. ``status``) of a file whose bytes
    :func:`parse_csv` has read with it in ``text_columns``, one per row;
    None when the header has no such column.
    """
    if data.startswith(b'\xef\xbb\xbf'):
        data = data[3:]
    lines = data[:_content_end(data)].split(b'\n')
    names = [cell.strip() for cell in lines[0].decode('utf-8', 'replace').split(',')]
    if name not in names:
        return None
    j = names.index(name)
    return [line.split(b',')[j].decode('utf-8', 'replace').strip() for line in lines[1:]]


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
    slow scan finds and reports the offending cell).
    """
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


def _parse_slow(body: bytes, names: Sequence[str], path: str,
                skip: frozenset[int] = frozenset()) -> np.ndarray:
    """Line-by-line parse that raises CsvError at the first malformed cell;
    the columns in ``skip`` (0-based) may hold anything and are left out.
    """
    ncol = len(names)
    keep = [j for j in range(ncol) if j not in skip]
    rows = body.split(b'\n')
    out = np.empty((len(rows), len(keep)))
    for i, raw in enumerate(rows):
        line = i + 2
        try:
            text = raw.decode('utf-8').rstrip('\r')
        except UnicodeDecodeError:
            raise CsvError('not valid UTF-8 text', path=path, line=line) from None
        if not text.strip():
            raise CsvError(f'empty line; expected {ncol} values', path=path, line=line)
        cells = text.split(',')
        for k, j in enumerate(keep):
            if j >= len(cells):
                break
            cell = cells[j]
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
            out[i, k] = value
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
# Writing: exact, with Python's own float repr
# ----------------------------------------------------------------------------
#: Rows formatted per block (the block's text stays small).
BLOCK_ROWS = 4096


def format_value(x: float) -> str:
    """The text of one value in the files written here: Python's ``repr``
    (the shortest decimal that reads back as the same double, the sign of zero
    included), without the ``.0`` of an integral value (``1``, ``-0``).
    """
    text = repr(float(x))
    return text[:-2] if text.endswith('.0') else text


def _format_blocks(data: np.ndarray, words: Sequence[str] | None = None,
                   block_rows: int = BLOCK_ROWS) -> Iterator[bytes]:
    """The rows of ``data`` (2-D float64) as text, each value as
    :func:`format_value` gives it, ``block_rows`` rows at a time; ``words``
    (one per row) end each row as a last column.
    """
    nrows, ncol = data.shape
    sep = ',' if ncol else ''
    for start in range(0, nrows, block_rows):
        rows = data[start:start + block_rows].tolist()
        if words is None:
            text = ''.join([','.join(map(repr, row)) + '\n' for row in rows])
            text = text.replace('.0\n', '\n')
        else:
            text = ''.join([','.join(map(repr, row)) + sep + word + '\n'
                            for row, word in zip(rows, words[start:start + block_rows])])
        # repr writes integral values as 'd.0'; a '.0' before a separator is
        # only ever that (the words come last and hold no comma)
        yield text.replace('.0,', ',').encode()


def format_table(data: np.ndarray, *, chunk_values: int = 8192) -> bytes:
    """Rows of comma-separated exact decimals (:func:`format_value`), each row
    ending in a newline; formatted in blocks of about ``chunk_values`` numbers.
    """
    data = np.asarray(data, dtype=np.float64)
    if data.ndim != 2:
        raise ValueError(f'expected a 2-D array, got shape {data.shape}')
    block_rows = max(1, chunk_values // max(data.shape[1], 1))
    return b''.join(_format_blocks(data, block_rows=block_rows))


@contextlib.contextmanager
def atomic_output(path: str | os.PathLike[str]) -> Iterator[IO[bytes]]:
    """Open ``path`` for binary writing so that it appears complete or not at
    all: the data goes to a temporary file in the same directory, which
    replaces ``path`` only when the block finishes without an exception (the
    old file, if any, is untouched otherwise). ``-`` writes to standard output.

    What is at ``path`` is respected: a character device, FIFO or socket
    (``/dev/null``, ``/dev/stdout``, a named pipe) is written through, never
    replaced; a symbolic link is followed and its target replaced (the link
    stays); a replaced file keeps its mode; a read-only file is refused. A
    SIGTERM or SIGHUP during the write removes the temporary file and ends
    the process with status 128 + the signal, as the signal would.
    """
    if os.fspath(path) == '-':
        yield sys.stdout.buffer
        sys.stdout.buffer.flush()
        return
    shown = os.fspath(path)
    target = os.path.realpath(shown)            # a symlink: its target
    try:
        st = os.stat(target)
    except FileNotFoundError:
        st = None
    except OSError as exc:
        raise CsvError(f'cannot write: {exc.strerror}', path=shown) from None
    if st is not None and (stat.S_ISCHR(st.st_mode) or stat.S_ISFIFO(st.st_mode)
                           or stat.S_ISSOCK(st.st_mode)):
        with _errors_named(shown), open(target, 'wb') as f:    # write through, never replace
            yield f
        return
    if st is not None and not stat.S_ISREG(st.st_mode):
        what = 'a directory' if stat.S_ISDIR(st.st_mode) else 'not a regular file'
        raise CsvError(f'is {what}; cannot write a file there', path=shown)
    if st is not None and not st.st_mode & 0o222:
        raise CsvError(f'is read-only (mode {stat.S_IMODE(st.st_mode):04o}): not replaced',
                       path=shown)
    directory = os.path.dirname(target)
    if not os.path.isdir(directory):
        raise CsvError(f"cannot write: directory '{os.path.dirname(shown) or '.'}' does not "
                       'exist', path=shown)
    with _errors_named(shown):
        fd, tmp = tempfile.mkstemp(prefix='.' + os.path.basename(target) + '.', suffix='.tmp',
                                   dir=directory)
    try:
        with _signals_end_the_write(), _errors_named(shown):
            with os.fdopen(fd, 'wb') as f:
                yield f
            if st is None:
                umask = os.umask(0)
                os.umask(umask)
                os.chmod(tmp, 0o666 & ~umask)
            else:
                os.chmod(tmp, stat.S_IMODE(st.st_mode))
            os.replace(tmp, target)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise


@contextlib.contextmanager
def _errors_named(shown: str) -> Iterator[None]:
    """An OSError while writing, as a CsvError naming the user's path (not the
    temporary file).
    """
    try:
        yield
    except OSError as exc:
        raise CsvError(f'cannot write: {exc.strerror or exc}', path=shown) from None


class _Terminated(BaseException):
    """A catchable termination signal, raised where the write is."""


@contextlib.contextmanager
def _signals_end_the_write() -> Iterator[None]:
    """SIGTERM and SIGHUP raise inside the block (so that the temporary file is
    removed on the way out) and then end the process as the signal would;
    the previous handlers are restored. Only the main thread gets signals.
    """
    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def handler(signum: int, frame: object) -> None:
        raise _Terminated(signum)

    old = {s: signal.signal(s, handler) for s in (signal.SIGTERM, signal.SIGHUP)}
    try:
        yield
    except _Terminated as exc:
        raise SystemExit(128 + exc.args[0]) from None
    finally:
        for s, h in old.items():
            signal.signal(s, h)


def write_csv(path: str | os.PathLike[str], names: Sequence[str], data: np.ndarray,
              text: tuple[str, Sequence[str]] | None = None) -> None:
    """Write a header and the rows of ``data`` (N, len(names)), exactly, atomically;
    ``text = (name, values)`` appends one column of plain words (no commas).
    """
    data = np.asarray(data, dtype=np.float64)
    if data.ndim != 2 or data.shape[1] != len(names):
        raise ValueError(f'{len(names)} column names for data of shape {data.shape}')
    header = ','.join(names)
    words = None
    if text is not None:
        name, words = text
        if len(words) != data.shape[0] or any(',' in w or '\n' in w for w in set(words)):
            raise ValueError(f'text column {name!r}: one word per row expected')
        header += ',' + name
    with atomic_output(path) as f:
        f.write((header + '\n').encode())
        for part in _format_blocks(data, words):     # written as formatted
            f.write(part)
