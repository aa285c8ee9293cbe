"""The hand-made cases of 002's experiments, and the shipped file that holds them.

002 section 4: in scenario 1, "at point A the robot retrieves a previous case formed by the
landmarks l1, l2 and the linear obstacle" and l2 becomes the diverting target; in scenario 2, "a
case formed by the landmarks l1, l2, l3 and both linear obstacles between them is retrieved" and
the diverting target is l3. The paper gives the cases' content only so; we build each as the
robot sees the layout from point A facing its target, with the camera of the experiment and no
measurement noise (the spreads of the camera's fuzzy numbers, peaks at the true values), and put
the diverting target beside the named landmark (a robot cannot drive onto one): :data:`ALONG`
metres past it along the obstacle that reaches it and :data:`ASIDE` metres to the left of that
obstacle's direction, which in scenario 2 is outside the V, so that the straight way on to the
target passes clear of l3.

``cases/ros2005.yaml`` (an exported case base, for a store's ``initial`` option) is written by
:func:`write_paper_cases` (``python -m cbr_landmarks.handmade``); a test checks that it matches.
"""

from __future__ import annotations

import math
from importlib import resources
from pathlib import Path

import attrs
import numpy as np

from cbr_landmarks.action import DivertAction
from cbr_landmarks.case import LandmarkCase
from cbr_landmarks.problem import RegionOptions, problem_view
from cbr_world2d.worldfile import load_world
from cbrcore.casebase.exchange import Document, write_document

ALONG = 0.5
"""How far past the named landmark the diverting target lies, in metres."""
ASIDE = 0.3
"""How far to the left of the obstacle's direction the diverting target lies, in metres."""

PAPER_CASES: dict[str, tuple[str, str]] = {"scenario1": ("l2", "l1"), "scenario2": ("l3", "l2")}
"""Per scenario world: the landmark 002 sets as the diverting target, and the landmark at the
other end of the obstacle that reaches it."""

CAMERA_FOV = 180.0
"""The camera's field of view in the paper's experiments, in degrees: 002's robot sees every
landmark of the layout at point A (its Vision agent scans round the robot), which a narrower
forward camera would not."""


def paper_case(scenario: str, region: RegionOptions | None = None,
               fov: float = CAMERA_FOV, along: float = ALONG, aside: float = ASIDE
               ) -> LandmarkCase:
    """The hand-made case of the shipped world ``scenario``, seen from its start."""
    from cbr_world2d.robot import RobotState
    from cbr_world2d.sensors import Camera, Sensors
    from cbr_world2d.workload import situation

    world = load_world(resources.files("cbr_world2d") / "worlds" / f"{scenario}.yaml")
    start, target = world.places["start"], world.places["target"]
    heading = math.atan2(target[1] - start[1], target[0] - start[0])
    sensors = Sensors(sonar=None, camera=Camera(fov=math.radians(fov), noise=0.0))
    obs = sensors.observe(RobotState(start[0], start[1], heading), world, 0.0, False,
                          np.random.default_rng(0))
    view = problem_view(situation(world, 0, "hand-made", obs, target),
                        region if region is not None else RegionOptions())
    if view is None:
        raise ValueError(f"{scenario}: fewer than two landmarks in view from the start")
    anchor, base = PAPER_CASES[scenario]
    graph = attrs.evolve(view.graph, where=f"hand-made case of {scenario}")
    return LandmarkCase(graph, DivertAction(anchor, base, along, aside), origin="hand-made")


def paper_document() -> Document:
    """The hand-made cases as an exported case base, ids from 1."""
    cases = tuple(attrs.evolve(paper_case(name), id=k).to_case()
                  for k, name in enumerate(PAPER_CASES, start=1))
    return Document(revision=1, cases=tuple(attrs.evolve(c, created=1) for c in cases))


def shipped_path() -> Path:
    return Path(str(resources.files("cbr_landmarks") / "cases" / "ros2005.yaml"))


def write_paper_cases(target: Path | None = None) -> Path:
    """Write :func:`paper_document` to ``target`` (default: the shipped file)."""
    path = target if target is not None else shipped_path()
    path.parent.mkdir(parents=True, exist_ok=True)
    write_document(paper_document(), path, "yaml")
    return path


if __name__ == "__main__":
    print(write_paper_cases())
