"""The route graph the grid page shows: a case graph learned on Nav2's depot, exported for
Nav2's Route Server and drawn over the map.

``python benchmarks/figures.py --keep-route-graph`` runs ``configs/ros_depot_route.yaml`` in a
scratch folder with the commands the page gives (``cbr run``, then ``cbr casebase export
--config ... --format nav2-route``), keeps the route graph and the run's summary in
``docs/figures/depot-route-graph.json`` with the commit, and draws ``docs/img/
depot_route_graph.png`` from what it kept. The page's blocks quote the kept file.
"""

from __future__ import annotations

import json
import subprocess
import sys
import tempfile
from pathlib import Path
from typing import Any

from .keep import commit_kept
from .provenance import imported_units, stamped
from .results import DOCS, KEPT, ROOT, FiguresError, load_json

ROUTE_GRAPH = "depot-route-graph"
CONFIG = ROOT / "configs" / "ros_depot_route.yaml"
IMAGE = DOCS / "img" / "depot_route_graph.png"
_SUMMARY = ("queries", "from_casebase", "from_solver", "cbr_share", "success_rate")


def _cbr(*args: str, cwd: Path) -> None:
    done = subprocess.run([sys.executable, "-m", "cbrcore", *args], cwd=cwd,
                          capture_output=True, text=True, check=False)
    if done.returncode:
        raise FiguresError(f"cbr {' '.join(args[:2])} failed: {done.stderr.strip()}")


def keep_route_graph() -> Path:
    """Run the depot configuration, keep its exported route graph and summary, draw it."""
    with tempfile.TemporaryDirectory() as scratch:
        work = Path(scratch)
        _cbr("run", str(CONFIG), cwd=work)
        _cbr("casebase", "export", "--config", str(CONFIG), "--format", "nav2-route", "-o",
             "depot.geojson", cwd=work)
        summary = json.loads((work / "runs" / CONFIG.stem / "summary.json").read_text())
        graph = json.loads((work / "depot.geojson").read_text())
    data = stamped({"config": CONFIG.relative_to(ROOT).as_posix(),
                    "summary": {key: summary[key] for key in _SUMMARY}, "route_graph": graph},
                   "python benchmarks/figures.py --keep-route-graph",
                   # what `cbr run` and `cbr casebase export` import for the case graph
                   unit_names=imported_units(["cbrcore.run", "cbrcore.cli", "cbr_casegraph"]))
    target = commit_kept(f"{ROUTE_GRAPH}.json", data)
    draw(data)
    return target


def _parts(graph: dict[str, Any]) -> tuple[dict[int, list[float]], list[dict[str, Any]]]:
    """The nodes' points by id, and the edges' properties."""
    features = graph["features"]
    points = {f["properties"]["id"]: f["geometry"]["coordinates"] for f in features
              if f["geometry"]["type"] == "Point"}
    return points, [f["properties"] for f in features if f["geometry"]["type"] != "Point"]


def draw(data: dict[str, Any]) -> None:
    """The route graph over the depot as the run saw it (inflated), each segment drawn once,
    the darker the more paths reused it."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from cbr_grid.plot import draw_grid
    from cbrcore.config import Config, load_config
    from cbrcore.engine import Engine
    from cbrcore.plugins import current

    config = load_config(CONFIG, current().registry)
    # the world alone: the map as the run saw it is all the picture needs
    with Engine(Config(seed=config.seed, world=config.world, source=config.source)) as engine:
        figure = draw_grid(engine.world)
    axes = figure.axes[0]
    points, edges = _parts(data["route_graph"])
    most = max((e["metadata"]["cbr"]["uses"] for e in edges), default=0) or 1
    drawn = set()
    for edge in edges:
        pair = frozenset((edge["startid"], edge["endid"]))
        if pair in drawn:
            continue
        drawn.add(pair)
        (x0, y0), (x1, y1) = points[edge["startid"]][:2], points[edge["endid"]][:2]
        shade = 0.25 + 0.75 * edge["metadata"]["cbr"]["uses"] / most
        axes.plot([x0, x1], [y0, y1], color=(0.1, 0.3, 0.8, shade), linewidth=1.6)
    xs, ys = zip(*(p[:2] for p in points.values()), strict=True)
    axes.plot(xs, ys, "o", color="#d95f02", markersize=2.5, label="nodes")
    axes.set_title(f"{len(points)} nodes, {len(edges)} edges (one each way)")
    figure.set_size_inches(10, 5.6)
    figure.savefig(IMAGE, dpi=110, bbox_inches="tight")
    plt.close(figure)


def route_graph_reading() -> str:
    """What the run learned and what its route graph holds, with the commit that made it."""
    data = load_json(KEPT / f"{ROUTE_GRAPH}.json")
    summary = data["summary"]
    points, edges = _parts(data["route_graph"])
    reused = sum(1 for e in edges if e["metadata"]["cbr"]["uses"] > 0)
    return (f"A run of `{data['config']}` ({summary['queries']} trips, "
            f"{summary['from_casebase']} of them planned from the case graph) exports a route "
            f"graph of {len(points)} nodes and {len(edges)} edges, one each way along each of "
            f"the case graph's {len(edges) // 2} segments; {reused} of the edges were driven "
            f"again after they were learned. Kept by `{data['command']}` at commit "
            f"{data['commit'][:12]}.")
