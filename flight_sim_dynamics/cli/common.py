"""What the subcommands of the command line share: the user-error type, the
model from ``--params``/``--scene``, and writing a result table (CSV or .npz
by the output's suffix).
"""
from __future__ import annotations

import os
from typing import Sequence

import numpy as np

import flight_sim_dynamics as fsd

from . import csv_io, npz_io
from ..config.scenes import SceneError


class CliError(Exception):
    """A user error: printed as ``error: <message>``, exit status 2."""


def load_model(params: str | None, scene: str | None = None) -> fsd.Model:
    """The model from ``--params`` (None: packaged defaults) and ``--scene``."""
    if params is not None and not os.path.isfile(params):
        raise CliError(f"--params {params}: no such file")
    try:
        return fsd.load_model(params, scene=scene)
    except SceneError as exc:           # before its parent class ParameterError
        raise CliError(f'--scene: {exc}') from None
    except fsd.ParameterError as exc:
        raise CliError(f"--params {params or '(packaged defaults)'}: {exc}") from None


def write_table(path: str, names: Sequence[str], data: np.ndarray,
                text: tuple[str, Sequence[str]] | None = None) -> None:
    """Write a result table as .npz if ``path`` ends so (:mod:`.npz_io`),
    else as CSV (:func:`.csv_io.write_csv`); same arguments as both.
    """
    write = npz_io.write_npz if npz_io.is_npz(path) else csv_io.write_csv
    write(path, names, data, text=text)
