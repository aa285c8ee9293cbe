"""The run context handed to component factories and to every phase hook."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any

import attrs
import numpy as np

from cbrcore.casebase.mirror import StoreMirror
from cbrcore.errors import CbrError
from cbrcore.stash import Stash, StashKey

if TYPE_CHECKING:
    from cbrcore.casebase.store import CaseStore
    from cbrcore.model import Proposal
    from cbrcore.registry import Registry


@attrs.define
class Context:
    """What a component may need besides its own options.

    ``world`` is the run's world: the configured one (None while it is being built), or, once a
    component made it a view of the case base with :meth:`learn_world` (a map the robot learns),
    that view as the case base holds it now. ``rng`` is the
    run's seeded generator: draw randomness from it, or from ``spawn_rng``, so that a run with the
    same seed repeats. ``step`` is the index of the query being handled. ``out_dir`` is the run's
    output folder, None when the engine is embedded without one. ``registry`` lets a component
    build another (a reuser's local search solver). ``stash`` holds state that components share
    within a run, under typed keys (:mod:`cbrcore.stash`). ``casebase`` is the run's case base
    (None while the world and the case base are being built). ``mirror`` keeps what components
    derive from the case base (a case graph, the arrays of a path index, a learned map) at the
    store's revision (:mod:`cbrcore.casebase.mirror`). ``previous`` is the engine's proposal for
    the query before the current one (None before the first answered query): its timings say
    what each phase cost, for a component that decides from what the run measured.
    """

    registry: Registry
    seed: int
    _world: Any = attrs.field(default=None, alias="world")
    step: int = 0
    out_dir: Path | None = None
    casebase: CaseStore | None = None
    config_dir: Path = attrs.field(factory=Path.cwd)
    rng: np.random.Generator = attrs.field()
    stash: Stash = attrs.field(factory=Stash)
    previous: Proposal | None = None
    _mirror: StoreMirror | None = attrs.field(default=None, init=False, repr=False)
    _world_view: tuple[StashKey[Any], Callable[[CaseStore], Any]] | None = attrs.field(
        default=None, init=False, repr=False)

    @rng.default
    def _seeded(self) -> np.random.Generator:
        return np.random.default_rng(self.seed)

    @property
    def world(self) -> Any:
        if self._world_view is not None:
            return self.mirror.view(*self._world_view)
        return self._world

    @world.setter
    def world(self, value: Any) -> None:
        self._world = value
        self._world_view = None

    def learn_world(self, key: StashKey[Any], load: Callable[[CaseStore], Any]) -> None:
        """From now on the run's world is the store mirror's view under ``key``, which ``load``
        builds from the case base: what the robot learned of its world is case base content, so
        a learn step that rolls back takes it back, and what another process learned into a
        shared case base reaches this run's planners at its next query. The component that
        learns changes the world with ``ctx.mirror.put(key, world)`` inside the learn step."""
        self._world_view = (key, load)

    @property
    def mirror(self) -> StoreMirror:
        """The mirror of the run's case base; a CbrError when the run has none."""
        if self.casebase is None:
            raise CbrError("this component keeps an index of the case base and needs one "
                           "(the 'casebase' slot)")
        if self._mirror is None or self._mirror.store is not self.casebase:
            self._mirror = StoreMirror(self.casebase)
        return self._mirror

    def spawn_rng(self) -> np.random.Generator:
        """A new independent generator derived from the run's seed, for one component's use."""
        return self.rng.spawn(1)[0]
