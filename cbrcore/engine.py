"""The engine: the CBR cycle with a fallback solver, for embedding or for ``cbr run``."""

from __future__ import annotations

import collections
import contextlib
import functools
import os
import time
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from types import TracebackType
from typing import Any

import attrs
import pluggy

from cbrcore.casebase.store import CaseStore
from cbrcore.casebase.worlds import admit, record_world, recorded_worlds, store_policy
from cbrcore.config import ComponentRef, Config, Overrides, config_from_data, load_config
from cbrcore.context import Context
from cbrcore.errors import (
    CaseBaseError,
    CaseBaseLocked,
    CbrError,
    ConfigError,
    PhaseError,
    PluginError,
)
from cbrcore.fingerprint import WorldFingerprint, fingerprint
from cbrcore.hookimpls import implemented_hooks, unknown_hooks
from cbrcore.hookspecs import PHASE_HOOKS
from cbrcore.kernel_cache import holds_no_kernels
from cbrcore.model import CASEBASE, Outcome, Proposal, Retrieval, Revision, Solution, no_action
from cbrcore.options import unstructure
from cbrcore.plugins import Plugins, current, new_plugin_manager
from cbrcore.registry import KIND_HOOK
from cbrcore.warm_split import warm_in_turn

_PHASE_OF_HOOK = {hook: phase for phase, hook in PHASE_HOOKS.items()}

MEASURE = "measure"
"""The phase a metric fails in: measuring a carried-out proposal, before its learn step."""

WARM = "warm"
"""The phase a component fails in while it warms up (``cbr_warm``), when the engine is built."""


def output_folder(path: Path) -> None:
    """Make ``path`` a folder the program can write into, or raise a CbrError saying why not.

    Checked before anything is written, so a bad ``--out`` is one message rather than an
    OSError from whichever file happens to be written first.
    """
    expected = "expected a folder, or a path where one can be made, that this user can write into"
    try:
        if path.exists() and not path.is_dir():
            raise CbrError(f"output folder {path}: is a file; {expected}")
        blocking = next((parent for parent in path.parents if parent.is_file()), None)
        if blocking is not None:
            raise CbrError(f"output folder {path}: {blocking} is a file; {expected}")
        path.mkdir(parents=True, exist_ok=True)
    except OSError as exc:  # a parent that cannot be searched or written
        raise CbrError(f"output folder {path}: cannot be made ({exc.strerror}); {expected}"
                       ) from exc
    if not os.access(path, os.W_OK | os.X_OK):
        raise CbrError(f"output folder {path}: not writable; {expected}")


@attrs.define
class EngineStats:
    """Counters over the queries an engine has answered."""

    queries: int = 0
    from_casebase: int = 0
    from_solver: int = 0
    unsolved: int = 0
    learned: int = 0
    learn_skipped: int = 0
    """Learn steps that waited longer than the store's ``busy_timeout`` for the case base's
    write lock and were kept to be retried (:meth:`Engine.learn`)."""
    learn_pending: int = 0
    """Skipped learn steps not yet learned: at the end of a run, those the lock kept out to
    the last."""
    fallback_reasons: collections.Counter[str] = attrs.field(factory=collections.Counter)

    @property
    def cbr_share(self) -> float:
        """The fraction of queries the case base answered (0 before any query)."""
        return self.from_casebase / self.queries if self.queries else 0.0

    def as_dict(self) -> dict[str, Any]:
        return {
            "queries": self.queries,
            "from_casebase": self.from_casebase,
            "from_solver": self.from_solver,
            "unsolved": self.unsolved,
            "learned": self.learned,
            "learn_skipped": self.learn_skipped,
            "learn_pending": self.learn_pending,
            "cbr_share": self.cbr_share,
            "fallback_reasons": dict(self.fallback_reasons),
        }


LearnDone = Callable[[dict[str, float]], None]
"""Called with a learn step's timings once the step has committed."""


@attrs.frozen
class SkippedStep:
    """A learn step that gave up waiting for the case base's write lock, kept to be retried."""

    problem: Any
    proposal: Proposal
    outcome: Outcome
    step: int
    """``ctx.step`` when the step was first tried: its retry sees the same."""
    then: LearnDone | None


def culprit(caller: Any, exc: BaseException | None, owners: Mapping[str, str]) -> str:
    """Who is to blame for ``exc`` raised in a call of the hook ``caller``: the plugin of the
    innermost frame that is one of the hook's implementations, else the implementation that
    answers; named by ``owners`` (the label of each registered name), else by its own name."""
    impls = caller.get_hookimpls()
    if exc is not None:
        codes = {impl.function.__code__: impl.plugin_name for impl in impls}
        raised = None
        tb = exc.__traceback__
        while tb is not None:
            raised = codes.get(tb.tb_frame.f_code, raised)
            tb = tb.tb_next
        if raised is not None:
            return owners.get(raised, raised)
    answering = [impl for impl in impls if not impl.wrapper and not impl.hookwrapper]
    name = answering[-1].plugin_name if answering else "<none>"
    return owners.get(name, name)


class Hooks:
    """The one typed facade over the engine's phase hooks.

    Each call times the phase, checks the type of the answer and turns an exception raised by a
    component into a :class:`~cbrcore.errors.PhaseError` naming the plugin that raised.
    """

    def __init__(self, pm: pluggy.PluginManager, owners: dict[str, str]) -> None:
        self._pm = pm
        self._owners = owners

    def _call(self, hook: str, expected: type | None, timings: dict[str, float],
              **kwargs: Any) -> Any:
        caller = getattr(self._pm.hook, hook)
        started = time.perf_counter()
        try:
            result = caller(**kwargs)
        except CbrError:
            raise
        except Exception as exc:
            raise PhaseError(_PHASE_OF_HOOK[hook], self._culprit(caller, exc), exc) from exc
        finally:
            phase = _PHASE_OF_HOOK[hook]
            timings[phase] = timings.get(phase, 0.0) + time.perf_counter() - started
        if expected is not None and result is not None and not isinstance(result, expected):
            raise PhaseError(_PHASE_OF_HOOK[hook], self._culprit(caller, None), TypeError(
                f"returned {type(result).__name__}, expected {expected.__name__} or None"))
        return result

    def _culprit(self, caller: Any, exc: BaseException | None) -> str:
        return culprit(caller, exc, self._owners)

    def retrieve(self, problem: Any, casebase: CaseStore, ctx: Context,
                 timings: dict[str, float]) -> Retrieval | None:
        return self._call("cbr_retrieve", Retrieval, timings,
                          problem=problem, casebase=casebase, ctx=ctx)

    def reuse(self, problem: Any, retrieval: Retrieval, ctx: Context,
              timings: dict[str, float]) -> Solution | None:
        return self._call("cbr_reuse", Solution, timings,
                          problem=problem, retrieval=retrieval, ctx=ctx)

    def revise(self, problem: Any, solution: Solution, ctx: Context,
               timings: dict[str, float]) -> Revision | None:
        return self._call("cbr_revise", Revision, timings,
                          problem=problem, solution=solution, ctx=ctx)

    def solve(self, problem: Any, ctx: Context, timings: dict[str, float]) -> Solution | None:
        return self._call("cbr_solve", Solution, timings, problem=problem, ctx=ctx)

    def retain(self, problem: Any, solution: Solution, outcome: Outcome, casebase: CaseStore,
               ctx: Context, timings: dict[str, float]) -> None:
        self._call("cbr_retain", None, timings, problem=problem, solution=solution,
                   outcome=outcome, casebase=casebase, ctx=ctx)

    def forget(self, casebase: CaseStore, ctx: Context, timings: dict[str, float]) -> None:
        self._call("cbr_forget", None, timings, casebase=casebase, ctx=ctx)


class Engine:
    """A configured CBR engine.

    ``solve`` runs retrieve -> reuse -> revise and hands the query to the fallback solver when the
    retrieval is not usable, reuse fails or revision rejects. ``learn`` runs retain -> forget in one
    case base transaction after the solution has been carried out. ``stats`` counts where answers
    came from. Close the engine (or use it as a context manager) to release the case base.

    Build one from a checked :class:`~cbrcore.config.Config`, a YAML file (:meth:`from_yaml`)
    or a mapping (:meth:`from_dict`). ``world`` hands the engine a world object instead of the
    configured ``world`` slot (which the configuration may then leave out): a plugin that knows
    the object's type makes the world of it (``cbr_world_object``; the grid plugin takes a
    ``cbr_grid.Grid`` or a 2-D NumPy occupancy or risk array). ``out_dir`` is the output folder
    for files components write (a SQLite case base by default); None embeds the engine without
    one. Once every component is built, those implementing ``cbr_warm`` warm up (compile their
    kernels on a tiny problem), so that no query's timings include compilation.

    A run whose retriever, reuser, retainers or forgetters are not all declared
    world-independent uses cases bound to its world: the engine takes the world's fingerprint
    (``cbr_world_fingerprint``) and, before any component reads the case base, refuses one
    whose cases belong to another world (:class:`~cbrcore.casebase.worlds.OtherWorld`), unless
    its store is configured with ``worlds: any``; the first learn step records the world in the
    case base (:mod:`cbrcore.casebase.worlds`).
    """

    def __init__(self, config: Config, *, world: Any = None, plugins: Plugins | None = None,
                 out_dir: Path | None = None) -> None:
        if not isinstance(config, Config):
            raise CbrError(f"Engine(config): expected a checked Config, got "
                           f"{_type_name(config)}; build an engine from a mapping with "
                           f"Engine.from_dict(...) or from a file with Engine.from_yaml(...)")
        self.config = config
        self.plugins = plugins or current()
        self.stats = EngineStats()
        registry = self.plugins.registry
        self.ctx = Context(registry=registry, seed=config.seed, out_dir=out_dir,
                           config_dir=config.base_dir)
        self._pm = new_plugin_manager()
        self._owners: dict[str, str] = {}
        self._slots: dict[str, str] = {}
        self.components: dict[str, Any] = {}
        """The built components by YAML path (``retrieve``, ``retain.0``, ``kinematics``): the
        plugin slots', the phase components and the observers."""
        self.casebase: CaseStore | None = None
        self.world_fingerprint: WorldFingerprint | None = None
        """The world the run's cases belong to; None when its case components are all
        world-independent (or it has no world or no case base)."""
        self._unrecorded: WorldFingerprint | None = None
        self.warm_seconds = 0.0
        """How long the components' warm-up (``cbr_warm``) took while the engine was built."""
        self._closed = False
        self._skipped: collections.deque[SkippedStep] = collections.deque()
        # read before any component is built: building one may compile (and cache) a kernel
        self._first_compile = holds_no_kernels()
        made = out_dir is not None and not out_dir.exists()
        if out_dir is not None:
            output_folder(out_dir)
        try:
            self.world = (self._build(config.world) if world is None
                          else self._world_object(world))
            self.ctx.world = self.world
            for slot, ref in config.slots.items():
                self.ctx.stash[self.plugins.registry.slots[slot].key] = self._component(ref)
            self.casebase = self._build(config.casebase)
            self.ctx.casebase = self.casebase
            # before any component loads the cases: another world's would fail it obscurely
            self.world_fingerprint = self._world_fingerprint(configured_world=world is None)
            self._admit_world()
            for slot in ("retrieve", "reuse", "revise", "solver"):
                ref = getattr(config, slot)
                if ref is not None:
                    self._register(ref, self._component(ref))
            for slot in ("retain", "forget", "observers"):
                # built in the order written; pluggy calls the last registered first, so they
                # are registered backwards for collect-all phases to run in that order too
                built = [(ref, self._component(ref)) for ref in getattr(config, slot)]
                for ref, instance in reversed(built):
                    self._register(ref, instance)
            self.workload = self._build(config.workload)
            self.metrics = [self._build(ref) for ref in config.metrics]
            self.warm_seconds = self._warm(configured_world=world is None)
        except BaseException:
            self.close()
            if made:  # an engine that could not be built leaves no empty output folder behind
                with contextlib.suppress(OSError):
                    out_dir.rmdir()
            raise
        self.hooks = Hooks(self._pm, self._owners)

    @classmethod
    def from_yaml(cls, path: Path | str, *, world: Any = None, overrides: Overrides = (),
                  plugins: Plugins | None = None, out_dir: Path | None = None) -> Engine:
        """Build an engine from a YAML file.

        ``overrides`` edit the file's settings before they are checked: ``KEY.PATH=VALUE``
        strings as ``cbr run --set`` takes them (values written in YAML), or a mapping of
        ``KEY.PATH`` to Python values (``{"retrieve.k": 3, "casebase": "memory"}``). ``world``
        is a world object that replaces the configured world (see :class:`Engine`).
        """
        plugins = plugins or current()
        config = load_config(path, plugins.registry, overrides)
        return cls(config, world=world, plugins=plugins, out_dir=out_dir)

    @classmethod
    def from_dict(cls, data: Mapping[str, Any], *, world: Any = None, overrides: Overrides = (),
                  plugins: Plugins | None = None, out_dir: Path | None = None) -> Engine:
        """Build an engine from a configuration given as a mapping, without a file.

        ``data`` has the shape of a YAML configuration (``{"solver": "astar", "retrieve":
        {"use": "casegraph", "delta": 8}}``) and is checked the same way; it is copied, never
        changed. Relative paths in it resolve against the working directory. ``overrides`` and
        ``world`` are those of :meth:`from_yaml`.
        """
        plugins = plugins or current()
        return cls(config_from_data(data, plugins.registry, overrides), world=world,
                   plugins=plugins, out_dir=out_dir)

    def _world_object(self, obj: Any) -> Any:
        """The world the loaded plugins make of ``obj`` (``cbr_world_object``)."""
        caller = self.plugins.pm.hook.cbr_world_object
        try:
            world = caller(obj=obj, ctx=self.ctx)
        except CbrError:
            raise
        except Exception as exc:
            raise PluginError(f"world: plugin {culprit(caller, exc, {})!r} failed to make a "
                              f"world of a {_type_name(obj)}: {type(exc).__name__}: {exc}"
                              ) from exc
        if world is None:
            takers = sorted({impl.plugin_name for impl in caller.get_hookimpls()})
            worlds = [f"{c.name} ({c.plugin})" for c in self.plugins.registry if c.kind == "world"]
            raise CbrError(
                f"world: no loaded plugin makes a world of a {_type_name(obj)} given as "
                f"Engine(world=...); plugins that take world objects: "
                f"{', '.join(takers) or 'none'}; the worlds a configuration can name instead: "
                f"{', '.join(worlds) or 'none registered'}")
        return world

    def _world_fingerprint(self, *, configured_world: bool) -> WorldFingerprint | None:
        """The fingerprint of the run's world, when its case components are world-bound.

        Asked of the loaded plugins (``cbr_world_fingerprint``); a configured world no plugin
        answers for is known by its component, options and the run's seed.
        """
        config = self.config
        if self.casebase is None or self.world is None:
            return None
        refs = [ref for ref in (config.retrieve, config.reuse, *config.retain, *config.forget)
                if ref is not None]
        registry = self.plugins.registry
        if all(registry.get(ref.kind, ref.name).world_independent for ref in refs):
            return None
        caller = self.plugins.pm.hook.cbr_world_fingerprint
        try:
            found = caller(world=self.world)
        except CbrError:
            raise
        except Exception as exc:
            raise PluginError(f"world: plugin {culprit(caller, exc, {})!r} failed to give the "
                              f"fingerprint of a {_type_name(self.world)}: "
                              f"{type(exc).__name__}: {exc}") from exc
        if found is not None:
            if not isinstance(found, WorldFingerprint):
                raise PluginError(f"world: plugin {culprit(caller, None, {})!r} gave a "
                                  f"{_type_name(found)} as the fingerprint of a "
                                  f"{_type_name(self.world)}, expected a WorldFingerprint")
            return found
        ref = config.world
        if not configured_world or ref is None:
            return None
        options = unstructure(ref.options)
        written = ", ".join(f"{key}: {value}" for key, value in options.items())
        return fingerprint("configured world", {"use": ref.name, "options": options,
                                                "seed": config.seed},
                           f"world {ref.name} {{{written}}}, seed {config.seed}")

    def _admit_world(self) -> None:
        """Refuse a case base of another world than the run's; note the world for the first
        learn step to record, when the run learns."""
        world = self.world_fingerprint
        if world is None or self.casebase is None:
            return
        recorded, problems = recorded_worlds(self.casebase)
        if problems:
            raise CaseBaseError(f"case base {self.casebase}: {problems[0]}; cbr casebase check "
                                "lists what is wrong")
        assert self.config.casebase is not None
        admit(recorded, [world], store_policy(self.config.casebase.options), self.casebase,
              "this run's world is")
        if self.config.retain or self.config.forget:
            self._unrecorded = world

    def _warm(self, *, configured_world: bool) -> float:
        """Call ``cbr_warm`` on every built component that implements it; the seconds taken.

        A world object given to the engine is the caller's, not a component: it is not warmed.
        """
        pm = new_plugin_manager()
        owners: dict[str, str] = {}
        world = [("world", self.config.world)] if configured_world else []
        refs = [*world, *((ref.path, ref) for ref in self._refs())]
        built = {"world": self.world, **self.components, "workload": self.workload,
                 **{ref.path: metric for ref, metric in zip(self.config.metrics, self.metrics,
                                                            strict=True)}}
        for path, ref in refs:
            part = built.get(path)
            if part is None or ref is None or "cbr_warm" not in implemented_hooks(part):
                continue
            plugin = self.plugins.registry.get(ref.kind, ref.name).plugin
            try:
                pm.register(part, name=path)
            except pluggy.PluginValidationError as exc:
                raise PluginError(f"{path}: {ref.kind} {ref.name!r} (plugin {plugin!r}): {exc}"
                                  ) from exc
            owners[path] = f"{ref.name} ({plugin})"
        # one job per component, in the order pluggy calls them (the last registered first)
        names = [impl.plugin_name for impl in reversed(pm.hook.cbr_warm.get_hookimpls())]

        def warm(name: str) -> None:
            others = [pm.get_plugin(other) for other in names if other != name]
            caller = pm.subset_hook_caller("cbr_warm", remove_plugins=others)
            try:
                caller(ctx=self.ctx)
            except CbrError:
                raise
            except Exception as exc:
                raise PhaseError(WARM, culprit(caller, exc, owners), exc) from exc

        started = time.perf_counter()
        warm_in_turn([functools.partial(warm, name) for name in names],
                     helper=self._first_compile)
        return time.perf_counter() - started

    def _refs(self) -> list[ComponentRef]:
        """Every configured component but the world and the case base, in the order built."""
        config = self.config
        single = [getattr(config, slot) for slot in ("retrieve", "reuse", "revise", "solver")]
        return [*config.slots.values(), *(ref for ref in single if ref is not None),
                *config.retain, *config.forget, *config.observers,
                *([config.workload] if config.workload is not None else []), *config.metrics]

    def _build(self, ref: ComponentRef | None) -> Any:
        if ref is None:
            return None
        component = self.plugins.registry.get(ref.kind, ref.name)
        try:
            return component.factory(ref.options, self.ctx)
        except CbrError:
            raise
        except Exception as exc:
            raise PluginError(f"{ref.path}: plugin {component.plugin!r} failed to build "
                              f"{ref.kind} {ref.name!r}: {type(exc).__name__}: {exc}") from exc

    def _component(self, ref: ComponentRef) -> Any:
        """Build the component of a slot, phase or observer, kept in ``components``."""
        instance = self.components[ref.path] = self._build(ref)
        return instance

    def _register(self, ref: ComponentRef, instance: Any) -> None:
        plugin = self.plugins.registry.get(ref.kind, ref.name).plugin
        hooks = set(implemented_hooks(instance)) & set(PHASE_HOOKS.values())
        wanted = KIND_HOOK.get(ref.kind)
        label = f"{ref.path}: {ref.kind} {ref.name!r} (plugin {plugin!r})"
        misspelt = unknown_hooks(instance)
        if misspelt:
            raise PluginError(f"{label}: {'; '.join(misspelt)}")
        if wanted is not None and hooks != {wanted}:
            extra = ", ".join(sorted(hooks - {wanted})) or "nothing else"
            raise PluginError(f"{label} must implement exactly {wanted}; it implements "
                              f"{', '.join(sorted(hooks)) or 'no phase hook'} ({extra} besides)")
        if wanted is None and not hooks:
            raise PluginError(f"{label} implements no phase hook to observe")
        name = f"{ref.path}:{ref.name}"
        try:
            self._pm.register(instance, name=name)
        except pluggy.PluginValidationError as exc:  # e.g. an argument the hookspec lacks
            raise PluginError(f"{label}: {exc}") from exc
        self._owners[name] = f"{ref.name} ({plugin})"
        self._slots[ref.kind] = ref.name

    def solve(self, problem: Any) -> Proposal:
        """Answer one query: from the case base if it can, else from the fallback solver. The
        proposal is also the context's ``previous`` until the next query is answered."""
        proposal = self._solve(problem)
        self.ctx.previous = proposal
        return proposal

    def _solve(self, problem: Any) -> Proposal:
        self.ctx.step = self.stats.queries
        self.stats.queries += 1
        if self.casebase is not None:
            self.ctx.mirror.sync()
        timings: dict[str, float] = {}
        retrieval: Retrieval | None = None
        revision: Revision | None = None
        solution, reason = None, None
        if "retriever" not in self._slots:
            reason = "no retriever configured"
        else:
            retrieval = self.hooks.retrieve(problem, self.casebase, self.ctx, timings)
            if retrieval is None or not retrieval.usable:
                reason = "no usable retrieval"
                if retrieval is not None and retrieval.reason:
                    reason = f"{reason}: {retrieval.reason}"
            elif "reuser" not in self._slots:
                reason = "no reuser configured"
            else:
                solution = self.hooks.reuse(problem, retrieval, self.ctx, timings)
                if solution is None:
                    reason = "reuse failed"
                elif "reviser" in self._slots:
                    revision = self.hooks.revise(problem, solution, self.ctx, timings)
                    if revision is None or not revision.accepted:
                        why = revision.reason if revision is not None else "no verdict"
                        reason = f"revision rejected: {why}" if why else "revision rejected"
                        solution = None
                    elif revision.solution is not None:
                        solution = revision.solution
        if solution is not None:
            self.stats.from_casebase += 1
            return Proposal(solution, CASEBASE, None, retrieval, revision, timings)
        self.stats.fallback_reasons[reason or ""] += 1
        if "solver" in self._slots:
            solution = self.hooks.solve(problem, self.ctx, timings)
        if solution is None:
            self.stats.unsolved += 1
            return Proposal(None, "none", reason, retrieval, revision, timings)
        self.stats.from_solver += 1
        source = f"solver:{self._slots['solver']}"
        return Proposal(solution, source, reason, retrieval, revision, timings)

    def learn(self, problem: Any, proposal: Proposal, outcome: Outcome, *,
              then: LearnDone | None = None) -> dict[str, float] | None:
        """Retain and forget after ``proposal`` was carried out.

        Every learn step reaches the retainers, a proposal without a solution too: they are
        then handed :func:`~cbrcore.model.no_action` (``solution.no_action``), since going on
        without an action is an outcome worth learning (a situation that needed nothing).
        One case base transaction: a crash inside keeps nothing of this step and everything
        before it. The step is all or nothing for what the run derives from the case base too:
        it runs inside the store mirror's transaction, which first catches up with what other
        writers committed and, if the step fails, drops the views that may hold its writes (a
        learned world among them). The engine's own transaction must be the outermost one: a
        learn step nested in a caller's transaction that rolls back later is not taken back
        from the mirror. The first step of a world-bound run records its world in the case
        base first (:func:`~cbrcore.casebase.worlds.record_world`), refusing one that another
        process of another world recorded meanwhile. Returns seconds per phase (``retain``,
        ``forget``) and for the whole step, commit included (``learn``), and calls ``then`` with
        them once it has committed.

        A step that waits longer than the store's ``busy_timeout`` for the case base's write
        lock (another process holds it, a learner frozen in its own step say) is skipped
        instead of failing the run: it is kept, counted in ``stats.learn_skipped``, and
        ``learn`` returns None. Skipped steps are retried in the order they were skipped at the
        start of the next learn step, which waits behind them (and is skipped too while the
        lock is still held), and by :meth:`retry_skipped`; ``then`` is called when the step
        commits at last. So a learner waits at most ``busy_timeout`` per learn step.
        """
        if self.casebase is None:
            raise ConfigError(str(self.config.source or "configuration"),
                              ["casebase: the engine has no case base to learn into; name a "
                               "store in the 'casebase' slot"])
        step = SkippedStep(problem, proposal, outcome, self.ctx.step, then)
        if self._skipped and not self._retry():
            self._skip(step)
            return None
        try:
            return self._learn(step)
        except CaseBaseLocked:
            self._skip(step)
            return None

    def retry_skipped(self) -> int:
        """Retry the skipped learn steps in order, until one still finds the case base locked
        (after waiting the store's ``busy_timeout``); return how many remain skipped.

        ``cbr run`` calls it when its workload is done, and reports the steps skipped and those
        still pending in its summary.
        """
        if self._skipped:
            self._retry()
        return len(self._skipped)

    def _skip(self, step: SkippedStep) -> None:
        self._skipped.append(step)
        self.stats.learn_skipped += 1
        self.stats.learn_pending = len(self._skipped)

    def _retry(self) -> bool:
        """Learn the skipped steps in order; False when the lock kept one out (it and those
        after it stay skipped)."""
        while self._skipped:
            step = self._skipped.popleft()
            try:
                self._learn(step)
            except CaseBaseLocked:
                self._skipped.appendleft(step)
                return False
            finally:
                self.stats.learn_pending = len(self._skipped)
        return True

    def _learn(self, step: SkippedStep) -> dict[str, float]:
        """One learn step, as the step it was first tried at; CaseBaseLocked changes nothing."""
        assert self.casebase is not None
        started = time.perf_counter()
        timings: dict[str, float] = {}
        proposal, outcome = step.proposal, step.outcome
        # a proposal without a solution is still an outcome: going on with no action worked
        # or did not, and a retainer may learn that (a safe place, a positive case)
        solution = outcome.solution or proposal.solution or no_action()
        current, self.ctx.step = self.ctx.step, step.step
        try:
            with self.ctx.mirror.transaction():
                if self._unrecorded is not None:
                    # under the write lock: a process of another world may have recorded it since
                    assert self.config.casebase is not None
                    record_world(self.casebase, self._unrecorded,
                                 store_policy(self.config.casebase.options))
                if proposal.from_casebase and proposal.solution is not None:
                    _touch_stored(self.casebase, proposal.solution.cases)
                self.hooks.retain(step.problem, solution, outcome, self.casebase, self.ctx,
                                  timings)
                self.hooks.forget(self.casebase, self.ctx, timings)
            self._unrecorded = None
        finally:
            self.ctx.step = current
        self.stats.learned += 1
        timings["learn"] = time.perf_counter() - started
        if step.then is not None:
            step.then(timings)
        return timings

    def measure(self, problem: Any, proposal: Proposal, outcome: Outcome) -> dict[str, Any]:
        """What the configured metrics measure of ``proposal`` carried out with ``outcome``.

        The figures of every metric, in the order configured. A metric that raises, or returns
        anything but a mapping, is a :class:`~cbrcore.errors.PhaseError` of the phase
        ``measure`` naming the metric and its plugin; a ``CbrError`` passes through unchanged.
        """
        figures: dict[str, Any] = {}
        for ref, metric in zip(self.config.metrics, self.metrics, strict=True):
            culprit = f"{ref.name} ({self.plugins.registry.get(ref.kind, ref.name).plugin})"
            try:
                measured = metric.measure(problem, proposal, outcome, self.ctx)
            except CbrError:
                raise
            except Exception as exc:
                raise PhaseError(MEASURE, culprit, exc) from exc
            if not isinstance(measured, Mapping):
                raise PhaseError(MEASURE, culprit, TypeError(
                    f"returned {type(measured).__name__}, expected a mapping of names to "
                    "numbers"))
            figures.update(measured)
        return figures

    def close(self) -> None:
        """Close every component that has a ``close()`` method, the case base last; idempotent."""
        if self._closed:
            return
        self._closed = True
        parts = [*self.components.values(), getattr(self, "workload", None),
                 *getattr(self, "metrics", ()), getattr(self, "world", None), self.casebase]
        for part in parts:
            close = getattr(part, "close", None)
            if callable(close):
                close()

    def __enter__(self) -> Engine:
        return self

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:
        self.close()


def _type_name(obj: Any) -> str:
    kind = type(obj)
    name = kind.__qualname__ if kind.__module__ == "builtins" else (
        f"{kind.__module__}.{kind.__qualname__}")
    shape = getattr(obj, "shape", None)
    return f"{name} of shape {tuple(shape)}" if isinstance(shape, tuple) else name


def _touch_stored(casebase: CaseStore, ids: Sequence[int]) -> None:
    """Count a use of each case of ``ids`` the case base still holds: a process sharing it may
    have forgotten one between the proposal that used it and the learn step."""
    try:
        casebase.touch(ids)
    except KeyError:
        # a touch that finds an id missing writes nothing: count the uses of the others
        kept = []
        for case_id in ids:
            try:
                casebase.get(case_id)
            except KeyError:
                continue
            kept.append(case_id)
        casebase.touch(kept)
