"""The shipped hexapod parameter files (config/stewart_*.yaml) are the
machines docs/design/stewart.md prints, and build them."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import yaml

from flight_sim_dynamics.config.files import PACKAGED_SECTION
from flight_sim_dynamics.machines.stewart import model as stewart_model
from stewart_cases import doc_machines

CONFIG = Path(__file__).resolve().parents[3] / 'config'
NAMES = ('stewart_6dof', 'stewart_tsai2000')


def shipped_machine(name: str) -> dict:
    """The shipped file's parameters without its ``cueing`` group (the planner's,
    docs/cueing.md; the loaders take it apart before the machine's builder sees
    the file).
    """
    shipped = yaml.safe_load((CONFIG / f'{name}.yaml').read_text(encoding='utf-8'))
    params = shipped[PACKAGED_SECTION]['ros__parameters']
    params.pop('cueing', None)
    return params


@pytest.mark.parametrize('name', NAMES)
def test_the_shipped_file_is_the_documented_machine(name):
    assert shipped_machine(name) == doc_machines()[name]


@pytest.mark.parametrize('name', NAMES)
def test_the_shipped_file_builds_its_machine(name):
    model = stewart_model.from_dict(shipped_machine(name))
    documented = stewart_model.from_dict(doc_machines()[name])
    assert model.name == name
    np.testing.assert_array_equal(model.base_joints, documented.base_joints)
    np.testing.assert_array_equal(model.platform_joints, documented.platform_joints)
