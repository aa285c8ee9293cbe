"""Forgetting strategies for whole-path cases (survey §2.2; Šeda & Dvořák §4).

Each is a forgetter with a ``capacity``: after a retain, while more than ``capacity`` paths are
stored, it forgets the one its strategy ranks first (ties go to the lower id, the older case):

============================  ==================================================================
``worst_paths``               the highest cost: success-driven learning
``average_paths``             the cost nearest the mean cost of the stored paths: the
                              non-characteristic cases (recomputed after each removal)
``best_paths``                the lowest cost: failure-driven learning, which keeps the robot's
                              memory of what went wrong
``least_recent_paths``        the longest unused (last use, or creation if never used)
``least_used_paths``          the fewest uses
``oldest_paths``              the first stored
``newest_paths``              the last stored: the passive limit, which stops learning when full
============================  ==================================================================

``near_duplicate_paths`` is the survey's "stop retaining information about new cases that
provided similar solutions after reaching a predefined number of such cases": a newly retained
path with more than ``count`` stored paths within ``radius`` (Hausdorff) of it is forgotten
again, while paths unlike any stored one are still kept.
"""

from __future__ import annotations

import abc

import attrs
import numpy as np

from cbr_grid.distances import DistanceName
from cbr_pathcases import CAPACITY_FORGETTERS
from cbr_pathcases.base import PathBase, base_of
from cbrcore.context import Context
from cbrcore.hookspecs import hookimpl
from cbrcore.options import option


@attrs.frozen
class CapacityOptions:
    capacity: int = option(100, "The most paths kept.", validator=attrs.validators.ge(1))


class CapacityForgetter(abc.ABC):
    """Forget the paths ranked first by :meth:`rank` until at most ``capacity`` remain."""

    def __init__(self, options: CapacityOptions, ctx: Context) -> None:
        self.capacity = options.capacity
        base_of(ctx)

    @staticmethod
    @abc.abstractmethod
    def rank(base: PathBase) -> np.ndarray:
        """A key per stored path; the lowest is forgotten first."""

    @hookimpl
    def cbr_forget(self, ctx: Context) -> None:
        base = base_of(ctx)
        while len(base) > self.capacity:
            # rows are ordered by id: the first of the lowest keys is the older case
            base.remove([int(base.ids[np.argmin(self.rank(base))])])


class WorstPaths(CapacityForgetter):
    """Success-driven: forget the costliest path."""

    @staticmethod
    def rank(base: PathBase) -> np.ndarray:
        return -base.costs


class AveragePaths(CapacityForgetter):
    """Forget the path whose cost is nearest the mean cost."""

    @staticmethod
    def rank(base: PathBase) -> np.ndarray:
        return np.abs(base.costs - base.costs.mean())


class BestPaths(CapacityForgetter):
    """Failure-driven: forget the cheapest path."""

    @staticmethod
    def rank(base: PathBase) -> np.ndarray:
        return base.costs


class LeastRecentPaths(CapacityForgetter):
    """Forget the path unused for longest (never used counts from its creation)."""

    @staticmethod
    def rank(base: PathBase) -> np.ndarray:
        return np.where(base.last_used >= 0, base.last_used, base.created)


class LeastUsedPaths(CapacityForgetter):
    """Forget the path used the fewest times."""

    @staticmethod
    def rank(base: PathBase) -> np.ndarray:
        return base.uses


class OldestPaths(CapacityForgetter):
    """Forget the path stored first."""

    @staticmethod
    def rank(base: PathBase) -> np.ndarray:
        return base.created


class NewestPaths(CapacityForgetter):
    """The passive limit: forget the path stored last, so a full case base stops learning."""

    @staticmethod
    def rank(base: PathBase) -> np.ndarray:
        # the id, not the creation stamp, orders the cases of one learn step
        return -base.ids


CAPACITY_STRATEGIES: dict[str, type[CapacityForgetter]] = {
    name: globals()[cls] for name, cls in CAPACITY_FORGETTERS.items()}
"""Each capacity strategy by forgetter name."""


@attrs.frozen
class NearDuplicateOptions:
    count: int = option(
        3, "How many stored paths may resemble a new one before it is no longer kept.",
        validator=attrs.validators.ge(0))
    radius: float = option(
        6.0, "Paths within this symmetric Hausdorff distance resemble each other.",
        validator=attrs.validators.ge(0))
    distance: DistanceName = option("euclidean", "The cell distance inside the Hausdorff "
                                    "distance.")


class NearDuplicatePaths:
    """Stop retaining paths like ``count`` stored ones; keep retaining new kinds of path."""

    def __init__(self, options: NearDuplicateOptions, ctx: Context) -> None:
        self.options = options
        self.known = base_of(ctx).ids.copy()

    @hookimpl
    def cbr_forget(self, ctx: Context) -> None:
        base = base_of(ctx)
        new = base.ids[~np.isin(base.ids, self.known)]
        for case_id in new.tolist():
            row = int(base.rows([case_id])[0])
            rows, forward, backward = base.hausdorff(base.paths[row],
                                                     distance=self.options.distance,
                                                     limit=self.options.radius, symmetric=True)
            near = (np.maximum(forward, backward) <= self.options.radius) & (rows != row)
            if int(near.sum()) > self.options.count:
                base.remove([case_id])
        self.known = base.ids.copy()
