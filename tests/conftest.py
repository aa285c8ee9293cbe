"""Fixtures shared by the test suite (cbrcore's own fixtures come from cbrcore.testing)."""

from __future__ import annotations

from collections.abc import Callable, Iterator
from pathlib import Path

import pytest

import cbr_observers
import toy_domain
from cbrcore.casebase.memory import MemoryStore
from cbrcore.casebase.sqlite import SQLiteStore
from cbrcore.casebase.store import CaseStore
from cbrcore.plugins import Plugins

PLUGIN_VARIABLES = ("CBR_PLUGINS", "CBR_DISABLE_PLUGINS", "CBR_STRICT_PLUGINS")


@pytest.fixture(autouse=True)
def _no_plugin_environment(monkeypatch: pytest.MonkeyPatch) -> None:
    """Keep the caller's plugin environment variables out of every test."""
    for name in PLUGIN_VARIABLES:
        monkeypatch.delenv(name, raising=False)


@pytest.fixture
def load_toy(cbr_plugins: Callable[..., Plugins]) -> Callable[..., Plugins]:
    """A callable ``load_toy(*extra) -> Plugins`` making the toy domain current.

    It loads the toy domain with the built-in plugins (``core`` and ``observers``, registered in
    code rather than through their entry points) and any test-only ``extra`` plugins, given as
    ``cbr_plugins`` takes them; each call makes a fresh set current until the test ends.
    """
    import cbrcore.builtins

    def load(*extra: object) -> Plugins:
        return cbr_plugins(("toy", toy_domain), ("core", cbrcore.builtins),
                           ("observers", cbr_observers), *extra)

    return load


@pytest.fixture
def toy_plugins(load_toy: Callable[..., Plugins]) -> Plugins:
    """The toy domain and the built-in plugins, made current for the test."""
    return load_toy()


@pytest.fixture(params=["memory", "sqlite"])
def store(request: pytest.FixtureRequest, tmp_path: Path) -> Iterator[CaseStore]:
    """An empty case base: each test using it runs on the memory and on the SQLite store."""
    if request.param == "memory":
        yield MemoryStore()
    else:
        with SQLiteStore(tmp_path / "casebase.sqlite") as sqlite:
            yield sqlite


@pytest.fixture
def toy_config(tmp_path: Path) -> Path:
    """The toy domain's full composition written to a YAML file."""
    path = tmp_path / "toy.yaml"
    path.write_text(toy_domain.TOY_CONFIG, encoding="utf-8")
    return path


def installed_plugins() -> list[str]:
    """The names of the plugins the installed distributions declare, as they load: sorted."""
    from importlib import metadata

    return sorted({ep.name for ep in metadata.entry_points(group="cbr")})
