"""The shipped Nav2 maps: frames, metre starts and goals, planning with inflation, pictures."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest

from cbr_grid.formats import load_grid
from cbr_grid.frame import MapFrame
from cbr_grid.grid import Grid
from cbr_grid.inflation import Inflation, inflate
from cbr_grid.plot import UNKNOWN_COLOUR, draw_grid
from cbr_solvers.search import astar
from cbrcore.engine import Engine
from cbrcore.errors import ConfigError
from repo_paths import DATA

ROS = DATA / "ros"
DEPOT = ROS / "depot.yaml"
CIRCULAR = ROS / "map_circular.yaml"
ROBOT = 0.22  # the radius of Nav2's default robot, metres

# depot: 0.05 m cells, origin (0, 0), 604 x 307 cells. (2, 2) m lies 40 cells right of and 40
# up from the lower-left corner: column 40, row 307 - 1 - 40 = 266. (20, 3.5) m: column 400,
# row 306 - 70 = 236. Between them the shortest path passes a box 0.05 m away.
START_M, GOAL_M = (2.0, 2.0), (20.0, 3.5)
START, GOAL = (40, 266), (400, 236)


def clearance(grid: Grid, path: np.ndarray) -> float:
    """The least distance, in metres, from a path cell's centre to an obstacle cell's centre,
    by brute force over every pair."""
    obstacles = np.argwhere(~grid.passable)[:, ::-1]
    gaps = np.hypot(*(path[:, None, :] - obstacles[None, :, :]).transpose(2, 0, 1))
    return float(gaps.min()) * grid.frame.resolution


def test_both_maps_load_with_their_frames() -> None:
    depot = load_grid(DEPOT)
    assert (depot.width, depot.height) == (604, 307)
    assert depot.frame == MapFrame(0.05, 0.0, 0.0, 0.0)
    assert depot.unknown is None  # its grey outside reads as free (p = 50/255 < 0.25)
    circular = load_grid(CIRCULAR)
    assert (circular.width, circular.height) == (384, 384)
    assert circular.frame == MapFrame(0.05, -10.0, -10.0, 0.0)
    # its grey 205 reads as p = 50/255 = 0.19608, just above free_thresh 0.196: unknown
    # space, marked and, by default as in Nav2's planners, crossable at cost 252 of 254
    assert circular.unknown is not None
    assert circular.unknown.sum() > (circular.passable & ~circular.unknown).sum()
    assert (circular.risk[circular.unknown] == 252 / 254).all()
    assert circular.unknown[0, 0]
    lethal = load_grid(CIRCULAR, allow_unknown=False)
    assert (lethal.risk[lethal.unknown] == 1).all()


def test_metres_land_on_the_right_cells() -> None:
    depot = load_grid(DEPOT)
    np.testing.assert_array_equal(depot.to_cells([START_M, GOAL_M]), [START, GOAL])
    np.testing.assert_allclose(depot.to_map([START]), [[2.025, 2.025]])
    # map_circular's origin is (-10, -10): (-2, 0) m is 160 cells right of and 200 up from the
    # lower-left corner, row 383 - 200 = 183; the map frame's (0, 0) is cell (200, 183)
    circular = load_grid(CIRCULAR)
    np.testing.assert_array_equal(circular.to_cells([(-2.0, 0.0), (0.0, 0.0)]),
                                  [[160, 183], [200, 183]])
    np.testing.assert_allclose(circular.to_map([(200, 183)]), [[0.025, 0.025]])


def test_inflated_plan_keeps_the_robot_radius_from_obstacles() -> None:
    depot = load_grid(DEPOT)
    inflated = inflate(depot, Inflation(ROBOT, 0.55, 3.0))
    assert inflated.frame == depot.frame
    start, goal = (tuple(int(v) for v in cell) for cell in inflated.to_cells([START_M, GOAL_M]))
    plain = astar(depot.factor, depot.passable, depot.corner_cutting, start, [goal])
    found = astar(inflated.factor, inflated.passable, inflated.corner_cutting, start, [goal])
    assert found is not None and plain is not None
    assert tuple(found.path[0]) == START and tuple(found.path[-1]) == GOAL
    assert clearance(depot, plain.path) < ROBOT
    assert clearance(depot, found.path) > ROBOT
    assert inflated.path_problems(found.path) == []


def test_pictures_have_metric_axes() -> None:
    depot = load_grid(DEPOT)
    axes = draw_grid(depot, path=[START, (41, 266)], start=START, goal=GOAL).axes[0]
    assert axes.get_xlabel() == "x [m]" and axes.get_ylabel() == "y [m]"
    np.testing.assert_allclose(axes.images[0].get_extent(), [0, 30.2, 0, 15.35])
    np.testing.assert_allclose(axes.get_xlim(), [0, 30.2])
    np.testing.assert_allclose(axes.get_ylim(), [0, 15.35])
    line = axes.get_lines()[0]
    np.testing.assert_allclose(np.column_stack(line.get_data()), [[2.025, 2.025],
                                                                 [2.075, 2.025]])

    circular = load_grid(CIRCULAR)
    axes = draw_grid(circular).axes[0]
    # the whole map is drawn, the axes show the part it knows
    np.testing.assert_allclose(axes.images[0].get_extent(), [-10, 9.2, -10, 9.2])
    rows, columns = np.nonzero(~circular.unknown)
    x0, x1, y0, y1 = columns.min(), columns.max() + 1, rows.min(), rows.max() + 1
    margin = max(2, int(np.ceil(0.05 * max(x1 - x0, y1 - y0))))
    x0, y0, x1, y1 = max(x0 - margin, 0), max(y0 - margin, 0), x1 + margin, y1 + margin
    np.testing.assert_allclose(axes.get_xlim(), [-10 + 0.05 * x0, -10 + 0.05 * x1])
    np.testing.assert_allclose(axes.get_ylim(), [-10 + 0.05 * (384 - y1),
                                                 -10 + 0.05 * (384 - y0)])
    assert axes.get_xlim()[1] - axes.get_xlim()[0] < 0.8 * 19.2
    picture = axes.images[0].get_array()
    np.testing.assert_allclose(picture[0, 0], UNKNOWN_COLOUR)
    assert [text.get_text() for text in axes.get_legend().get_texts()] == ["unknown"]
    # free and obstacle cells keep white and black
    free = np.argwhere(circular.passable & ~circular.unknown)[0]
    blocked = np.argwhere(~circular.passable & ~circular.unknown)[0]
    np.testing.assert_allclose(picture[tuple(free)], [1, 1, 1])
    np.testing.assert_allclose(picture[tuple(blocked)], [0, 0, 0])


def test_a_turned_frame_is_drawn_turned() -> None:
    grid = Grid(np.zeros((2, 4)), frame=MapFrame(1.0, 5.0, 0.0, np.pi / 2))
    axes = draw_grid(grid, path=[(0, 1), (1, 1)]).axes[0]
    assert axes.get_xlabel() == "x [m]"
    np.testing.assert_allclose(axes.get_xlim(), [3, 5], atol=1e-12)
    np.testing.assert_allclose(axes.get_ylim(), [0, 4], atol=1e-12)
    np.testing.assert_allclose(np.column_stack(axes.get_lines()[0].get_data()),
                               [[4.5, 0.5], [4.5, 1.5]], atol=1e-12)


def test_cells_only_grids_keep_cell_axes() -> None:
    axes = draw_grid(Grid(np.zeros((3, 5)))).axes[0]
    assert axes.get_xlabel() == "x"
    assert axes.get_ylim() == pytest.approx((2.5, -0.5))


def test_a_map_of_cells_placed_in_a_frame_by_its_world_options(
        tmp_path: Path, cbr_engine: Callable[..., Engine]) -> None:
    # a 4 x 3 text map of 0.5 m cells whose lower-left corner is at (10, 20) m, with one
    # obstacle at cell (1, 0), inflated by a 1.0 m inscribed radius
    (tmp_path / "room.grid").write_text(".#..\n....\n....\n")
    world = {"use": "map_file", "path": str(tmp_path / "room.grid"),
             "frame": {"resolution": 0.5, "origin": [10, 20, 0]},
             "inflation": {"robot_radius": 1.0}}
    engine = cbr_engine({"world": world, "solver": "astar"})
    grid = engine.world
    assert grid.frame == MapFrame(0.5, 10.0, 20.0, 0.0)
    assert grid.to_map([(0, 2)]).tolist() == [[10.25, 20.25]]
    # 1 m is 2 cells: left free are the cells farther from (1, 0), (3, 1), (0, 2) and (2, 2)
    # at sqrt(5) cells and (3, 2) at sqrt(8); (3, 0) and (1, 2), exactly 2 away, are inside
    assert np.argwhere(grid.passable)[:, ::-1].tolist() == [[3, 1], [0, 2], [2, 2], [3, 2]]


@pytest.mark.parametrize(("frame", "problem"), [
    ("{resolution: 0.5, origin: [.nan, 0, 0]}",
     "world.frame.origin (line 1, column 74): must be three finite numbers [x, y, yaw], got "
     "[nan, 0.0, 0.0]"),
    ("{resolution: 0.5, origin: [0, 0, .inf]}",
     "world.frame.origin (line 1, column 74): must be three finite numbers [x, y, yaw], got "
     "[0.0, 0.0, inf]"),
    ("{resolution: .inf}",
     "world.frame.resolution (line 1, column 61): must be a finite number of metres > 0, got inf"),
])
def test_a_frame_that_is_not_finite_is_the_options_problem(
        frame: str, problem: str, cbr_engine: Callable[..., Engine]) -> None:
    # refused while the configuration is read, at its YAML path, before any map is loaded
    # (the map file does not even exist)
    with pytest.raises(ConfigError) as caught:
        cbr_engine(f"world: {{use: map_file, path: room.grid, frame: {frame}}}\n")
    assert caught.value.problems == [problem]


def test_a_frame_given_for_a_ros_map_is_the_frame_options_problem(
        cbr_engine: Callable[..., Engine]) -> None:
    with pytest.raises(ConfigError) as caught:
        cbr_engine({"world": {"use": "map_file", "path": str(CIRCULAR),
                              "frame": {"resolution": 0.05}}})
    assert caught.value.problems == [
        "world.frame: must be null for a ROS map (map_circular.yaml), which carries its own "
        "frame (resolution and origin)"]


def test_pictures_of_maps_with_unknown_cells_are_cropped_to_the_known_cells() -> None:
    # cells only: 40 x 30, known cells x 10-19 and y 5-9, a box 10 x 5 cells; the margin is
    # 5 % of 10, less than 2 cells: 2. Shown: x 8-21 and y 3-11, so the limits are the cells'
    # outer edges 7.5 to 21.5 and (row 0 at the top) 11.5 to 2.5
    risk = np.zeros((30, 40))
    unknown = np.ones((30, 40), dtype=bool)
    unknown[5:10, 10:20] = False
    grid = Grid(risk, unknown=unknown)
    axes = draw_grid(grid).axes[0]
    assert axes.get_xlim() == pytest.approx((7.5, 21.5))
    assert axes.get_ylim() == pytest.approx((11.5, 2.5))
    # a goal in unknown space widens the box to hold it: x 10-30, y 5-25, longest side 21
    # cells, margin 2 (5 % is 1.05): x 8-32, y 3-27
    axes = draw_grid(grid, path=[(19, 9), (30, 25)], goal=(30, 25)).axes[0]
    assert axes.get_xlim() == pytest.approx((7.5, 32.5))
    assert axes.get_ylim() == pytest.approx((27.5, 2.5))

    # metres: 200 x 100 cells of 0.1 m, origin (-1, 2); known cells x 20-99 and y 10-49, a box
    # 80 x 40 cells; margin 5 % of 80 = 4 cells: x 16-103 and rows 6-53. In metres x from
    # -1 + 1.6 to -1 + 10.4, y from 2 + (100 - 54) 0.1 = 6.6 to 2 + (100 - 6) 0.1 = 11.4
    unknown = np.ones((100, 200), dtype=bool)
    unknown[10:50, 20:100] = False
    grid = Grid(np.zeros((100, 200)), unknown=unknown, frame=MapFrame(0.1, -1.0, 2.0))
    axes = draw_grid(grid).axes[0]
    assert axes.get_xlim() == pytest.approx((0.6, 9.4))
    assert axes.get_ylim() == pytest.approx((6.6, 11.4))
    # a map that knows every cell, or none, is shown whole
    for everywhere in (False, True):
        grid = Grid(np.zeros((100, 200)), unknown=np.full((100, 200), everywhere),
                    frame=MapFrame(0.1, -1.0, 2.0))
        axes = draw_grid(grid).axes[0]
        assert axes.get_xlim() == pytest.approx((-1, 19))
        assert axes.get_ylim() == pytest.approx((2, 12))
