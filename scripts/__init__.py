"""Documentation generators (not installed), run from the repository root:
``python -m scripts.reproduction_table``, ``python -m scripts.node_param_table`` and
``python -m scripts.stewart_tables``.
Each writes its block between ``<!-- NAME:begin -->`` and ``<!-- NAME:end -->``
of a page under docs/.
"""
from __future__ import annotations

from pathlib import Path

DOCS = Path(__file__).resolve().parent.parent / 'docs'


def markers(name: str) -> tuple[str, str]:
    return f'<!-- {name}:begin -->', f'<!-- {name}:end -->'


def block(path: Path, name: str) -> str:
    """The text between the markers ``name`` of ``path``."""
    begin, end = markers(name)
    doc = path.read_text()
    if begin not in doc or end not in doc:
        raise SystemExit(f'{path}: markers {begin} ... {end} not found')
    return doc.split(begin, 1)[1].split(end, 1)[0].strip('\n')


def replace_block(path: Path, name: str, text: str) -> None:
    """Replace the text between the markers ``name`` of ``path`` with ``text``."""
    begin, end = markers(name)
    block(path, name)
    head, rest = path.read_text().split(begin, 1)
    path.write_text(f'{head}{begin}\n{text.strip(chr(10))}\n{end}{rest.split(end, 1)[1]}')
