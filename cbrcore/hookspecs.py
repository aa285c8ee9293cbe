"""The hook specifications of cbrcore.

Two sorts of hook live here.

*Plugin hooks* (``cbr_register``, ``cbr_cli``, ``cbr_world_object``, ``cbr_world_fingerprint``,
``cbr_check_casebase``, ``cbr_casebase_formats``) are implemented by plugin modules found through
the ``cbr`` entry point group and are called on the manager of the loaded plugins:
``cbr_register`` once when plugins load, ``cbr_cli`` when the command line starts,
``cbr_world_object`` when an engine is given a world object instead of a configured world,
``cbr_world_fingerprint`` when an engine whose components use world-bound cases is built,
``cbr_check_casebase`` when ``cbr casebase check`` checks a case base, ``cbr_casebase_formats``
when a case base is exported, imported or started from initial cases.

*Phase hooks* (``cbr_retrieve`` ... ``cbr_forget``, ``cbr_solve``) are implemented by component
instances. An :class:`~cbrcore.engine.Engine` has its own plugin manager holding exactly the
components its configuration names, one per single-answer phase, plus its observers, so a
``firstresult`` phase hook reaches the configured component and nothing else. Observers wrap phase
hooks with ``wrapper=True`` hookimpls. A configured component may implement the *component hook*
``cbr_warm`` besides its phase hook, to be warmed up before anything is timed.

Rules for implementers: hooks are called with keyword arguments only; declare just the arguments
you use; a phase hook is called once per query (never per cell or per case pair), so vectorise the
inner loops. Arguments and results are the attrs objects of :mod:`cbrcore.model`; ``problem``
is whatever the configured workload produces, which the engine passes through untouched.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import pluggy

if TYPE_CHECKING:
    import typer

    from cbrcore.casebase.formats import DocumentFormat
    from cbrcore.casebase.store import CaseStore
    from cbrcore.context import Context
    from cbrcore.fingerprint import WorldFingerprint
    from cbrcore.model import Outcome, Retrieval, Revision, Solution
    from cbrcore.registry import Registry

PROJECT = "cbr"

hookspec = pluggy.HookspecMarker(PROJECT)
hookimpl = pluggy.HookimplMarker(PROJECT)


@hookspec
def cbr_register(registry: Registry) -> None:
    """Register the plugin's named components.

    Called once per plugin when plugins load, in entry point name order (collect-all, return
    value ignored). Call ``registry.add(kind, name, factory, options=OptionsClass)`` for every
    component the plugin supplies, of one of cbrcore's kinds (:data:`cbrcore.registry.KINDS`) or
    of a kind a plugin declares with ``registry.add_kind(kind, doc)``. The factory is called as
    ``factory(options, ctx)`` with a validated instance of the attrs options class and the run's
    :class:`~cbrcore.context.Context`. The factory and the options class may be named as
    ``"package.module:Attribute"`` instead, so that the module is imported only when the
    component is first used (every ``cbr`` command calls this hook). A name or kind already
    taken by another plugin, an exception raised here, or a kind that no plugin has declared
    once all have registered marks this plugin as failed; the others still load.
    """


@hookspec
def cbr_cli(app: typer.Typer) -> None:
    """Add commands to the ``cbr`` command line.

    Called once per plugin when the CLI starts (collect-all, return value ignored). Add commands
    with ``@app.command()`` or sub-applications with ``app.add_typer(...)``. Raise
    :class:`~cbrcore.errors.CbrError` from a command for a user error: the CLI prints it and exits
    with code 2.

    Each plugin is given an application of its own, whose commands then join ``cbr``: a plugin
    whose ``cbr_cli`` raises (``SystemExit`` included, ``KeyboardInterrupt`` excepted) or adds a
    command typer cannot build adds none, and a command named like one of cbrcore's, a built-in
    plugin's or an earlier plugin's is left out. Either is one warning naming the plugin while
    every other command works (an error with ``CBR_STRICT_PLUGINS=1``).
    """


@hookspec(firstresult=True)
def cbr_world_object(obj: Any, ctx: Context) -> Any | None:
    """Give the world for an object handed to an engine as ``Engine(config, world=obj)``.

    firstresult: a plugin that knows the type of ``obj`` returns the world it stands for,
    converted if need be (the grid plugin turns a NumPy occupancy or risk array into a
    :class:`cbr_grid.Grid` and returns a ``Grid`` as it is); the others return None. The world
    replaces the configuration's ``world`` slot. When no plugin answers, the engine raises a
    :class:`~cbrcore.errors.CbrError` naming the object's type. Raise a ``CbrError`` for an
    object of a known type that is not a valid world (an array with values out of range).
    """


@hookspec(firstresult=True)
def cbr_world_fingerprint(world: Any) -> WorldFingerprint | None:
    """Give the fingerprint of a world: what a case base records of the world its cases belong
    to, so that a run in another world does not use them.

    firstresult: the plugin that knows the type of ``world`` (the world a configuration's
    ``world`` slot built, or the one given as ``Engine(world=...)``) returns
    :func:`cbrcore.fingerprint.fingerprint` of its content, with a short description for people
    (``office 100x100, seed 7``); the others return None. Hash what the cases depend on (a grid's
    cells and frame, a 2D world's walls and landmarks), not how the world was made, so that the
    same map read from two files is one world. Called once, when an engine whose retriever,
    reuser, retainers or forgetters are not all world-independent is built (see
    ``Registry.add``). When no plugin answers, a configured world is known by its component, its
    options and the run's seed; a world object no plugin answers for is not recorded.
    """


@hookspec
def cbr_check_casebase(casebase: CaseStore) -> list[str]:
    """Check the invariants the plugin's cases keep in ``casebase``; return the broken ones.

    Collect-all: every loaded plugin's check runs when ``cbr casebase check`` checks a case base,
    after the store's own check, and the command exits 1 when any returns a problem. A family
    states here what its learn steps keep true of its cases (segments that meet only at their
    ends, paths of 8-neighbour steps, risks within [0, 1]) and that the index it builds from the
    store agrees with the store. The check reads only ``casebase``, which it must not change,
    and needs no world: what it knows of the map the case base records. Return one message per
    broken invariant, naming the case (or meta key) and what was expected; an empty list (or
    None) when the plugin's cases are sound or the case base holds none of them.
    """


@hookspec
def cbr_casebase_formats() -> list[DocumentFormat]:
    """Offer document formats a case base is exported to and imported from.

    Collect-all: called, in plugin order, whenever a case base document is written or read
    (``cbr casebase export`` and ``import``, a store's ``initial`` cases), after cbrcore's own
    ``yaml`` and ``json``. Return one :class:`~cbrcore.casebase.formats.DocumentFormat` per
    format: its name (``--format NAME``), the file extensions it is known by, a one-line summary,
    and the functions that write a whole case base as text and read text back into a case base
    document. A format whose cases say where they lie in the world (cells in metres) states in
    ``world`` what world it needs; it is then given the world of the configuration or of
    ``--world``, and never called without one. ``parse`` raises
    :class:`~cbrcore.errors.CaseBaseError` naming the file and every problem with its place in
    it (the feature's id or index), so that nothing is stored from a bad file. A name that
    another plugin (or cbrcore) already offers, or a hook that raises, is a
    :class:`~cbrcore.errors.PluginError` where the formats are looked up.
    """


@hookspec(firstresult=True)
def cbr_retrieve(problem: Any, casebase: CaseStore, ctx: Context) -> Retrieval | None:
    """Retrieve: find the stored cases that may solve ``problem``.

    firstresult: the configured retriever answers. Return a :class:`~cbrcore.model.Retrieval`
    whose ``matches`` are ordered best first and carry per-feature similarity detail; an empty
    retrieval (or None) means the case base cannot answer and the query goes to ``cbr_solve``.
    Must not modify the case base.
    """


@hookspec(firstresult=True)
def cbr_reuse(problem: Any, retrieval: Retrieval, ctx: Context) -> Solution | None:
    """Reuse: adapt the retrieved cases into a solution of ``problem``.

    firstresult: the configured reuser answers. Called only with a usable retrieval. Return a
    :class:`~cbrcore.model.Solution` listing in ``cases`` the ids of the cases it was built from;
    None means adaptation failed and the query goes to ``cbr_solve``.
    """


@hookspec(firstresult=True)
def cbr_revise(problem: Any, solution: Solution, ctx: Context) -> Revision | None:
    """Revise: accept, repair or reject a reused solution before it is used.

    firstresult: the configured reviser answers. Return a :class:`~cbrcore.model.Revision`;
    ``accepted=False`` sends the query to ``cbr_solve`` with its reason recorded, an accepted
    revision may carry a repaired solution. With no reviser configured every reused solution is
    accepted as it is.
    """


@hookspec(firstresult=True)
def cbr_solve(problem: Any, ctx: Context) -> Solution | None:
    """Solve with the alternative (model-based) method, without the case base.

    firstresult: the configured fallback solver answers. Called when retrieval is not usable, reuse
    fails or revision rejects. Return the :class:`~cbrcore.model.Solution`, or None when the
    problem has no solution (the proposal's source is then ``"none"``).
    """


@hookspec
def cbr_retain(problem: Any, solution: Solution, outcome: Outcome, casebase: CaseStore,
               ctx: Context) -> None:
    """Retain: store what is worth keeping from a carried-out solution.

    Collect-all: every configured retainer runs, in the order the configuration lists them and
    in the same case base transaction as the forget step that follows, so a crash keeps all or
    none of one learn step. ``solution`` is what was executed (the outcome's solution when it
    has one, else the proposal's). Every learn step calls it: when the proposal had no solution
    (nothing matched and the solver had no answer, or the answer was to do nothing), the robot
    went on as it was and ``solution`` is :func:`~cbrcore.model.no_action`, whose ``no_action``
    is true (``value`` None), with ``outcome`` telling how going on fared. A retainer that keeps
    what was carried out checks ``solution.no_action`` first; one may learn from it that a
    situation needed nothing (a positive case). Return value ignored.
    """


@hookspec
def cbr_forget(casebase: CaseStore, ctx: Context) -> None:
    """Forget: maintain the case base after a retain (capacity limits, forgetting strategies).

    Collect-all: every configured forgetter runs, in the order the configuration lists them,
    inside the learn step's transaction, after all retainers. Return value ignored.
    """


@hookspec
def cbr_warm(ctx: Context) -> None:
    """Warm up: compile or load what this component's hot path will use, on a tiny problem.

    Collect-all: implemented by configured components (a solver, a retriever, a reuser, a
    retainer ...) besides their phase hook, and called once on every component that has it, when
    the engine is built and before anything is timed, so that no query's timings include the
    compilation or the cache loading of compiled kernels. ``ctx`` is the run's context, with its
    world and case base; warm on a problem of your own (a few cells of the same types as the
    world's) and leave the case base, the run's generator and the stash as they were. Return
    value ignored.

    On an empty kernel cache (a first run) the engine also calls it in a helper process forked
    to compile beside it (:mod:`cbrcore.warm_split`): a warm-up must change nothing outside
    its own process but the kernel cache (no file written, no output), must not use the run's
    case base (the helper would share its connection) and must not rely on being called once.
    """


PHASE_HOOKS: dict[str, str] = {
    "retrieve": "cbr_retrieve",
    "reuse": "cbr_reuse",
    "revise": "cbr_revise",
    "solve": "cbr_solve",
    "retain": "cbr_retain",
    "forget": "cbr_forget",
}
"""Each phase of the cycle and the hook that carries it out."""

PLUGIN_HOOKS = ("cbr_register", "cbr_cli", "cbr_world_object", "cbr_world_fingerprint",
                "cbr_check_casebase", "cbr_casebase_formats")
"""Hooks implemented by plugin modules rather than by configured components."""

COMPONENT_HOOKS = ("cbr_warm",)
"""Hooks a configured component may implement besides the phase hook of its kind."""

HOOKS = (*PLUGIN_HOOKS, *PHASE_HOOKS.values(), *COMPONENT_HOOKS)
"""The name of every cbrcore hook, in the order of the hook reference."""
