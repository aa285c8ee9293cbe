"""Fuzzy landmark-graph situations (Ros et al. 2005, 002): the CBR agent that diverts a
potential-field robot away from dead ends and linear obstacles in the 2D world.

A case ``<L, O, delta, alpha, a>`` is a graph of landmarks with linear obstacles between some of
them, the fuzzy distances and angles of every pair (:mod:`cbr_landmarks.graph`), and a diverting
target placed among its landmarks (:mod:`cbr_landmarks.action`). The problem case is what the
camera sees in the region in front of the robot (:mod:`cbr_landmarks.problem`); two graphs are
compared by the best landmark matching found by branch and bound (:mod:`cbr_landmarks.similarity`)
over an index of every stored situation (:mod:`cbr_landmarks.index`).

Registers the ``landmarks`` retriever and reuser, the ``landmark_trouble`` retainer, the
``unhelpful_situations`` forgetter, the ``landmark_detour`` solver, and the experiments
``landmark-scenarios`` and ``landmark-learning``. See docs/landmarks.md.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from cbrcore.hookspecs import hookimpl

if TYPE_CHECKING:
    from cbrcore.context import Context
    from cbrcore.registry import Registry

_COMPONENTS = "cbr_landmarks.components"


def _scenarios(options: object, ctx: Context) -> object:
    # the engine, the simulator and matplotlib load when the experiment runs
    from cbr_landmarks.experiments.scenarios import Scenarios

    return Scenarios(options, ctx)


def _learning(options: object, ctx: Context) -> object:
    from cbr_landmarks.experiments.learning import Learning

    return Learning(options, ctx)


@hookimpl
def cbr_register(registry: Registry) -> None:
    # named, not imported: the components load with the 2D world when a configuration uses them.
    # Landmark graphs compared by matching, not a world's landmarks: the cases hold in any world
    registry.add("retriever", "landmarks", f"{_COMPONENTS}:LandmarkRetriever",
                 options=f"{_COMPONENTS}:RetrieveOptions", world_independent=True)
    registry.add("reuser", "landmarks", f"{_COMPONENTS}:LandmarkReuser",
                 options=f"{_COMPONENTS}:ReuseOptions", world_independent=True)
    registry.add("retainer", "landmark_trouble", f"{_COMPONENTS}:TroubleRetainer",
                 options=f"{_COMPONENTS}:RetainOptions", world_independent=True)
    registry.add("forgetter", "unhelpful_situations", f"{_COMPONENTS}:UnhelpfulSituations",
                 options=f"{_COMPONENTS}:ForgetOptions", world_independent=True)
    registry.add("solver", "landmark_detour", "cbr_landmarks.detour:LandmarkDetour",
                 options="cbr_landmarks.detour:DetourOptions")
    registry.add("experiment", "landmark-scenarios", _scenarios,
                 doc="002 Figures 6 and 7: the two scenarios with and without the CBR agent "
                 "and its hand-made cases.")
    registry.add("experiment", "landmark-learning", _learning,
                 doc="Situations learned in some semi-structured worlds reused in unseen ones: "
                 "learning curves of success, time and distance against no CBR.")
