"""The run context handed to component factories and to every phase hook."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

import attrs
import numpy as np

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
    build another (a reuser's local search solver). ``shared`` is scratch space for components of
    one plugin family that must share state within a run. ``casebase`` is the run's case base
    (None while the world and the case base are being built), for components that keep state
    derived from it (a case graph, a learned map) and load it when they are built.
    """

    registry: Registry
    seed: int
    world: Any = None
    step: int = 0
    out_dir: Path | None = None
    casebase: CaseStore | None = None
    config_dir: Path = attrs.field(factory=Path.cwd)
    rng: np.random.Generator = attrs.field()
    shared: dict[str, Any] = attrs.field(factory=dict)

    @rng.default
    def _seeded(self) -> np.random.Generator:
        return np.random.default_rng(self.seed)

    def spawn_rng(self) -> np.random.Generator:
        """A new independent generator derived from the run's seed, for one component's use."""
        return self.rng.spawn(1)[0]
