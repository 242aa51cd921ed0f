"""Fixtures of the plugin machine's tests: the plugin found in-process through
the real entry-point mechanism (its folder on sys.path, the registry read again)."""
from __future__ import annotations

import importlib
import warnings

import pytest

import flight_sim_dynamics as fsd
from flight_sim_dynamics import machines as registry
from plugin_site import DIST, NAME, PARAMS


@pytest.fixture
def plugin(monkeypatch):
    """The plugin's distribution on the path, the registry read again; after the
    test, neither (the next use reads the entry points without it)."""
    monkeypatch.syspath_prepend(str(DIST))
    importlib.invalidate_caches()
    registry.clear_cache()
    with warnings.catch_warnings():
        warnings.simplefilter('error', registry.MachinePluginWarning)
        machine = registry.machine_named(NAME)
    yield machine
    monkeypatch.undo()
    registry.clear_cache()


@pytest.fixture
def model(plugin):
    """The plugin machine's model of its parameter file."""
    return fsd.load_model(PARAMS)
