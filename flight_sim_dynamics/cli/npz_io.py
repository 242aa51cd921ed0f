"""Binary tables for the command line: numpy's ``.npz`` (``np.savez``).

``solve -o out.npz`` writes the same columns as its CSV output, without any
text formatting (the fast choice for large batches):

* one array per column, named like the CSV column, shape (N,): float64 for
  the numbers, and ``status`` as strings (numpy unicode, e.g. ``'ok'``,
  ``'unreachable'``), the same words as the CSV's status column;
* ``names``: the column names in the CSV's order (status last), so that
  ``np.load('out.npz')['names']`` tells how to lay the arrays side by side.

Loaded with ``np.load(path)`` (no pickle needed). :func:`read_npz` reads one
back as a :class:`~.csv_io.Table`, checked like a CSV file.
"""
from __future__ import annotations

import os
import zipfile
from typing import Sequence

import numpy as np

from .csv_io import CsvError, Table, atomic_output

#: File-name suffix that selects this format (any other: CSV).
SUFFIX = '.npz'
#: Name of the array that lists the columns in order.
NAMES_KEY = 'names'


def is_npz(path: str | os.PathLike[str]) -> bool:
    """Whether ``path`` names an .npz file (by its suffix, any case)."""
    return os.fspath(path).lower().endswith(SUFFIX)


def write_npz(path: str | os.PathLike[str], names: Sequence[str], data: np.ndarray,
              text: tuple[str, Sequence[str]] | None = None) -> None:
    """Write the columns of ``data`` (N, len(names)) as named arrays and the
    ``names`` array, atomically (see the module docstring); ``text = (name,
    words)`` adds one column of strings. Same arguments as ``write_csv``.
    """
    data = np.asarray(data, dtype=np.float64)
    if data.ndim != 2 or data.shape[1] != len(names):
        raise ValueError(f'{len(names)} column names for data of shape {data.shape}')
    arrays = {name: data[:, j] for j, name in enumerate(names)}
    order = list(names)
    if text is not None:
        name, words = text
        if len(words) != data.shape[0]:
            raise ValueError(f'text column {name!r}: one word per row expected')
        arrays[name] = np.asarray(words, dtype=str)
        order.append(name)
    if len(set(order)) != len(order) or NAMES_KEY in order:
        raise ValueError(f'column names must be distinct and not {NAMES_KEY!r}: {order}')
    arrays[NAMES_KEY] = np.asarray(order, dtype=str)
    with atomic_output(path) as f:
        np.savez(f, **arrays)


def read_npz(path: str | os.PathLike[str], *, required: Sequence[str],
             optional: Sequence[str] = ()) -> Table:
    """The numeric columns of an .npz written by :func:`write_npz` as a Table
    (``lines``: the line each row has in the CSV form). Raises CsvError naming
    the file and the column when ``required`` columns are missing or hold
    anything but finite numbers; columns neither required nor ``optional``
    are left out (an ``optional`` one is read, and checked, when present).
    """
    shown = os.fspath(path)
    try:
        with np.load(path, allow_pickle=False) as npz:
            arrays = {key: npz[key] for key in npz.files}
    except (OSError, ValueError, zipfile.BadZipFile) as exc:
        raise CsvError(f'cannot read as .npz: {exc}', path=shown) from None
    if NAMES_KEY not in arrays:
        raise CsvError(f"no '{NAMES_KEY}' array: not an .npz written by solve", path=shown)
    names = tuple(str(n) for n in arrays[NAMES_KEY])
    missing = [n for n in required if n not in names or n not in arrays]
    if missing:
        raise CsvError(f"missing column{'s' if len(missing) > 1 else ''} "
                       f"{', '.join(repr(m) for m in missing)}; it has {', '.join(names)}",
                       path=shown)
    kept = tuple(n for n in names if n in required or (n in optional and n in arrays))
    columns = []
    for j, name in enumerate(kept):
        column = arrays[name]
        if column.ndim != 1 or column.dtype.kind not in 'fiu':
            raise CsvError(f'not a 1-D array of numbers ({column.dtype}, shape {column.shape})',
                           path=shown, column=names.index(name) + 1, name=name)
        if columns and column.shape != columns[0].shape:
            raise CsvError(f'{column.size} rows, column {kept[0]!r} has {columns[0].size}',
                           path=shown, column=names.index(name) + 1, name=name)
        bad = np.flatnonzero(~np.isfinite(column))
        if bad.size:
            raise CsvError(f'{column[bad[0]]} in row {bad[0] + 1} is not a finite number',
                           path=shown, column=names.index(name) + 1, name=name)
        columns.append(np.asarray(column, dtype=np.float64))
    n = columns[0].size if columns else 0
    data = np.column_stack(columns) if columns else np.empty((n, 0))
    return Table(path=shown, names=kept, data=data, lines=np.arange(2, n + 2))


def text_column(path: str | os.PathLike[str], name: str) -> list[str] | None:
    """The strings of array ``name`` (e.g. ``status``) of an .npz that
    :func:`read_npz` has read; None when there is no such array.
    """
    with np.load(path, allow_pickle=False) as npz:
        if name not in npz.files:
            return None
        column = npz[name]
    if column.ndim != 1 or column.dtype.kind != 'U':
        raise CsvError(f'not a 1-D array of strings ({column.dtype}, shape {column.shape})',
                       path=os.fspath(path), name=name)
    return column.tolist()
