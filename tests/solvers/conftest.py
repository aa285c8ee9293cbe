"""Fixtures of the solver tests."""

from __future__ import annotations

from collections.abc import Callable

import pytest

from cbrcore.plugins import Plugins


@pytest.fixture
def solver_plugins(cbr_plugins: Callable[..., Plugins]) -> Plugins:
    """The installed grid and solver plugins, loaded through their entry points."""
    return cbr_plugins(entry_points=True, environ={"CBR_PLUGINS": "core,grid,solvers"})
