"""Map frames: cells and metres both ways, turned frames, and grids built from arrays."""

from __future__ import annotations

import math

import attrs
import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from cbr_grid.costs import CostModel
from cbr_grid.frame import MapFrame
from cbr_grid.grid import Grid
from cbrcore.errors import CbrError


def test_cell_centres_in_metres_by_hand() -> None:
    # 0.5 m cells, the image's lower-left corner at (10, 20); 4 rows, so row 3 is the bottom row
    frame = MapFrame(0.5, 10.0, 20.0)
    np.testing.assert_allclose(frame.to_map([(0, 3), (0, 0), (2, 1)], height=4),
                               [[10.25, 20.25], [10.25, 21.75], [11.25, 21.25]])
    np.testing.assert_array_equal(frame.to_cells([(10.25, 20.25), (11.25, 21.25)], height=4),
                                  [[0, 3], [2, 1]])
    # a point on the border between cells belongs to the larger x and the larger map y: the
    # cell right of it and above it, whose row number is the smaller (row 2 spans map y 20.5
    # to 21, row 3 20 to 20.5)
    np.testing.assert_array_equal(frame.to_cells([(10.5, 20.5)], height=4), [[1, 2]])
    # unit cells, 10 rows: map y 1 is the border between row 9 (y 0 to 1) and row 8 (y 1 to 2)
    np.testing.assert_array_equal(MapFrame(1.0).to_cells([[0.5, 1.0]], 10), [[0, 8]])
    # points off the map give cells off the grid
    np.testing.assert_array_equal(frame.to_cells([(9.9, 19.9)], height=4), [[-1, 4]])


def test_a_turned_frame_turns_about_the_lower_left_corner() -> None:
    # turned a quarter turn counter-clockwise: the image's x axis points along map y
    frame = MapFrame(1.0, 5.0, 0.0, math.pi / 2)
    # the bottom-left cell of a 2-row grid is half a cell along both image axes
    np.testing.assert_allclose(frame.to_map([(0, 1)], height=2), [[4.5, 0.5]], atol=1e-12)
    np.testing.assert_allclose(frame.to_map([(3, 0)], height=2), [[3.5, 3.5]], atol=1e-12)
    np.testing.assert_array_equal(frame.to_cells([(3.5, 3.5)], height=2), [[3, 0]])
    np.testing.assert_allclose(frame.corners(4, 2), [[5, 0], [5, 4], [3, 4], [3, 0]],
                               atol=1e-12)


@given(resolution=st.floats(0.01, 2.0), x=st.floats(-100, 100), y=st.floats(-100, 100),
       yaw=st.floats(-math.pi, math.pi), width=st.integers(1, 50), height=st.integers(1, 50),
       data=st.data())
def test_cells_and_metres_round_trip(resolution: float, x: float, y: float, yaw: float,
                                     width: int, height: int, data: st.DataObject) -> None:
    frame = MapFrame(resolution, x, y, yaw)
    cells = np.array(data.draw(st.lists(st.tuples(st.integers(0, width - 1),
                                                  st.integers(0, height - 1)),
                                        min_size=1, max_size=20)))
    points = frame.to_map(cells, height)
    np.testing.assert_array_equal(frame.to_cells(points, height), cells)
    # any point of a cell, not only its centre, maps back to that cell
    offset = np.array(data.draw(st.tuples(st.floats(-0.49, 0.49), st.floats(-0.49, 0.49))))
    inside = frame.to_map(cells + offset, height)
    np.testing.assert_array_equal(frame.to_cells(inside, height), cells)
    # neighbouring cell centres are one resolution apart, and map y grows as the row falls
    if height > 1:
        up = frame.to_map([(0, 0)], height)[0] - frame.to_map([(0, 1)], height)[0]
        np.testing.assert_allclose(up, resolution * np.array([-math.sin(yaw), math.cos(yaw)]),
                                   atol=1e-9)


@pytest.mark.parametrize(("args", "message"), [
    ((0.0,), "resolution must be a positive number"),
    ((-1.0,), "resolution must be a positive number"),
    ((0.1, math.inf), "x must be a finite number"),
    ((0.1, 0.0, 0.0, math.nan), "yaw must be a finite number"),
])
def test_bad_frames(args: tuple[float, ...], message: str) -> None:
    with pytest.raises(CbrError, match=message):
        MapFrame(*args)


def test_grid_keeps_frame_and_unknown_through_evolve() -> None:
    frame = MapFrame(0.05, 1.0, 2.0)
    unknown = np.array([[True, False], [False, False]])
    grid = Grid(np.zeros((2, 2)), frame=frame, unknown=unknown)
    changed = attrs.evolve(grid, risk=np.ones((2, 2)))
    assert changed.frame == frame
    np.testing.assert_array_equal(changed.unknown, unknown)
    assert not changed.unknown.flags.writeable
    np.testing.assert_allclose(grid.to_map([(1, 1)]), [[1.075, 2.025]])
    np.testing.assert_array_equal(grid.to_cells([(1.075, 2.025)]), [[1, 1]])
    with pytest.raises(CbrError, match="needs a grid with a map frame"):
        Grid(np.zeros((2, 2))).to_map([(0, 0)])
    with pytest.raises(CbrError, match=r"mask has shape \(1, 2\), the risk \(2, 2\)"):
        Grid(np.zeros((2, 2)), unknown=np.zeros((1, 2), dtype=bool))
    with pytest.raises(CbrError, match="must be a boolean mask"):
        Grid(np.zeros((1, 1)), unknown=np.zeros((1, 1)))


def test_from_array_reads_booleans_floats_and_occupancy() -> None:
    grid = Grid.from_array(np.array([[True, False]]))
    np.testing.assert_array_equal(grid.risk, [[1, 0]])
    assert grid.unknown is None and grid.frame is None

    floats = Grid.from_array(np.array([[0.0, 0.25, np.nan]]), allow_unknown=False,
                             corner_cutting=True, cost_model=CostModel(risk_weight=2.0))
    np.testing.assert_array_equal(floats.risk, [[0, 0.25, 1]])
    np.testing.assert_array_equal(floats.unknown, [[False, False, True]])
    assert floats.corner_cutting and floats.cost_model.risk_weight == 2.0

    # OccupancyGrid data as Nav2's static layer reads it: -1 unknown, 100 an obstacle, v below
    # it the cost int(v / 100 * 254): 24 -> 60.96 -> 60, 25 -> 63.5 -> 63, 65 -> 165.1 -> 165,
    # 66 -> 167.64 -> 167, 99 -> 251.46 -> 251
    frame = MapFrame(0.05)
    occupancy = Grid.from_array(np.array([[-1, 0, 24, 25, 65, 66, 99, 100]], dtype=np.int8),
                                frame=frame)
    np.testing.assert_allclose(occupancy.risk, [[252 / 254, 0, 60 / 254, 63 / 254, 165 / 254,
                                                 167 / 254, 251 / 254, 1]], rtol=0, atol=0)
    np.testing.assert_array_equal(occupancy.unknown, [[True] + [False] * 7])
    assert occupancy.frame == frame
    lethal = Grid.from_array(np.array([[-1, 50]], dtype=np.int8), allow_unknown=False)
    np.testing.assert_allclose(lethal.risk, [[1, 127 / 254]])


@pytest.mark.parametrize("dtype", [np.int64, np.int32, np.uint8, np.int16])
def test_only_int8_reads_as_occupancy_other_integers_are_refused(dtype: type) -> None:
    # a hand-made map of 0 free and 1 wall: as occupancy percentages it would be all free
    walls = np.array([[0, 1, 0], [0, 1, 0]], dtype=dtype)
    with pytest.raises(CbrError, match=rf"^an array of {np.dtype(dtype)} is ambiguous: expected "
                                       r"booleans \(True an obstacle, e\.g\. array == 1 .*\), "
                                       r"int8 occupancy values .* or floats \(risk in \[0, 1\]\)$"):
        Grid.from_array(walls)
    # read as the message suggests, the walls are walls
    np.testing.assert_array_equal(Grid.from_array(walls == 1).passable,
                                  [[True, False, True], [True, False, True]])
    np.testing.assert_array_equal(Grid.from_array(walls.astype(np.int8)).passable,
                                  [[True, True, True], [True, True, True]])


@pytest.mark.parametrize(("array", "kwargs", "message"), [
    (np.array([[0, 101]], dtype=np.int8), {},
     r"-1 \(unknown\) or 0 to 100; 1 cell\(s\) .* \(1, 0\) with 101"),
    (np.array([[-2]], dtype=np.int8), {}, "with -2"),
    (np.array([["a"]]), {}, r"expected a boolean, int8 \(ROS occupancy\) or float array, got "
                            r"<U1"),
    (np.array([[1.5]]), {}, r"within \[0, 1\]"),
])
def test_from_array_refuses_bad_values(array: np.ndarray, kwargs: dict[str, float],
                                       message: str) -> None:
    with pytest.raises(CbrError, match=message):
        Grid.from_array(array, **kwargs)


def test_a_blocked_unknown_cell_says_how_to_cross_unknown_space() -> None:
    # int8 occupancy: -1 unknown (lethal without allow_unknown), 100 an obstacle, 0 free
    grid = Grid.from_array(np.array([[-1, 100, 0]], dtype=np.int8), frame=MapFrame(1.0),
                           allow_unknown=False)
    with pytest.raises(CbrError, match=r"^start \(0, 0\) is on an unknown cell \(lethal as "
                                       r"unknown space is not allowed; allow_unknown: true "
                                       r"lets a planner cross it\)$"):
        grid.check_cell((0, 0), "start")
    with pytest.raises(CbrError, match=r"^start \(1, 0\) is on an obstacle$"):
        grid.check_cell((1, 0), "start")
    # in metres, the cell (0, 0) of a 1-row grid of 1 m cells spans x 0 to 1 m, y 0 to 1 m
    with pytest.raises(CbrError, match=r"^--goal \(0\.5, 0\.5\) m \[cell 0, 0\] is on an "
                                       r"unknown cell \(lethal as unknown space is not "
                                       r"allowed; --allow-unknown lets"):
        grid.check_point((0.5, 0.5), "--goal", allow="--allow-unknown")
    assert grid.check_point((2.5, 0.5), "--goal") == (2, 0)
    # allowed (the default), unknown space is passable: the cell is no longer refused
    assert Grid.from_array(np.array([[-1]], dtype=np.int8)).check_cell(
        (0, 0), "start") == (0, 0)
