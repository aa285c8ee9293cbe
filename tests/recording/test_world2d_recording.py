"""The 2D world's recording: when doors change and how the sonar ring becomes a scan."""

from __future__ import annotations

import math

import numpy as np
from hypothesis import given
from hypothesis import strategies as st

from cbr_world2d.recording import RAYS, _beam_table, _next_change
from cbr_world2d.sensors import SonarRing
from cbr_world2d.world import Door


@given(period=st.floats(2.0, 60.0), share=st.floats(0.05, 0.95), phase=st.floats(0.0, 60.0),
       t=st.floats(0.0, 1000.0))
def test_a_door_keeps_its_state_until_its_next_change(period: float, share: float,
                                                      phase: float, t: float) -> None:
    door = Door((0.0, 0.0), (1.0, 0.0), period=period, open_for=share * period, phase=phase)
    change = _next_change(door, t)
    assert t < change <= t + period
    state = door.is_open(t)
    for u in np.linspace(t, change, 40, endpoint=False):
        assert door.is_open(float(u)) == state
    assert door.is_open(change + 1e-6 * period) != state


def test_every_ray_inside_a_beam_reads_the_nearest_covering_beam() -> None:
    sonar = SonarRing()
    table = _beam_table(sonar)
    readings = np.append(np.linspace(0.5, 4.0, len(sonar.angles)), np.inf)
    ranges = readings[table].min(axis=1)
    for ray in range(RAYS):
        angle = -math.pi + ray * 2 * math.pi / RAYS
        covering = [readings[b] for b, beam in enumerate(sonar.angles)
                    if abs(math.remainder(angle - beam, 2 * math.pi))
                    <= sonar.beam_width / 2 + 1e-9]
        assert ranges[ray] == min(covering, default=math.inf)
