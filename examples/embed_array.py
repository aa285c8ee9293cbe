"""Plan on your own occupancy grid: a NumPy array handed to the engine, no files at all."""

import numpy as np

from cbr_grid import GridQuery
from cbrcore import Engine, Outcome

# 200 x 200 cells, indexed [y, x]; True is an obstacle. Two walls, each with a doorway.
occupancy = np.zeros((200, 200), dtype=bool)
occupancy[:, 66] = True
occupancy[90:110, 66] = False
occupancy[:, 133] = True
occupancy[20:40, 133] = False

config = {
    "retrieve": {"use": "casegraph", "delta": 8},
    "reuse": "casegraph",
    # without a reviser every reused path is taken as it is, however long
    "revise": {"use": "path_quality", "ideal": "landmarks", "max_ratio": 1.5},
    "solver": "astar",
    "retain": ["casegraph"],
    "forget": ["redundant_vertices"],
}
trips = [GridQuery((10, 100), (190, 30)), GridQuery((12, 102), (188, 32)),
         GridQuery((190, 30), (10, 100)), GridQuery((8, 98), (191, 28))]

with Engine.from_dict(config, world=occupancy) as engine:
    for query in trips:
        proposal = engine.solve(query)
        # the robot drives the path; here it arrives, at the planned cost
        outcome = Outcome(success=True, cost=proposal.solution.cost)
        engine.learn(query, proposal, outcome)
        print(f"{query.start} -> {query.goal}: {proposal.source}, "
              f"cost {proposal.solution.cost:.1f}, {len(proposal.solution.value)} cells")
    print(engine.stats.as_dict())
