"""The hook contracts, one test per hook, as a plugin author relies on them.

Each ``test_hook_<name>`` demonstrates one hook of :mod:`cbrcore.hookspecs`: when it is called,
with which arguments, whether one implementation answers (firstresult) or all run (collect-all),
and what the engine does with the return value. Meta-tests keep the specifications, the generated
reference and this module in step, and two domains unlike grids (a landmark situation and a RUPART
behavior index) go through the same cycle and both case base stores.
"""

from __future__ import annotations

import re
import sys
from importlib import metadata
from pathlib import Path
from typing import Any

import attrs
import pytest
import typer
import yaml

import cbr_observers
import cbr_stores
import cbrcore.builtins
import toy_domain
from cbr_stores.sqlite import SQLiteStore
from cbrcore import Case, Engine, Match, Outcome, Retrieval, Revision, Solution, hookimpl, hookspecs
from cbrcore.casebase import Document, MemoryStore
from cbrcore.casebase.formats import DocumentFormat
from cbrcore.casebase.store import CaseStore
from cbrcore.casebase.worlds import WORLDS_KEY, OtherWorld
from cbrcore.cli import main
from cbrcore.config import parse_config
from cbrcore.context import Context
from cbrcore.errors import CaseBaseError, CbrError
from cbrcore.fingerprint import WorldFingerprint, fingerprint
from cbrcore.model import Proposal, no_action
from cbrcore.options import option
from cbrcore.plugins import Plugins, load_plugins, new_plugin_manager, use_plugins
from cbrcore.reference import config_reference, hook_reference
from cbrcore.registry import Registry
from cbrcore.stash import StashKey
from repo_paths import ROOT

HOOKS_MD = ROOT / "docs" / "reference" / "hooks.md"
CONFIGURATION_MD = ROOT / "docs" / "reference" / "configuration.md"
SPECS = {name: function for name, function in vars(hookspecs).items()
         if name.startswith("cbr_") and callable(function)}


LOG = StashKey[list[Any]]()
"""What the test-only components saw, in order."""


class _Component:
    """Base of the test-only components: built as ``factory(options, ctx)``."""

    def __init__(self, options: Any, ctx: Context) -> None:
        self.options = options
        self.ctx = ctx

    def _log(self, entry: Any) -> None:
        self.ctx.stash.setdefault(LOG, []).append(entry)


def load(*extra: tuple[str, Any]) -> Plugins:
    """The toy domain, the built-in plugins, this module's components and ``extra``."""
    return load_plugins(extra=[("toy", toy_domain), ("core", cbrcore.builtins),
                               ("stores", cbr_stores),
                               ("observers", cbr_observers), ("hooks", HookComponents()),
                               *extra], entry_points=False, environ={})


def engine_for(plugins: Plugins, config: str | dict[str, Any], *stored: int) -> Engine:
    """An engine for ``config`` whose case base holds the toy cases (x, x²) for ``stored``."""
    data = yaml.safe_load(config) if isinstance(config, str) else config
    engine = Engine(parse_config(data, plugins.registry), plugins=plugins)
    for x in stored:
        engine.casebase.add(Case(x, x * x, kind=toy_domain.KIND))
    return engine


# --- plugin hooks -----------------------------------------------------------------------------


@attrs.frozen
class ScaleOptions:
    factor: int = option(2, "What the problem is multiplied by.")


class Scale(_Component):
    """Solve by multiplying the problem by the configured factor."""

    @hookimpl
    def cbr_solve(self, problem: int) -> Solution:
        return Solution(problem * self.options.factor)


class Registers:
    """A plugin registering one solver under ``name``."""

    def __init__(self, name: str) -> None:
        self.name = name

    @hookimpl
    def cbr_register(self, registry: Registry) -> str:
        registry.add("solver", self.name, Scale, options=ScaleOptions)
        return "a return value nobody reads"


def test_hook_cbr_register() -> None:
    """``cbr_register`` is collect-all: every plugin's call runs once at load time, each adding
    its components, which are recorded with the plugin that registered them and built later as
    ``factory(options, ctx)`` with a validated options instance. The return value is ignored."""
    plugins = load_plugins(extra=[("first", Registers("double")), ("second", Registers("twice"))],
                           entry_points=False, environ={})
    assert [p.name for p in plugins.loaded] == ["first", "second"]
    assert plugins.failed == []
    component = plugins.registry.get("solver", "double")
    assert (component.plugin, component.options) == ("first", ScaleOptions)
    assert component.summary == "Solve by multiplying the problem by the configured factor."
    assert plugins.registry.get("solver", "twice").plugin == "second"
    assert plugins.info("first").components == ("solver:double",)
    assert plugins.info("first").hooks == ("cbr_register", "cbr_solve")
    built = plugins.registry.create("solver", "twice", {"factor": 3}, None)
    assert isinstance(built, Scale) and built.options == ScaleOptions(3)


class Greets:
    """A plugin adding the command ``hello``."""

    @hookimpl
    def cbr_cli(self, app: typer.Typer) -> None:
        @app.command()
        def hello(name: str = typer.Argument("robot")) -> None:
            """Say hello."""
            typer.echo(f"hello {name}")


class Refuses:
    """A plugin adding the command ``refuse``, which fails with a user error."""

    @hookimpl
    def cbr_cli(self, app: typer.Typer) -> None:
        @app.command()
        def refuse() -> None:
            """Always refuse."""
            raise CbrError("the map is not loaded")


def test_hook_cbr_cli(capsys: pytest.CaptureFixture[str]) -> None:
    """``cbr_cli`` is collect-all: every plugin adds its commands to the ``cbr`` application.
    A command raising :class:`CbrError` makes ``cbr`` print the message and exit with code 2."""
    plugins = load_plugins(extra=[("greets", Greets()), ("refuses", Refuses())],
                           entry_points=False, environ={})
    with use_plugins(plugins):
        assert main(["hello", "Ada"]) == 0
        assert capsys.readouterr().out == "hello Ada\n"
        assert main(["refuse"]) == 2
        assert "error: the map is not loaded" in capsys.readouterr().err
    app = typer.Typer()
    assert plugins.pm.hook.cbr_cli(app=app) == []
    assert sorted(command.callback.__name__ for command in app.registered_commands) == [
        "hello", "refuse"]


class Warms(_Component):
    """A solver that logs when it warms up and when it solves."""

    @hookimpl
    def cbr_warm(self, ctx: Context) -> None:
        self._log(("warm", ctx.step, ctx.world))

    @hookimpl
    def cbr_solve(self, problem: int) -> Solution:
        self._log(("solve", problem))
        return Solution(problem * problem)


def test_hook_cbr_warm() -> None:
    """``cbr_warm`` is collect-all on the configured components that implement it besides their
    phase hook: called once on each, with the run's context (its world built), when the engine is
    built and before the first query; its time is ``engine.warm_seconds``, in no query's
    timings."""
    with engine_for(load(), "solver: warms\n") as engine:
        assert engine.ctx.stash[LOG] == [("warm", 0, None)]
        assert engine.warm_seconds >= 0
        proposal = engine.solve(4)
        engine.solve(5)
        assert set(proposal.timings) == {"solve"}
        assert engine.ctx.stash[LOG] == [("warm", 0, None), ("solve", 4), ("solve", 5)]


class Rooms:
    """A plugin that makes worlds of strings: the name of a room."""

    @hookimpl
    def cbr_world_object(self, obj: object, ctx: Context) -> object | None:
        if isinstance(obj, str):
            return {"room": obj, "seed": ctx.seed}
        return None


class Numbers:
    """A plugin that makes worlds of integers, asked after ``Rooms``."""

    @hookimpl
    def cbr_world_object(self, obj: object) -> object | None:
        return ("number", obj) if isinstance(obj, int) else None


def test_hook_cbr_world_object() -> None:
    """``cbr_world_object`` is firstresult on the loaded plugins, called with the object and the
    run's context when an engine is given ``world=obj``: the first plugin that returns something
    makes the world, a plugin returns None for types it does not know, and the world replaces the
    configured one (``engine.world`` and ``ctx.world``). No answer is an error naming the type."""
    plugins = load(("rooms", Rooms()), ("numbers", Numbers()))
    with Engine.from_dict({"seed": 3}, world="kitchen", plugins=plugins) as engine:
        assert engine.world == {"room": "kitchen", "seed": 3}
        assert engine.ctx.world is engine.world
    with Engine.from_dict({}, world=7, plugins=plugins) as engine:
        assert engine.world == ("number", 7)
    with pytest.raises(CbrError, match="float"):
        Engine.from_dict({}, world=2.5, plugins=plugins)


@attrs.frozen
class Floor:
    """A world: one floor of a building."""

    level: int


@attrs.frozen
class TowerOptions:
    levels: int = option(3, "How many floors.")


def tower(options: TowerOptions, ctx: Context) -> dict[str, int]:
    """A world no plugin gives a fingerprint of."""
    return {"levels": options.levels}


class Floors:
    """A plugin whose worlds are floors, with a fingerprint each, and towers, without."""

    @hookimpl
    def cbr_register(self, registry: Registry) -> None:
        registry.add("world", "tower", tower, options=TowerOptions)

    @hookimpl
    def cbr_world_object(self, obj: object) -> Floor | None:
        return obj if isinstance(obj, Floor) else None

    @hookimpl
    def cbr_world_fingerprint(self, world: object) -> WorldFingerprint | None:
        if not isinstance(world, Floor):
            return None
        return fingerprint("floor", {"level": world.level}, f"floor {world.level}")


def test_hook_cbr_world_fingerprint(tmp_path: Path) -> None:
    """``cbr_world_fingerprint`` is firstresult on the loaded plugins, called with the run's world
    when an engine whose case components are not all world-independent is built: the plugin that
    knows the world answers, and its fingerprint is ``engine.world_fingerprint``. The first learn
    step records it in the case base, and an engine of another world is refused before it reads
    a case. A world no plugin answers for is not recorded; a configured one is known by its
    component, options and seed."""
    plugins = load(("floors", Floors()), ("rooms", Rooms()))
    config = {"casebase": {"use": "sqlite", "path": str(tmp_path / "cb.sqlite")},
              "solver": "compute", "retain": ["keep"]}
    with Engine.from_dict(config, world=Floor(1), plugins=plugins) as engine:
        assert engine.world_fingerprint == fingerprint("floor", {"level": 1}, "")
        assert engine.casebase.get_meta(WORLDS_KEY) is None
        engine.learn(3, engine.solve(3), Outcome(success=True))
        assert engine.casebase.get_meta(WORLDS_KEY) == [
            {"sha256": engine.world_fingerprint.sha256, "description": "floor 1"}]
    with pytest.raises(OtherWorld, match=r"floor 1 \(world \w{12}\); this run's world is floor 2"):
        Engine.from_dict(config, world=Floor(2), plugins=plugins)
    with Engine.from_dict(config, world="kitchen", plugins=plugins) as engine:
        assert engine.world_fingerprint is None
    towers = {**config, "casebase": "memory", "seed": 5, "world": {"use": "tower", "levels": 4}}
    with Engine.from_dict(towers, plugins=plugins) as engine:
        seed_5 = engine.world_fingerprint
        assert seed_5 is not None and seed_5.description == "world tower {levels: 4}, seed 5"
    with Engine.from_dict({**towers, "seed": 6}, plugins=plugins) as engine:
        assert engine.world_fingerprint not in (None, seed_5)
    with Engine.from_dict({"solver": "compute"}, world=Floor(2), plugins=plugins) as engine:
        assert engine.world_fingerprint is None  # no case component: nothing to protect


class Squares:
    """A family whose cases keep an invariant: the solution is the square of the problem."""

    @hookimpl
    def cbr_check_casebase(self, casebase: CaseStore) -> list[str]:
        return [f"case {case.id}: {case.solution} is not {case.problem}²"
                for case in casebase.cases(toy_domain.KIND) if case.solution != case.problem ** 2]


class Silent:
    """A plugin with nothing to check in this case base: None counts as no problem."""

    @hookimpl
    def cbr_check_casebase(self) -> None:
        return None


def test_hook_cbr_check_casebase(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """``cbr_check_casebase`` is collect-all on the loaded plugins, called by ``cbr casebase
    check`` with the case base once the store's own check passed: each plugin returns the broken
    invariants of its cases, and any problem makes the command list them, named with the plugin,
    and exit 1. The check must not change the case base."""
    path = tmp_path / "cb.sqlite"
    with SQLiteStore(path) as store:
        store.add(Case(3, 9, kind=toy_domain.KIND))
    plugins = load(("squares", Squares()), ("silent", Silent()))
    with use_plugins(plugins):
        assert main(["casebase", "check", str(path)]) == 0
        assert capsys.readouterr().out == "ok\n"
        with SQLiteStore(path) as store:
            store.add(Case(4, 15, kind=toy_domain.KIND))
            revision = store.revision
        assert main(["casebase", "check", str(path)]) == 1
        assert f"{path}: 1 problem:\n  - squares: case 2: 15 is not 4²\n" in capsys.readouterr().out
    with SQLiteStore(path) as store:
        assert store.revision == revision
    assert plugins.pm.hook.cbr_check_casebase(casebase=MemoryStore()) == [[]]


@attrs.frozen
class NumberOptions:
    value: int = option(0, "The number.")


def number(options: NumberOptions, ctx: Context) -> int:
    """A world that is a number."""
    return options.value


class Tallies:
    """A format that writes a case base as one line per case, ``problem solution``, on a world
    that is a number added to each solution."""

    @hookimpl
    def cbr_register(self, registry: Registry) -> None:
        registry.add("world", "number", number, options=NumberOptions)

    @staticmethod
    def dump(document: Document, world: Any) -> str:
        return "".join(f"{c.problem} {c.solution + world}\n" for c in document.cases)

    @staticmethod
    def parse(text: str, source: str, world: Any) -> Document:
        rows = [line.split() for line in text.splitlines()]
        if not all(len(row) == 2 and all(v.isdigit() for v in row) for row in rows):
            raise CaseBaseError(f"{source}: expected lines of two numbers")
        return Document(1, {}, tuple(Case(int(p), int(s) - world, kind=toy_domain.KIND, id=i + 1)
                                     for i, (p, s) in enumerate(rows)))

    @hookimpl
    def cbr_casebase_formats(self) -> list[DocumentFormat]:
        return [DocumentFormat("tally", (".tally",), "toy cases, one a line", self.dump,
                               self.parse, world="a number")]


class Yaml:
    """A plugin that offers a format under a name cbrcore's own has."""

    @hookimpl
    def cbr_casebase_formats(self) -> list[DocumentFormat]:
        return [DocumentFormat("yaml", (".yml",), "another yaml", Tallies.dump, Tallies.parse)]


def test_hook_cbr_casebase_formats(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """``cbr_casebase_formats`` is collect-all on the loaded plugins, asked whenever a case base
    is exported or imported: ``cbr casebase formats`` lists each format with its plugin,
    ``--format`` (or the file's extension) picks it, and a format that needs a world gets the
    one ``--world`` names, built as a run builds it. A name cbrcore or another plugin has is a
    plugin error."""
    path = tmp_path / "cb.sqlite"
    with SQLiteStore(path) as store:
        store.add(Case(3, 9, kind=toy_domain.KIND))
        store.add(Case(4, 16, kind=toy_domain.KIND))
    plugins = load(("tallies", Tallies()))
    with use_plugins(plugins):
        assert main(["casebase", "formats"]) == 0
        assert "tally       .tally       tallies         toy cases, one a line; needs a number" \
            in capsys.readouterr().out
        tally = tmp_path / "cb.tally"
        world = "{use: number, value: 10}"
        assert main(["casebase", "export", str(path), "-o", str(tally), "--world", world]) == 0
        assert tally.read_text() == "3 19\n4 26\n"
        copy = tmp_path / "copy.sqlite"
        assert main(["casebase", "import", str(copy), str(tally), "--format", "tally",
                     "--world", world]) == 0
        assert main(["casebase", "import", str(tmp_path / "no.sqlite"), str(tally)]) == 2
        assert "the tally format needs the world the cases belong to (a number)" in \
            capsys.readouterr().err
    with SQLiteStore(copy) as store:
        assert [(c.problem, c.solution) for c in store.cases()] == [(3, 9), (4, 16)]
    assert plugins.pm.hook.cbr_casebase_formats()[0][0].name == "tally"
    with use_plugins(load(("yaml", Yaml()))):
        assert main(["casebase", "export", str(path), "--format", "json"]) == 2
        assert "plugin 'yaml' offers the case base format 'yaml', which 'cbrcore' offers" in \
            capsys.readouterr().err


# --- phase hooks ------------------------------------------------------------------------------


class Remembers(_Component):
    """A retriever that answers the stored case of the query itself, with a payload for reuse."""

    @hookimpl
    def cbr_retrieve(self, problem: int, casebase: CaseStore, ctx: Context) -> Retrieval | None:
        self._log(("retrieve", problem, ctx.step))
        found = [c for c in casebase.cases(toy_domain.KIND) if c.problem == problem]
        if not found:
            return None
        return Retrieval((Match(found[0], 1.0, {"same": 1.0}),), payload={"looked_at": problem})


class Echoes(_Component):
    """A reuser that copies the retrieved case's solution and reports the payload it received."""

    @hookimpl
    def cbr_reuse(self, retrieval: Retrieval) -> Solution:
        self._log(("reuse", retrieval.payload))
        case = retrieval.matches[0].case
        assert case.id is not None
        return Solution(case.solution, cases=(case.id,))


class Judges(_Component):
    """A reviser: rejects negative problems, repairs odd ones (to -1), accepts the rest."""

    @hookimpl
    def cbr_revise(self, problem: int, solution: Solution) -> Revision:
        if problem < 0:
            return Revision(False, "negative")
        if problem % 2:
            return Revision(True, "repaired", attrs.evolve(solution, value=-1))
        return Revision(True)


class Declines(_Component):
    """A solver that has no answer for problems above 100."""

    @hookimpl
    def cbr_solve(self, problem: int, ctx: Context) -> Solution | None:
        self._log(("solve", problem, ctx.step))
        return None if problem > 100 else Solution(problem * problem)


@attrs.frozen
class TagOptions:
    tag: str = option("a", "The tag written into the retained case's meta.")


class Tags(_Component):
    """A retainer storing what it is given, tagged, and logging the solution it received."""

    @hookimpl
    def cbr_retain(self, problem: int, solution: Solution, outcome: Outcome,
                   casebase: CaseStore) -> None:
        self._log(("retain", self.options.tag, solution.value, outcome.success))
        if not solution.no_action:
            casebase.add(Case(problem, solution.value, kind="tagged",
                              meta={"tag": self.options.tag}))


class Trims(_Component):
    """A forgetter keeping at most one tagged case per tag, logging what it saw."""

    @hookimpl
    def cbr_forget(self, casebase: CaseStore) -> None:
        self._log(("forget", self.options.tag, casebase.count("tagged")))
        tagged = [c for c in casebase.cases("tagged") if c.meta["tag"] == self.options.tag]
        casebase.remove([c.id for c in tagged[:-1]])


class HookComponents:
    """Registers the components of the phase hook demonstrations as plugin ``hooks``."""

    @hookimpl
    def cbr_register(self, registry: Registry) -> None:
        registry.add("retriever", "remembers", Remembers)
        registry.add("reuser", "echoes", Echoes)
        registry.add("reviser", "judges", Judges)
        registry.add("solver", "declines", Declines)
        registry.add("retainer", "tags", Tags, options=TagOptions)
        registry.add("forgetter", "trims", Trims, options=TagOptions)
        registry.add("solver", "warms", Warms)


def test_hook_cbr_retrieve() -> None:
    """``cbr_retrieve`` is firstresult: the engine's own plugin manager holds only the configured
    retriever, which is called once per query with keyword arguments (declaring only those it
    uses) and answers a Retrieval. None, or a retrieval without matches, is not usable and sends
    the query to the solver."""
    with engine_for(load(), "retrieve: remembers\nreuse: echoes\nsolver: declines\n", 4) as engine:
        proposal = engine.solve(4)
        assert proposal.source == "casebase"
        assert proposal.retrieval is not None
        assert [m.case.problem for m in proposal.retrieval.matches] == [4]
        assert engine.solve(5).fallback_reason == "no usable retrieval"
        assert engine.ctx.stash[LOG] == [("retrieve", 4, 0), ("reuse", {"looked_at": 4}),
                                            ("retrieve", 5, 1), ("solve", 5, 1)]
    ctx = Context(registry=Registry(), seed=0)
    pm = new_plugin_manager()
    pm.register(toy_domain.Nearest(toy_domain.NearestOptions(), ctx))
    pm.register(Remembers(None, ctx))  # called first; its None passes the turn on
    answer = pm.hook.cbr_retrieve(problem=5, casebase=engine.casebase, ctx=ctx)
    assert answer == Retrieval((Match(engine.casebase.cases()[0], 0.5, {"dx": 1.0}),))


def test_hook_cbr_reuse() -> None:
    """``cbr_reuse`` is firstresult and called only with a usable retrieval, whose payload it
    receives. Its Solution names in ``cases`` the cases it was built from: learning the outcome
    counts their use."""
    with engine_for(load(), "retrieve: remembers\nreuse: echoes\n", 4, 6) as engine:
        six = next(c.id for c in engine.casebase.cases() if c.problem == 6)
        proposal = engine.solve(6)
        engine.learn(6, proposal, Outcome(success=True))
        assert proposal.solution == Solution(36, cases=(six,))
        assert engine.casebase.get(six).uses == 1
        engine.solve(7)  # nothing stored for 7: reuse is not called
        assert [e for e in engine.ctx.stash[LOG] if e[0] == "reuse"] == [
            ("reuse", {"looked_at": 6})]


def test_hook_cbr_revise() -> None:
    """``cbr_revise`` is firstresult: its Revision accepts the reused solution as it is, accepts
    a repaired one that replaces it, or rejects it (the solver answers, the reason recorded)."""
    config = "retrieve: remembers\nreuse: echoes\nrevise: judges\nsolver: declines\n"
    with engine_for(load(), config, 2, 3) as engine:
        engine.casebase.add(Case(-2, 4, kind=toy_domain.KIND))
        ids = {case.problem: case.id for case in engine.casebase.cases()}
        accepted, repaired, rejected = engine.solve(2), engine.solve(3), engine.solve(-2)
    assert accepted.source == repaired.source == "casebase"
    assert accepted.solution == Solution(4, cases=(ids[2],))
    assert repaired.solution == Solution(-1, cases=(ids[3],))
    assert repaired.revision == Revision(True, "repaired", repaired.solution)
    assert (rejected.source, rejected.fallback_reason) == ("solver:declines",
                                                           "revision rejected: negative")
    assert rejected.solution == Solution(4)


def test_hook_cbr_solve() -> None:
    """``cbr_solve`` is firstresult: the configured solver answers whenever the case base does not
    (source ``solver:<name>``); its None means no solution (source ``none``)."""
    with engine_for(load(), "solver: declines\n") as engine:
        solved, unsolved = engine.solve(9), engine.solve(101)
    assert (solved.source, solved.solution) == ("solver:declines", Solution(81))
    assert (unsolved.source, unsolved.solution) == ("none", None)
    assert engine.stats.unsolved == 1


def test_hook_cbr_retain() -> None:
    """``cbr_retain`` is collect-all: every configured retainer runs, given the executed solution
    (the outcome's when it has one, else the proposal's) and the outcome, and all their writes
    commit as one case base transaction (one revision)."""
    config = "solver: declines\nretain: [{use: tags, tag: a}, {use: tags, tag: b}]\n"
    with engine_for(load(), config) as engine:
        proposal = engine.solve(3)
        engine.learn(3, proposal, Outcome(success=True))
        assert engine.casebase.revision == 1
        proposal = engine.solve(4)
        engine.learn(4, proposal, Outcome(success=False, solution=Solution(15)))
        assert engine.casebase.revision == 2
        log = engine.ctx.stash[LOG]
        stored = [(c.problem, c.solution, c.meta["tag"]) for c in engine.casebase.cases()]
    assert sorted(e for e in log if e[0] == "retain") == [
        ("retain", "a", 9, True), ("retain", "a", 15, False),
        ("retain", "b", 9, True), ("retain", "b", 15, False)]
    assert sorted(stored) == [(3, 9, "a"), (3, 9, "b"), (4, 15, "a"), (4, 15, "b")]


def test_hook_cbr_retain_no_action() -> None:
    """A proposal without a solution is learned too: every retainer gets a solution that asks
    for nothing (``no_action``, value None) with the outcome of going on without an action, as
    it gets a reused solution that asks for nothing."""
    config = "solver: declines\nretain: [{use: tags, tag: a}, {use: tags, tag: b}]\n"
    with engine_for(load(), config) as engine:
        unsolved = engine.solve(101)
        assert unsolved.solution is None
        engine.learn(101, unsolved, Outcome(success=True, cost=2.0))
        engine.learn(102, Proposal(Solution(None), "casebase"), Outcome(success=False))
        retained = [e for e in engine.ctx.stash[LOG] if e[0] == "retain"]
        # the retainers kept nothing: they saw no_action
        assert engine.casebase.count("tagged") == 0
    assert retained == [("retain", "a", None, True), ("retain", "b", None, True),
                        ("retain", "a", None, False), ("retain", "b", None, False)]
    assert no_action().no_action and no_action() == Solution(None)
    assert not Solution(0).no_action  # a falsy answer is still an action


def test_hook_cbr_forget() -> None:
    """``cbr_forget`` is collect-all: every configured forgetter runs after all retainers, inside
    the same transaction, and it runs even when nothing was retained."""
    config = ("solver: declines\nretain: [{use: tags, tag: a}, {use: tags, tag: b}]\n"
              "forget: [{use: trims, tag: a}, {use: trims, tag: b}]\n")
    with engine_for(load(), config) as engine:
        for x in (1, 2):
            engine.learn(x, engine.solve(x), Outcome(success=True))
        # no solution: the retainers get no action and keep nothing; the forgetters still run
        engine.learn(101, engine.solve(101), Outcome(success=False))
        log = [entry for entry in engine.ctx.stash[LOG] if entry[0] != "solve"]
        stored = sorted((c.problem, c.meta["tag"]) for c in engine.casebase.cases())
    assert [entry[0] for entry in log] == (["retain"] * 2 + ["forget"] * 2) * 3
    assert sorted(entry[1] for entry in log if entry[0] == "forget") == ["a"] * 3 + ["b"] * 3
    assert stored == [(2, "a"), (2, "b")]


# --- meta-tests -------------------------------------------------------------------------------


def _kind(name: str) -> str:
    options = getattr(SPECS[name], f"{hookspecs.PROJECT}_spec")
    return "firstresult" if options.get("firstresult") else "collect-all"


def test_hookspecs_are_all_known() -> None:
    """The spec module's functions are exactly the plugin and phase hooks the engine knows, and
    each is a hook of cbrcore's plugin managers."""
    assert set(SPECS) == set(hookspecs.HOOKS)
    hooks = new_plugin_manager().hook
    assert all(hasattr(hooks, name) for name in SPECS)


@pytest.mark.parametrize("name", sorted(SPECS))
def test_each_hook_docstring_states_its_kind(name: str) -> None:
    """The docstring says firstresult or collect-all, as the pluggy spec options do."""
    doc = (SPECS[name].__doc__ or "").lower()
    kind = _kind(name)
    other = "collect-all" if kind == "firstresult" else "firstresult"
    assert kind in doc and other not in doc


@pytest.mark.parametrize("name", sorted(SPECS))
def test_each_hook_is_in_the_generated_reference(name: str) -> None:
    """``hook_reference()`` has a section for the hook giving its signature, its kind and the
    summary line of its docstring, written as markdown."""
    sections = _sections(hook_reference())
    assert name in sections
    assert f"def {name}(" in sections[name]
    assert f"*{_kind(name)}*" in sections[name]
    summary = (SPECS[name].__doc__ or "").strip().splitlines()[0]
    assert summary.replace("``", "`") in sections[name]  # reST literals become markdown code


@pytest.mark.parametrize("name", sorted(SPECS))
def test_each_hook_has_a_section_in_the_docs(name: str) -> None:
    if not HOOKS_MD.exists():
        pytest.skip("docs/reference/hooks.md is not generated yet (cbr reference hooks)")
    assert name in _sections(HOOKS_MD.read_text(encoding="utf-8"))


@pytest.mark.parametrize("name", sorted(SPECS))
def test_each_hook_has_a_demonstration_here(name: str) -> None:
    """Every hook has its ``test_hook_<name>`` in this module, with a docstring."""
    demo = vars(sys.modules[__name__]).get(f"test_hook_{name}")
    assert callable(demo) and demo.__doc__


def _sections(markdown: str) -> dict[str, str]:
    """The text under each ``## `name``` heading, by name."""
    parts = re.split(r"^## `(\w+)`$", markdown, flags=re.M)
    return dict(zip(parts[1::2], parts[2::2], strict=True))


BUILTIN = sorted(ep.name for ep in metadata.distribution("cbrcore").entry_points
                 if ep.group == "cbr")


def _builtin_plugins() -> Plugins:
    """The plugins the cbrcore distribution itself declares."""
    return load_plugins(environ={"CBR_PLUGINS": ",".join(BUILTIN), "CBR_STRICT_PLUGINS": "1"})


def test_the_configuration_reference_is_current() -> None:
    """docs/reference/configuration.md is ``config_reference`` over the built-in components."""
    if not CONFIGURATION_MD.exists():
        pytest.skip("docs/reference/configuration.md is not generated yet (cbr reference config)")
    plugins = _builtin_plugins()
    assert sorted(p.name for p in plugins.loaded) == BUILTIN
    assert {"core", "observers", "grid", "solvers"} <= set(BUILTIN)
    assert CONFIGURATION_MD.read_text(encoding="utf-8") == config_reference(plugins.registry)


def test_the_hook_reference_is_current() -> None:
    """docs/reference/hooks.md is ``hook_reference()``."""
    if not HOOKS_MD.exists():
        pytest.skip("docs/reference/hooks.md is not generated yet (cbr reference hooks)")
    assert HOOKS_MD.read_text(encoding="utf-8") == hook_reference()


# --- domains other than grids ------------------------------------------------------------------
#
# A landmark situation is a labelled graph of fuzzy numbers: landmarks with triangular fuzzy
# (a, b, c) angle and distance, and edges between landmarks. A RUPART behavior index is a record
# of sensor readings, the goal and a confidence. Both are plain JSON data, as cases must be.

SCENE = {
    "landmarks": {
        "door": {"angle": [10.0, 15.0, 20.0], "distance": [2.0, 2.5, 3.0]},
        "desk": {"angle": [80.0, 90.0, 100.0], "distance": [1.0, 1.2, 1.5]},
    },
    "edges": [["desk", "door"]],
}
SCENE_NEAR = {  # the door seen 2° further left and 0.2 m further away
    "landmarks": {
        "door": {"angle": [12.0, 17.0, 22.0], "distance": [2.2, 2.7, 3.2]},
        "desk": {"angle": [80.0, 90.0, 100.0], "distance": [1.0, 1.2, 1.5]},
    },
    "edges": [["desk", "door"]],
}
SCENE_FAR = {
    "landmarks": {"pillar": {"angle": [-40.0, -30.0, -20.0], "distance": [5.0, 6.0, 7.0]}},
    "edges": [],
}
SCENE_FEATURES = {"desk.angle": 1.0, "desk.distance": 1.0,
                  "door.angle": 1 - 2 / 180, "door.distance": 1 - 0.2 / 10, "edges": 1.0}

INDEX = {"sensors": {"front": 0.9, "left": 0.2, "right": 0.7},
         "goal": {"bearing": -30.0, "distance": 4.0}, "confidence": 0.8}
INDEX_NEAR = {"sensors": {"front": 0.8, "left": 0.2, "right": 0.7},
              "goal": {"bearing": -21.0, "distance": 4.0}, "confidence": 0.8}
INDEX_FAR = {"sensors": {"front": 0.0, "left": 0.9, "right": 0.0},
             "goal": {"bearing": 120.0, "distance": 0.5}, "confidence": 0.1}
INDEX_FEATURES = {"sensors.front": 0.9, "sensors.left": 1.0, "sensors.right": 1.0,
                  "goal.bearing": 0.95, "goal.distance": 1.0, "confidence": 1.0}

SCALES = {"angle": 180.0, "distance": 10.0, "bearing": 180.0}
"""The differences at which a feature's similarity reaches 0 (1 for features without a scale)."""


def _closeness(a: list[float] | float, b: list[float] | float, scale: float) -> float:
    """1 minus the mean absolute difference of two numbers or fuzzy triples, over ``scale``."""
    pairs = list(zip(a, b, strict=True)) if isinstance(a, list) else [(a, b)]
    return max(0.0, 1 - sum(abs(x - y) for x, y in pairs) / len(pairs) / scale)


def scene_features(query: dict[str, Any], case: dict[str, Any]) -> dict[str, float] | None:
    """Per-feature similarities of two scenes with the same landmarks; None if they differ."""
    if set(query["landmarks"]) != set(case["landmarks"]):
        return None
    features = {f"{label}.{part}": _closeness(mark[part], case["landmarks"][label][part],
                                              SCALES[part])
                for label, mark in sorted(query["landmarks"].items())
                for part in ("angle", "distance")}
    edges = {tuple(sorted(e)) for e in query["edges"]}, {tuple(sorted(e)) for e in case["edges"]}
    union = edges[0] | edges[1]
    features["edges"] = len(edges[0] & edges[1]) / len(union) if union else 1.0
    return features


def index_features(query: dict[str, Any], case: dict[str, Any]) -> dict[str, float]:
    """Per-feature similarities of two behavior indexes."""
    features = {f"sensors.{name}": _closeness(value, case["sensors"][name], 1.0)
                for name, value in sorted(query["sensors"].items())}
    for name, value in query["goal"].items():
        features[f"goal.{name}"] = _closeness(value, case["goal"][name], SCALES[name])
    features["confidence"] = _closeness(query["confidence"], case["confidence"], 1.0)
    return features


DOMAINS: dict[str, Any] = {"landmarks": scene_features, "behavior": index_features}


@attrs.frozen
class DomainOptions:
    domain: str = option(doc="landmarks or behavior.",
                         validator=attrs.validators.in_(tuple(DOMAINS)))
    threshold: float = option(0.9, "Smallest similarity retrieved.")


class Similar(_Component):
    """Retrieve the cases of the domain whose mean feature similarity reaches the threshold."""

    @hookimpl
    def cbr_retrieve(self, problem: dict[str, Any], casebase: CaseStore) -> Retrieval:
        matches = []
        for case in casebase.cases(self.options.domain):
            features = DOMAINS[self.options.domain](problem, case.problem)
            if features is None:
                continue
            similarity = sum(features.values()) / len(features)
            if similarity >= self.options.threshold:
                matches.append(Match(case, similarity, features))
        return Retrieval(tuple(sorted(matches, key=lambda m: -m.similarity)))


class Copies(_Component):
    """Reuse the best case's solution unchanged."""

    @hookimpl
    def cbr_reuse(self, retrieval: Retrieval) -> Solution:
        case = retrieval.matches[0].case
        assert case.id is not None
        return Solution(case.solution, cases=(case.id,))


class Reasons(_Component):
    """The model-based method of each domain.

    Landmarks: divert to the nearest landmark (smallest core distance), at its core angle.
    Behavior: with an obstacle ahead, turn to the freer side; otherwise seek the goal.
    """

    @hookimpl
    def cbr_solve(self, problem: dict[str, Any]) -> Solution:
        if self.options.domain == "landmarks":
            label, mark = min(problem["landmarks"].items(), key=lambda i: i[1]["distance"][1])
            return Solution({"target": label, "heading": mark["angle"][1]})
        sensors = problem["sensors"]
        if sensors["front"] > 0.5:
            turn = "turn_left" if sensors["left"] < sensors["right"] else "turn_right"
            return Solution({"behavior": turn, "weights": {"avoid": 0.7, "seek": 0.3}})
        return Solution({"behavior": "seek_goal", "weights": {"avoid": 0.2, "seek": 0.8}})


class Keeps(_Component):
    """Retain every successful (problem, solution) pair as a case of the domain."""

    @hookimpl
    def cbr_retain(self, problem: dict[str, Any], solution: Solution, outcome: Outcome,
                   casebase: CaseStore) -> None:
        if outcome.success:
            casebase.add(Case(problem, solution.value, kind=self.options.domain))


class DomainComponents:
    """Registers the two domains' minimal components as plugin ``domains``."""

    @hookimpl
    def cbr_register(self, registry: Registry) -> None:
        registry.add("retriever", "similar", Similar, options=DomainOptions)
        registry.add("reuser", "copies", Copies)
        registry.add("solver", "reasons", Reasons, options=DomainOptions)
        registry.add("retainer", "keeps", Keeps, options=DomainOptions)


@pytest.fixture(params=["memory", "sqlite"])
def store(request: pytest.FixtureRequest, tmp_path: Path) -> dict[str, Any]:
    """The case base slot for each store."""
    if request.param == "memory":
        return {"use": "memory"}
    return {"use": "sqlite", "path": str(tmp_path / "cases.sqlite")}


def domain_engine(domain: str, store: dict[str, Any]) -> Engine:
    config = {"casebase": store,
              "retrieve": {"use": "similar", "domain": domain},
              "reuse": "copies",
              "solver": {"use": "reasons", "domain": domain},
              "retain": [{"use": "keeps", "domain": domain}]}
    plugins = load(("domains", DomainComponents()))
    return Engine(parse_config(config, plugins.registry), plugins=plugins)


@pytest.mark.parametrize(("domain", "first", "near", "far", "features", "solution"), [
    ("landmarks", SCENE, SCENE_NEAR, SCENE_FAR, SCENE_FEATURES,
     {"target": "desk", "heading": 90.0}),
    ("behavior", INDEX, INDEX_NEAR, INDEX_FAR, INDEX_FEATURES,
     {"behavior": "turn_left", "weights": {"avoid": 0.7, "seek": 0.3}}),
])
def test_other_domains_pass_through_the_same_cycle(
        store: dict[str, Any], domain: str, first: dict[str, Any], near: dict[str, Any],
        far: dict[str, Any], features: dict[str, float], solution: dict[str, Any]) -> None:
    """A problem is solved by the domain's solver and learned as a JSON case; a similar problem
    is then answered from the case base with per-feature detail; a different one is not. Cases
    survive reopening a SQLite case base."""
    with domain_engine(domain, store) as engine:
        solved = engine.solve(first)
        assert solved.source == "solver:reasons"
        assert solved.solution is not None and solved.solution.value == solution
        engine.learn(first, solved, Outcome(success=True))
        (case,) = engine.casebase.cases(domain)
        assert (case.problem, case.solution) == (first, solution)
        assert engine.solve(far).fallback_reason == "no usable retrieval"
        reused = engine.solve(near)
        assert reused.source == "casebase"
        assert reused.solution == Solution(solution, cases=(case.id,))
        assert reused.retrieval is not None
        (match,) = reused.retrieval.matches
        assert dict(match.features) == pytest.approx(features)
        assert match.similarity == pytest.approx(sum(features.values()) / len(features))
    if store["use"] == "sqlite":
        with domain_engine(domain, store) as engine:
            assert engine.casebase.cases(domain) == [case]
            assert engine.solve(near).source == "casebase"
