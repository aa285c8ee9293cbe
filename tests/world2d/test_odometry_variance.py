"""The odometry's error variance (:class:`cbr_world2d.sensors.Odometry`), read back from its
public confidence, against the propagation worked by hand.

With ``H`` the heading variance, ``C`` the cross-track error's covariance with the heading and
``var`` the position variance, a turn ``dtheta`` adds ``(noise_w dtheta)^2`` to ``H`` and a
straight move ``ds`` adds ``(noise_v ds)^2 + 2 ds C + ds^2 H`` to ``var`` and ``ds H`` to ``C``.
After one turn in place (``H`` fixed from then on, ``C`` starting at 0) straight moves
``ds_1 .. ds_n`` give ``C_k = H (ds_1 + ... + ds_k)`` and so

    var = noise_v^2 (ds_1^2 + ... + ds_n^2) + H (ds_1 + ... + ds_n)^2,

for n equal steps ``n (noise_v ds)^2 + H (n ds)^2``: the heading error of the turn grows the
sideways error with the square of the distance driven, not linearly as independent steps
would.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from cbr_world2d.robot import Pose
from cbr_world2d.sensors import Odometry


def variance(odometry: Odometry) -> float:
    """The position variance from the public confidence, ``1 / (1 + var / scale^2)``."""
    scale = odometry.confidence_scale
    return scale * scale * (1.0 / odometry.confidence - 1.0)


def drive(odometry: Odometry, turn: float, steps: Sequence[float], rng: np.random.Generator,
          start: Pose = Pose(1.0, 2.0, 0.3)) -> None:
    """Turn in place by ``turn`` from ``start``, then drive straight ``steps`` metres each."""
    odometry.reset(start)
    heading = start.theta + turn
    odometry.update(start, Pose(start.x, start.y, heading), 0.1, rng)
    x, y = start.x, start.y
    for ds in steps:
        nx, ny = x + ds * math.cos(heading), y + ds * math.sin(heading)
        odometry.update(Pose(x, y, heading), Pose(nx, ny, heading), 0.1, rng)
        x, y = nx, ny


@pytest.mark.parametrize("noise_v, noise_w, turn, ds, n", [
    (0.05, 0.1, math.pi / 2, 0.1, 20),
    (0.0075, 0.0075, 1.0, 0.04, 100),
    (0.02, 0.0, -0.7, 0.2, 10),     # no heading noise: the along-track terms alone
    (0.0, 0.05, 2.5, 0.05, 40),     # no speed noise: the heading's term alone
])
def test_straight_steps_after_one_turn_follow_the_closed_form(noise_v: float, noise_w: float,
                                                              turn: float, ds: float,
                                                              n: int) -> None:
    odometry = Odometry(noise_v=noise_v, noise_w=noise_w, confidence_scale=0.5)
    rng = np.random.default_rng(0)
    drive(odometry, turn, [], rng)
    # a turn in place moves nothing: the position variance is still 0
    assert variance(odometry) == pytest.approx(0.0, abs=1e-15)
    heading = (noise_w * turn) ** 2
    drive(odometry, turn, [ds] * n, np.random.default_rng(1))
    expected = n * (noise_v * ds) ** 2 + heading * (n * ds) ** 2
    assert variance(odometry) == pytest.approx(expected, rel=1e-9)


def test_the_first_steps_worked_one_by_one() -> None:
    # noise_v 0.1, noise_w 0.2, a turn of 0.5 rad: H = (0.2 * 0.5)^2 = 0.01
    odometry = Odometry(noise_v=0.1, noise_w=0.2, confidence_scale=1.0)
    rng = np.random.default_rng(3)
    start = Pose(0.0, 0.0, 0.0)
    odometry.reset(start)
    odometry.update(start, Pose(0.0, 0.0, 0.5), 0.1, rng)
    c, s = math.cos(0.5), math.sin(0.5)
    # 1 m: var = (0.1)^2 + 0 + 1 * 0.01 = 0.02; C = 0.01
    odometry.update(Pose(0.0, 0.0, 0.5), Pose(c, s, 0.5), 0.1, rng)
    assert variance(odometry) == pytest.approx(0.02, rel=1e-9)
    assert odometry.confidence == pytest.approx(1.0 / 1.02)
    # 2 m more: var += (0.2)^2 + 2 * 2 * 0.01 + 4 * 0.01 = 0.12, to 0.14; C = 0.03
    odometry.update(Pose(c, s, 0.5), Pose(3 * c, 3 * s, 0.5), 0.1, rng)
    assert variance(odometry) == pytest.approx(0.14, rel=1e-9)
    # the closed form agrees: 0.1^2 (1^2 + 2^2) + 0.01 (1 + 2)^2 = 0.05 + 0.09
    # 0.5 m more: var += 0.0025 + 2 * 0.5 * 0.03 + 0.25 * 0.01 = 0.035, to 0.175
    odometry.update(Pose(3 * c, 3 * s, 0.5), Pose(3.5 * c, 3.5 * s, 0.5), 0.1, rng)
    assert variance(odometry) == pytest.approx(0.175, rel=1e-9)


@settings(max_examples=50, deadline=None)
@given(noise_v=st.floats(0.0, 0.1), noise_w=st.floats(0.0, 0.1),
       turn=st.floats(-3.0, 3.0), steps=st.lists(st.floats(0.0, 0.5), max_size=30),
       seed=st.integers(0, 2**32 - 1))
def test_uneven_straight_steps_after_one_turn(noise_v: float, noise_w: float, turn: float,
                                              steps: list[float], seed: int) -> None:
    odometry = Odometry(noise_v=noise_v, noise_w=noise_w, confidence_scale=2.0)
    drive(odometry, turn, steps, np.random.default_rng(seed))
    expected = noise_v ** 2 * sum(ds * ds for ds in steps) + (noise_w * turn) ** 2 * sum(
        steps) ** 2
    assert variance(odometry) == pytest.approx(expected, rel=1e-7, abs=1e-13)
    # the noise drawn never changes the variance: it depends on the path alone
    again = Odometry(noise_v=noise_v, noise_w=noise_w, confidence_scale=2.0)
    drive(again, turn, steps, np.random.default_rng(seed + 1))
    assert again.confidence == pytest.approx(odometry.confidence, rel=1e-12)


def test_confidence_halves_when_the_deviation_reaches_the_scale() -> None:
    # one straight step of 0.5 m with noise_v 0.6: the deviation is 0.3 m, the scale 0.3 m
    odometry = Odometry(noise_v=0.6, noise_w=0.0, confidence_scale=0.3)
    drive(odometry, 0.0, [0.5], np.random.default_rng(0))
    assert odometry.confidence == pytest.approx(0.5)


def test_a_heading_error_grows_the_variance_faster_than_independent_steps() -> None:
    noisy = Odometry(noise_v=0.01, noise_w=0.05)
    drive(noisy, 1.0, [0.1] * 50, np.random.default_rng(0))
    steps_alone = 50 * (0.01 * 0.1) ** 2 + 50 * (0.1 ** 2) * (0.05 * 1.0) ** 2
    assert variance(noisy) > 10 * steps_alone


def test_reset_restores_full_confidence() -> None:
    odometry = Odometry(noise_v=0.05, noise_w=0.05)
    drive(odometry, 1.2, [0.1] * 30, np.random.default_rng(2))
    assert odometry.confidence < 1.0
    where = Pose(4.0, -1.0, 2.0)
    odometry.reset(where)
    assert odometry.confidence == 1.0
    assert odometry.pose == where
    # and the propagation starts afresh: no cross term carried over from before
    odometry.update(where, Pose(where.x + 0.2 * math.cos(2.0), where.y + 0.2 * math.sin(2.0),
                                2.0), 0.1, np.random.default_rng(0))
    assert variance(odometry) == pytest.approx((0.05 * 0.2) ** 2, rel=1e-9)


def test_noiseless_odometry_keeps_full_confidence_and_the_truth() -> None:
    odometry = Odometry()
    rng = np.random.default_rng(0)
    start = Pose(0.5, 0.5, 0.0)
    odometry.reset(start)
    poses = [start, Pose(0.5, 0.5, 1.0), Pose(0.9, 1.1, 1.0), Pose(1.0, 1.5, 2.5),
             Pose(0.2, 2.0, -3.0)]
    for before, after in itertools.pairwise(poses):
        estimate = odometry.update(before, after, 0.1, rng)
        assert odometry.confidence == 1.0
        assert (estimate.x, estimate.y, estimate.theta) == pytest.approx(
            (after.x, after.y, after.theta))
