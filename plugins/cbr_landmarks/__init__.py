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

from cbr_landmarks.components import (
    ForgetOptions,
    LandmarkRetriever,
    LandmarkReuser,
    RetainOptions,
    RetrieveOptions,
    ReuseOptions,
    TroubleRetainer,
    UnhelpfulSituations,
)
from cbr_landmarks.detour import DetourOptions, LandmarkDetour
from cbrcore.context import Context
from cbrcore.hookspecs import hookimpl
from cbrcore.registry import Registry


def _scenarios(options: object, ctx: Context) -> object:
    # the engine, the simulator and matplotlib load when the experiment runs
    from cbr_landmarks.experiments.scenarios import Scenarios

    return Scenarios(options, ctx)


def _learning(options: object, ctx: Context) -> object:
    from cbr_landmarks.experiments.learning import Learning

    return Learning(options, ctx)


@hookimpl
def cbr_register(registry: Registry) -> None:
    # landmark graphs compared by matching, not a world's landmarks: the cases hold in any world
    registry.add("retriever", "landmarks", LandmarkRetriever, options=RetrieveOptions,
                 world_independent=True)
    registry.add("reuser", "landmarks", LandmarkReuser, options=ReuseOptions,
                 world_independent=True)
    registry.add("retainer", "landmark_trouble", TroubleRetainer, options=RetainOptions,
                 world_independent=True)
    registry.add("forgetter", "unhelpful_situations", UnhelpfulSituations,
                 options=ForgetOptions, world_independent=True)
    registry.add("solver", "landmark_detour", LandmarkDetour, options=DetourOptions)
    registry.add("experiment", "landmark-scenarios", _scenarios,
                 doc="002 Figures 6 and 7: the two scenarios with and without the CBR agent "
                 "and its hand-made cases.")
    registry.add("experiment", "landmark-learning", _learning,
                 doc="Situations learned in some semi-structured worlds reused in unseen ones: "
                 "learning curves of success, time and distance against no CBR.")
