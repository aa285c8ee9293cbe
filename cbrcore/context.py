"""The run context handed to component factories and to every phase hook."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

import attrs
import numpy as np

from cbrcore.casebase.mirror import StoreMirror
from cbrcore.errors import CbrError
from cbrcore.stash import Stash

if TYPE_CHECKING:
    from cbrcore.casebase.store import CaseStore
    from cbrcore.registry import Registry


@attrs.define
class Context:
    """What a component may need besides its own options.

    ``world`` is the configured world (None while the world itself is being built). ``rng`` is the
    run's seeded generator: draw randomness from it, or from ``spawn_rng``, so that a run with the
    same seed repeats. ``step`` is the index of the query being handled. ``out_dir`` is the run's
    output folder, None when the engine is embedded without one. ``registry`` lets a component
    build another (a reuser's local search solver). ``stash`` holds state that components share
    within a run, under typed keys (:mod:`cbrcore.stash`). ``casebase`` is the run's case base
    (None while the world and the case base are being built). ``mirror`` keeps what components
    derive from the case base (a case graph, the arrays of a path index, a learned map) at the
    store's revision (:mod:`cbrcore.casebase.mirror`).
    """

    registry: Registry
    seed: int
    world: Any = None
    step: int = 0
    out_dir: Path | None = None
    casebase: CaseStore | None = None
    config_dir: Path = attrs.field(factory=Path.cwd)
    rng: np.random.Generator = attrs.field()
    stash: Stash = attrs.field(factory=Stash)
    _mirror: StoreMirror | None = attrs.field(default=None, init=False, repr=False)

    @rng.default
    def _seeded(self) -> np.random.Generator:
        return np.random.default_rng(self.seed)

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
