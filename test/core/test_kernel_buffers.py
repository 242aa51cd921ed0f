"""The machines' kernels take a batch only as rows of float64 numbers
(core/kernel_support.h: get_rows): anything else is a ValueError, never read
as other numbers."""
from __future__ import annotations

import importlib
import os

import numpy as np
import pytest

import flight_sim_dynamics as fsd

MACHINES = [('staicu', None, 3), ('stewart', 'config/stewart_6dof.yaml', 6)]


@pytest.mark.parametrize('name, params_file, dof', MACHINES, ids=[m[0] for m in MACHINES])
def test_a_batch_is_rows_of_float64_numbers(name, params_file, dof):
    kernel = importlib.import_module(f'flight_sim_dynamics.machines.{name}.kernel')
    if kernel._kernel is None:
        assert os.environ.get('FSD_REQUIRE_KERNEL') != '1', kernel.IMPORT_ERROR
        pytest.skip('the kernel is not built')
    params, bits = kernel.prepared(fsd.load_model(params_file) if params_file
                                   else fsd.load_model())
    size = kernel._kernel.OUT_SIZE
    rows = np.zeros((2, dof))
    out = np.full((2, size), np.nan)
    kernel._kernel.solve_batch(params, bits, rows, rows, rows, out)
    assert np.isfinite(out).all()
    # as many bytes as 2 rows of float64, but float32; a row too long; no whole row
    for q in (np.zeros((4, dof), dtype=np.float32), np.zeros((2, dof + 1)),
              np.zeros(2 * dof + 1)):
        with pytest.raises(ValueError):
            kernel._kernel.solve_batch(params, bits, q, rows, rows, out)
