"""The example plugin of every hook (``docs/examples/hooks/<hook>.py``, shown in the hook
reference): each is loaded as a plugin, run through the engine or the command line, and the test
checks that its hook is called and that what it returns is used.
"""

from __future__ import annotations

import importlib.util
from collections.abc import Callable
from pathlib import Path
from types import ModuleType
from typing import Any

import pytest
import yaml

import cbr_stores
import cbrcore.builtins
from cbrcore import Case, Engine, Outcome, hookspecs
from cbrcore.casebase import Document
from cbrcore.casebase.formats import read_casebase, write_casebase
from cbrcore.config import parse_config
from cbrcore.errors import CaseBaseError, CbrError, ConfigError
from cbrcore.model import no_action
from cbrcore.plugins import Plugins
from cbrcore.reference import HOOK_EXAMPLES
from cbrcore.testing import CliResult
from repo_paths import ROOT

EXAMPLES = ROOT / "docs" / "examples" / "hooks"
HOOKS_MD = EXAMPLES.parent.parent / "reference" / "hooks.md"


def example(hook: str) -> ModuleType:
    """The example of ``hook``, imported from its file under a name of its own."""
    spec = importlib.util.spec_from_file_location(f"hook_example_{hook}", EXAMPLES / f"{hook}.py")
    assert spec and spec.loader
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.fixture
def load(cbr_plugins: Callable[..., Plugins]) -> Callable[..., Plugins]:
    """The built-in stores and the examples of ``hooks``, each a plugin named after its hook."""
    def plugins(*hooks: str) -> Plugins:
        loaded = cbr_plugins(("core", cbrcore.builtins), ("stores", cbr_stores),
                             *[(hook, example(hook)) for hook in hooks])
        assert loaded.failed == []
        return loaded
    return plugins


def engine(plugins: Plugins, config: str, *routes: list[list[float]], world: Any = None
           ) -> Engine:
    """An engine for ``config`` whose case base holds ``routes`` (start and goal their ends)."""
    built = Engine(parse_config(yaml.safe_load(config), plugins.registry), plugins=plugins,
                   world=world)
    for route in routes:
        built.casebase.add(Case({"start": route[0], "goal": route[-1]}, route, kind="route"))
    return built


def query(start: list[float], goal: list[float]) -> dict[str, list[float]]:
    return {"start": start, "goal": goal}


def test_every_hook_has_an_example_shown_in_the_reference() -> None:
    assert HOOK_EXAMPLES == EXAMPLES
    assert sorted(p.stem for p in EXAMPLES.glob("*.py")) == sorted(hookspecs.HOOKS)
    page = HOOKS_MD.read_text(encoding="utf-8")
    for hook in hookspecs.HOOKS:
        section = page.split(f"## `{hook}`")[1].split("\n## ")[0]
        assert (EXAMPLES / f"{hook}.py").read_text(encoding="utf-8").strip() in section, hook


# --- plugin hooks -----------------------------------------------------------------------------


def test_cbr_register(load: Callable[..., Plugins]) -> None:
    plugins = load("cbr_register")
    assert plugins.registry.get("world", "room").plugin == "cbr_register"
    with engine(plugins, "world: {use: room, width: 8}") as built:
        assert (built.ctx.world.width, built.ctx.world.depth) == (8.0, 6.0)
    with pytest.raises(ConfigError, match=r"world\.width"):
        engine(plugins, "world: {use: room, width: -1}")


def test_cbr_cli(load: Callable[..., Plugins], invoke_cbr: Callable[..., CliResult]) -> None:
    load("cbr_cli")
    done = invoke_cbr("room-distance", "0,0", "3,4")
    assert (done.exit_code, done.stdout) == (0, "5\n")


def test_cbr_world_object(load: Callable[..., Plugins]) -> None:
    plugins = load("cbr_world_object")
    with engine(plugins, "{}", world=(8, 5)) as built:
        assert (built.ctx.world.width, built.ctx.world.depth) == (8.0, 5.0)
    with pytest.raises(CbrError, match=r"a positive width and depth, not \(0, 5\)"):
        engine(plugins, "{}", world=(0, 5))
    with pytest.raises(CbrError, match="str"):  # nobody's world: the engine names its type
        engine(plugins, "{}", world="a room")


def test_cbr_world_fingerprint(load: Callable[..., Plugins], tmp_path: Path) -> None:
    plugins = load("cbr_world_fingerprint", "cbr_retrieve", "cbr_solve", "cbr_retain")
    config = (f"world: {{use: room, width: WIDTH}}\n"
              f"casebase: {{use: sqlite, path: {tmp_path / 'routes.sqlite'}}}\n"
              "retrieve: near_ends\nsolver: straight_line\nretain: [keep_routes]\n")
    with engine(plugins, config.replace("WIDTH", "8")) as built:
        problem = query([0, 0], [3, 4])
        built.learn(problem, built.solve(problem), Outcome(success=True))
    with pytest.raises(CbrError, match=r"room 8x6 m"):
        engine(plugins, config.replace("WIDTH", "9"))
    with engine(plugins, config.replace("WIDTH", "8")) as again:  # the same room: accepted
        assert again.casebase.count() == 1


def test_cbr_check_casebase(load: Callable[..., Plugins], invoke_cbr: Callable[..., CliResult],
                            tmp_path: Path) -> None:
    plugins = load("cbr_check_casebase")
    path = tmp_path / "routes.sqlite"
    with engine(plugins, f"casebase: {{use: sqlite, path: {path}}}", [[0, 0], [3, 4]]) as built:
        assert invoke_cbr("casebase", "check", str(path)).exit_code == 0
        built.casebase.add(Case(query([0, 0], [1, 1]), [[0, 0], [2, 2]], kind="route"))
    done = invoke_cbr("casebase", "check", str(path))
    assert done.exit_code == 1
    assert "case 2: the route does not join its start and goal" in done.stdout + done.stderr


def test_cbr_casebase_formats(load: Callable[..., Plugins], tmp_path: Path) -> None:
    load("cbr_casebase_formats")
    route = [[0.0, 0.0], [1.5, 2.0], [3.0, 4.0]]
    cases = (Case(query(route[0], route[-1]), route, kind="route"),)
    target = tmp_path / "kept.routes"
    write_casebase(Document(cases=cases), target)  # the format found by its extension
    assert target.read_text(encoding="utf-8") == "0 0,3 4,0 0,1.5 2,3 4\n"
    assert read_casebase(target).cases == cases
    target.write_text("0 0,3 4\nnot a point\n", encoding="utf-8")
    with pytest.raises(CaseBaseError, match=r"line 2: expected at least two points"):
        read_casebase(target, "routes-csv")


# --- phase hooks ------------------------------------------------------------------------------

PHASES = ("cbr_retrieve", "cbr_reuse", "cbr_revise", "cbr_solve")
CYCLE = "retrieve: {use: near_ends, radius: 2}\nreuse: splice\nsolver: straight_line\n"


def test_cbr_retrieve(load: Callable[..., Plugins]) -> None:
    with engine(load(*PHASES), CYCLE, [[0, 0], [0, 4], [4, 4]]) as built:
        near = built.solve(query([0.5, 0], [4, 3.5]))
        assert near.source == "casebase"
        [match] = near.retrieval.matches
        assert match.features == {"start": 0.5, "goal": 0.5} and match.similarity == 0.75
        far = built.solve(query([9, 9], [4, 4]))
        assert (far.source, far.fallback_reason) == ("solver:straight_line",
                                                     "no usable retrieval")


def test_cbr_reuse(load: Callable[..., Plugins]) -> None:
    with engine(load(*PHASES), CYCLE, [[0, 0], [0, 4], [4, 4]]) as built:
        problem = query([0.5, 0], [4, 3.5])
        proposal = built.solve(problem)
        assert proposal.solution.value == [[0.5, 0], [0, 4], [4, 3.5]]
        assert proposal.solution.cost == pytest.approx(4.0311 + 4.0311, abs=1e-3)
        built.learn(problem, proposal, Outcome(success=True))
        assert built.casebase.cases()[0].uses == 1  # the case it names was used


def test_cbr_revise(load: Callable[..., Plugins]) -> None:
    config = CYCLE + "revise: {use: detour_limit, max_ratio: 1.5}\n"
    with engine(load(*PHASES), config, [[0, 0], [0, 4], [4, 4]], [[0, 0], [4, 4]]) as built:
        detour = built.solve(query([0, 0], [4, 4]))  # the route through (0, 4), 1.41 x
        assert detour.source == "casebase"
    with engine(load(*PHASES), config.replace("1.5", "1.2"), [[0, 0], [0, 4], [4, 4]]) as built:
        rejected = built.solve(query([0, 0], [4, 4]))
        assert rejected.source == "solver:straight_line"
        assert rejected.fallback_reason == "revision rejected: route 1.41 x the straight line"


def test_cbr_solve(load: Callable[..., Plugins]) -> None:
    with engine(load("cbr_solve"), "solver: straight_line") as built:
        proposal = built.solve(query([0, 0], [3, 4]))
        assert proposal.source == "solver:straight_line"
        assert (proposal.solution.value, proposal.solution.cost) == ([[0, 0], [3, 4]], 5.0)


def test_cbr_retain(load: Callable[..., Plugins]) -> None:
    with engine(load("cbr_solve", "cbr_retain"),
                "solver: straight_line\nretain: [keep_routes]") as built:
        kept = query([0, 0], [3, 4])
        built.learn(kept, built.solve(kept), Outcome(success=True))
        failed = query([1, 1], [2, 2])
        built.learn(failed, built.solve(failed), Outcome(success=False))
        built.learn(failed, built.solve(failed), Outcome(success=True, solution=no_action()))
        assert [(c.problem, c.solution) for c in built.casebase.cases()] == [
            (kept, [[0, 0], [3, 4]])]


def test_cbr_forget(load: Callable[..., Plugins]) -> None:
    config = CYCLE + "retain: [keep_routes]\nforget: [{use: capacity, max_cases: 2}]\n"
    with engine(load(*PHASES, "cbr_retain", "cbr_forget"), config) as built:
        for goal in ([3, 4], [3, 4.5], [9, 9]):
            problem = query([0, 0], goal)
            built.learn(problem, built.solve(problem), Outcome(success=True))
        # the second trip reused the first's case, which stays; of the two never used, the older
        # one goes
        kept = [(c.problem["goal"], c.uses) for c in built.casebase.cases()]
        assert kept == [([3, 4], 1), ([9, 9], 0)]


def test_cbr_warm(load: Callable[..., Plugins]) -> None:
    with engine(load("cbr_warm"), "solver: table_lookup") as built:
        solver = built.components["solver"]
        assert solver.table is not None and len(solver.table) == 2500  # built before any query
        assert built.solve(query([0, 0], [3, 4])).solution.cost == 5.0
