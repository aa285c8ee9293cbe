"""Embedding the engine without files: world objects, configurations and overrides as Python
data, the examples and the README block that shows one, and plugins named as modules in tests."""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import cbr_grid
import cbr_stores
import cbrcore.builtins
import toy_domain
from cbr_grid.grid import Grid
from cbr_grid.query import GridQuery
from cbrcore import Engine, Outcome, hookimpl
from cbrcore.errors import CbrError, ConfigError
from cbrcore.plugins import Plugins, load_plugins
from repo_paths import ROOT

EXAMPLES = sorted((ROOT / "examples").glob("*.py"))


def grid_plugins(*extra: tuple[str, object]) -> Plugins:
    """The grid world, its solvers and the case graph, with the core, loaded in code."""
    import cbr_casegraph
    import cbr_kinematics
    import cbr_solvers

    return load_plugins(extra=[("core", cbrcore.builtins),
                               ("stores", cbr_stores), ("grid", cbr_grid),
                               ("kinematics", cbr_kinematics), ("solvers", cbr_solvers),
                               ("casegraph", cbr_casegraph), *extra],
                        entry_points=False, environ={})


# --- the examples -------------------------------------------------------------------------------


@pytest.mark.parametrize("example", EXAMPLES, ids=lambda path: path.name)
def test_each_example_runs_as_written_from_the_repository_root(example: Path) -> None:
    env = {key: value for key, value in os.environ.items()
           if not key.startswith("CBR_") or key == "CBR_CACHE_DIR"}
    done = subprocess.run([sys.executable, str(example.relative_to(ROOT))], cwd=ROOT, env=env,
                          capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr
    stats = eval(done.stdout.strip().splitlines()[-1], {})  # the engine's stats, printed
    assert stats["queries"] == stats["learned"] > 0
    assert stats["from_casebase"] + stats["from_solver"] == stats["queries"]


def test_there_are_the_two_examples() -> None:
    assert [path.name for path in EXAMPLES] == ["embed.py", "embed_array.py"]


def test_the_readme_embedding_block_is_the_example_file() -> None:
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    section = readme.split("## Embedding\n", 1)[1].split("\n## ", 1)[0]
    (block,) = re.findall(r"```python\n(.*?)```", section, flags=re.S)
    assert block == (ROOT / "examples" / "embed.py").read_text(encoding="utf-8")


def test_the_embedding_page_shows_both_examples_as_they_are() -> None:
    page = (ROOT / "docs" / "embedding.md").read_text(encoding="utf-8")
    blocks = re.findall(r"```python\n(.*?)```", page, flags=re.S)
    for example in EXAMPLES:
        assert example.read_text(encoding="utf-8") in blocks


# --- world objects ------------------------------------------------------------------------------


def test_a_boolean_occupancy_array_becomes_the_grid_world() -> None:
    occupancy = np.zeros((5, 7), dtype=bool)
    occupancy[1:4, 3] = True
    with Engine.from_dict({"solver": "astar"}, world=occupancy, plugins=grid_plugins()) as engine:
        assert isinstance(engine.world, Grid)
        assert engine.ctx.world is engine.world
        assert np.array_equal(engine.world.risk, occupancy.astype(float))
        proposal = engine.solve(GridQuery((0, 2), (6, 2)))
    # around the wall at x = 3 (rows 1..3) through row 0 or row 4: two diagonals out, two
    # straight steps past the wall (a diagonal onto row 0 beside it would cut its corner), two
    # diagonals back: 2 + 4·sqrt(2)
    assert proposal.source == "solver:astar"
    assert engine.world.path_problems(proposal.solution.value) == []
    assert proposal.solution.cost == pytest.approx(2 + 4 * 2 ** 0.5)


def test_a_grid_object_is_the_world_as_it_is() -> None:
    grid = Grid(np.full((4, 4), 0.25))
    with Engine.from_dict({}, world=grid, plugins=grid_plugins()) as engine:
        assert engine.world is grid


def test_a_world_object_replaces_the_configured_world() -> None:
    occupancy = np.ones((3, 3), dtype=bool)
    occupancy[1, 1] = False
    config = {"world": {"use": "generated", "kind": "random", "width": 9, "height": 9}}
    with Engine.from_dict(config, world=occupancy, plugins=grid_plugins()) as engine:
        assert (engine.world.width, engine.world.height) == (3, 3)
        assert int(engine.world.passable.sum()) == 1


def test_an_object_no_plugin_takes_names_its_type_and_the_worlds() -> None:
    with pytest.raises(CbrError) as caught:
        Engine.from_dict({}, world={"cells": []}, plugins=grid_plugins())
    assert str(caught.value) == (
        "world: no loaded plugin makes a world of a dict given as Engine(world=...); plugins "
        "that take world objects: grid; the worlds a configuration can name instead: "
        "generated (grid), map_file (grid), movingai (grid)")


class Rooms:
    """A plugin of another world, which takes no object it is shown here."""

    @hookimpl
    def cbr_world_object(self, obj: object) -> object | None:
        return None


def test_without_the_grid_plugin_the_refusal_names_only_the_loaded_ones() -> None:
    """The engine does not know grids: it names the plugins that implement the hook."""
    plugins = load_plugins(extra=[("core", cbrcore.builtins),
                                  ("stores", cbr_stores), ("rooms", Rooms())],
                           entry_points=False, environ={})
    with pytest.raises(CbrError) as caught:
        Engine.from_dict({}, world=np.zeros((2, 2)), plugins=plugins)
    assert str(caught.value) == (
        "world: no loaded plugin makes a world of a numpy.ndarray of shape (2, 2) given as "
        "Engine(world=...); plugins that take world objects: rooms; the worlds a configuration "
        "can name instead: none registered")


def test_a_bad_array_is_refused_by_the_grid_plugin() -> None:
    with pytest.raises(CbrError, match="within \\[0, 1\\]"):
        Engine.from_dict({}, world=np.full((3, 3), 2.0), plugins=grid_plugins())


def test_an_array_of_0_and_1_is_not_taken_for_occupancy_percentages() -> None:
    # a wall of 1s across the middle row: as percentages (1 %) it would be free, and the
    # solver would plan straight through it
    walls = np.zeros((3, 3), dtype=np.int64)
    walls[1] = 1
    with pytest.raises(CbrError, match=r"an array of int64 is ambiguous: expected booleans"):
        Engine.from_dict({"solver": "astar"}, world=walls, plugins=grid_plugins())
    with Engine.from_dict({"solver": "astar"}, world=walls == 1,
                          plugins=grid_plugins()) as engine:
        assert engine.solve(GridQuery((0, 0), (0, 2))).solution is None


class Spoils:
    """A plugin whose world conversion has a bug."""

    @hookimpl
    def cbr_world_object(self, obj: object) -> object:
        raise RuntimeError("not today")


def test_a_plugin_failing_to_convert_is_named() -> None:
    plugins = grid_plugins(("spoils", Spoils()))
    with pytest.raises(CbrError, match=r"world: plugin 'spoils' failed to make a world of a "
                                       r"list: RuntimeError: not today"):
        Engine.from_dict({}, world=[], plugins=plugins)


# --- configurations and overrides as data ------------------------------------------------------


def toy_plugins() -> Plugins:
    return load_plugins(extra=[("toy", toy_domain), ("core", cbrcore.builtins),
                               ("stores", cbr_stores)],
                        entry_points=False, environ={})


def test_from_dict_checks_like_a_file_and_leaves_the_mapping_alone() -> None:
    config = {"seed": 4, "retrieve": {"use": "nearest", "radius": 1}, "reuse": "tangent",
              "solver": "compute",
              "retain": ["keep"]}
    before = repr(config)
    with Engine.from_dict(config, plugins=toy_plugins(),
                          overrides={"retrieve.radius": 0, "workload": "squares"}) as engine:
        assert engine.config.retrieve.options.radius == 0
        assert engine.config.workload.name == "squares"
        proposal = engine.solve(3)
        engine.learn(3, proposal, Outcome(success=True))
        assert engine.solve(3).source == "casebase"
    assert repr(config) == before


def test_mapping_overrides_replace_what_the_path_held() -> None:
    config = {"retrieve": "nearest", "solver": "compute", "casebase": {"use": "memory"}}
    with Engine.from_dict(config, plugins=toy_plugins(),
                          overrides={"retrieve.radius": 5, "casebase": "memory",
                                     "retain": ["keep"]}) as engine:
        assert engine.config.retrieve.name == "nearest"
        assert engine.config.retrieve.options.radius == 5
        assert [ref.name for ref in engine.config.retain] == ["keep"]


def test_string_overrides_still_work_with_from_dict() -> None:
    with Engine.from_dict({"retrieve": "nearest"}, plugins=toy_plugins(),
                          overrides=["retrieve.radius=4"]) as engine:
        assert engine.config.retrieve.options.radius == 4


def test_from_yaml_takes_mapping_overrides(tmp_path: Path) -> None:
    path = tmp_path / "run.yaml"
    path.write_text("retrieve: {use: nearest, radius: 1}\ncasebase: sqlite\n", encoding="utf-8")
    with Engine.from_yaml(path, plugins=toy_plugins(),
                          overrides={"casebase": {"use": "memory"}}) as engine:
        assert engine.config.casebase.name == "memory"
        assert engine.config.source == path.resolve()


@pytest.mark.parametrize(("overrides", "expected"), [
    ({"retrieve.radius": "3"}, "overrides['retrieve.radius']: expected an integer, got '3'"),
    ({"retrieve..radius": 3}, "overrides['retrieve..radius']: expected a key of the form "
                              "KEY.PATH (dots between names), such as 'retrieve.k'"),
    ({7: 3}, "overrides[7]: expected a key of the form KEY.PATH (dots between names), such as "
             "'retrieve.k'"),
    ({"seed.x": 3}, "overrides['seed.x']: seed.x cannot be set: seed holds int, not a mapping "
                    "or a list"),
    ({"retain.4.x": 1}, "overrides['retain.4.x']: retain.4: the list has no item 4 (it has 1)"),
])
def test_a_bad_mapping_override_names_its_key(overrides: dict[object, object],
                                              expected: str) -> None:
    config = {"seed": 1, "retrieve": "nearest", "retain": ["keep"]}
    with pytest.raises(ConfigError) as caught:
        Engine.from_dict(config, plugins=toy_plugins(), overrides=overrides)
    assert caught.value.problems == [expected]


def test_a_bad_mapping_override_of_a_file_names_its_key_not_the_file_line() -> None:
    """The file's own ``delta: 8`` is valid: the problem is the override's value (checked with
    the installed plugins, which the file's components come from)."""
    with pytest.raises(ConfigError) as caught:
        Engine.from_yaml(ROOT / "configs" / "hybrid_grid.yaml", overrides={"retrieve.delta": -1})
    assert caught.value.problems == ["overrides['retrieve.delta']: must be >= 1: -1"]
    with pytest.raises(ConfigError) as caught:
        Engine.from_yaml(ROOT / "configs" / "hybrid_grid.yaml", overrides=["retrieve.delta=-1"])
    assert caught.value.problems == ["--set retrieve.delta=-1: must be >= 1: -1"]


def test_an_engine_given_a_mapping_points_to_from_dict() -> None:
    with pytest.raises(CbrError, match=r"expected a checked Config, got dict; .*from_dict"):
        Engine({"solver": "compute"})  # type: ignore[arg-type]


def test_from_dict_refuses_what_is_not_a_mapping() -> None:
    with pytest.raises(ConfigError, match="expected a mapping of settings, got list"):
        Engine.from_dict([], plugins=toy_plugins())  # type: ignore[arg-type]


# --- the testing kit ----------------------------------------------------------------------------


def test_cbr_plugins_takes_module_names(cbr_plugins, cbr_engine) -> None:  # type: ignore[no-untyped-def]
    plugins = cbr_plugins("toy_domain", ("core", "cbrcore.builtins"))
    assert {p.name for p in plugins.loaded} == {"toy_domain", "core"}
    engine = cbr_engine({"solver": "compute"}, overrides={"seed": 2})
    assert engine.solve(5).solution.value == 25


def test_cbr_plugins_names_a_module_it_cannot_import(cbr_plugins) -> None:  # type: ignore[no-untyped-def]
    with pytest.raises(CbrError, match=r"cbr_plugins\('no_such_plugin'\): cannot import the "
                                       r"plugin module 'no_such_plugin': ModuleNotFoundError"):
        cbr_plugins("no_such_plugin")


def test_cbr_engine_hands_on_a_world_object(cbr_plugins, cbr_engine) -> None:  # type: ignore[no-untyped-def]
    cbr_plugins("cbrcore.builtins", "cbr_grid", "cbr_kinematics", "cbr_solvers")
    engine = cbr_engine("solver: dijkstra\n", world=np.zeros((3, 3), dtype=bool))
    assert engine.solve(GridQuery((0, 0), (2, 2))).solution.cost == pytest.approx(2 * 2 ** 0.5)
