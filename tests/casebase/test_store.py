"""The store contract run on the memory and the SQLite store, and the built-in store components."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import pytest

import cbr_stores
import cbrcore.builtins
from cbr_stores.sqlite import SQLiteStore
from cbrcore.casebase import CaseStore, MemoryStore
from cbrcore.context import Context
from cbrcore.errors import CaseBaseError, ConfigError
from cbrcore.registry import Registry
from cbrcore.testing import StoreContract


class TestMemoryStore(StoreContract):
    @pytest.fixture
    def open_store(self) -> Callable[[str], CaseStore]:
        return lambda name: MemoryStore()


class TestSQLiteStore(StoreContract):
    persistent = shared = True

    @pytest.fixture
    def open_store(self, tmp_path: Path) -> Callable[[str], CaseStore]:
        return lambda name: SQLiteStore(tmp_path / f"{name}.sqlite")


def _context(out_dir: Path | None) -> Context:
    registry = Registry()
    cbrcore.builtins.cbr_register(registry)
    cbr_stores.cbr_register(registry)
    return Context(registry=registry, seed=0, out_dir=out_dir)


def test_builtin_store_components(tmp_path: Path) -> None:
    ctx = _context(tmp_path)
    assert isinstance(ctx.registry.create("store", "memory", {}, ctx), MemoryStore)
    with ctx.registry.create("store", "sqlite", None, ctx) as default:
        assert default.path == tmp_path / "casebase.sqlite"
    with ctx.registry.create("store", "sqlite", {"path": str(tmp_path / "x.sqlite"),
                                                 "busy_timeout": 1}, ctx) as chosen:
        assert (chosen.path, chosen.busy_timeout) == (tmp_path / "x.sqlite", 1.0)
    summaries = {c.name: c.summary for c in ctx.registry}
    assert summaries["sqlite"].startswith("A case base in a SQLite file")
    assert summaries["memory"].startswith("An in-memory case base")


def test_builtin_sqlite_store_needs_a_path_without_an_output_folder() -> None:
    ctx = _context(None)
    with pytest.raises(ConfigError, match=r"casebase\.path: required when the run has no"):
        ctx.registry.create("store", "sqlite", {}, ctx)
    with pytest.raises(ConfigError, match="busy_timeout: must be >= 0"):
        ctx.registry.create("store", "sqlite", {"busy_timeout": -1}, ctx)


def test_builtin_sqlite_store_creates_a_missing_file_unless_told_not_to(tmp_path: Path) -> None:
    ctx = _context(tmp_path)
    with pytest.raises(CaseBaseError, match="no case base at"):
        ctx.registry.create("store", "sqlite", {"create": False}, ctx)
    assert not (tmp_path / "casebase.sqlite").exists()
    ctx.registry.create("store", "sqlite", {}, ctx).close()
    with ctx.registry.create("store", "sqlite", {"create": False}, ctx) as store:
        assert store.count() == 0
