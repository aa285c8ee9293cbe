from cbrcore import Engine

overrides = {"casebase": "memory", "workload.count": 50}  # no case base file, 50 trips
with Engine.from_yaml("configs/hybrid_grid.yaml", overrides=overrides) as engine:
    for problem in engine.workload.queries(engine.ctx):
        proposal = engine.solve(problem)       # retrieve -> reuse -> revise (-> fallback solver)
        outcome = engine.workload.execute(problem, proposal, engine.ctx)   # or your robot
        engine.learn(problem, proposal, outcome)   # retain -> forget, one transaction
    print(engine.stats.as_dict())
