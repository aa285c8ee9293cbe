"""Every block the pages may hold: its name, the results file its figures come from and what
renders it."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from pathlib import Path

import attrs

from . import case_benchmarks as cases
from . import casegraph_experiments as casegraph
from . import fleet_experiment as fleet
from . import landmark_experiments as landmarks
from . import layers, route_graph
from . import pathcases_experiments as pathcases
from . import recording_benchmarks as recording
from . import ros2005_baseline as baseline
from . import rupart_experiments as delivery
from . import solver_benchmarks as solvers
from . import world2d_benchmarks as world2d
from .results import KEPT, RESULTS, ROOT, kept, result_md, table


@attrs.frozen
class Block:
    """A generated block: what renders it and the results file its figures come from."""

    name: str
    source: Path
    render: Callable[[], str]


def bench_tables(benchmark: str, *indices: int) -> Callable[[], str]:
    """Tables ``indices`` of a benchmark's markdown results, whole, a blank line apart."""
    return lambda: "\n\n".join(table(result_md(benchmark), k) for k in indices)


def bench_columns(benchmark: str, index: int, columns: Sequence[str]) -> Callable[[], str]:
    """Table ``index`` of a benchmark's markdown results, with only ``columns``."""
    return lambda: table(result_md(benchmark), index, columns)


def experiment_table(experiment: str, index: int) -> Callable[[], str]:
    """Table ``index`` of the results.md an experiment's run wrote."""
    return lambda: table(kept(experiment)["table"], index)


def _bench(name: str, results: str, render: Callable[[], str]) -> Block:
    """Block ``name``, rendered from ``benchmarks/results/<results>``."""
    return Block(name, RESULTS / results, render)


def _experiment(name: str, experiment: str, render: Callable[[], str]) -> Block:
    """Block ``name``, rendered from an experiment's kept results."""
    return Block(name, KEPT / f"{experiment}.json", render)


def _blocks() -> list[Block]:
    return [
        Block("layers-reading", ROOT / layers.KEPT_NAME, layers.reading),
        _bench("engine-overhead", "engine_overhead.md", bench_tables("engine_overhead", 0)),
        _bench("cli-startup", "cli_startup.md", bench_tables("cli_startup", 0)),
        _bench("solvers-maps", "solvers.md", solvers.solvers_maps),
        _bench("solvers-pooled", "solvers.md", solvers.solvers_pooled),
        _bench("search-loop", "search_loop.md", bench_tables("search_loop", 0)),
        _bench("search-loop-reading", "search_loop.json", solvers.search_loop_reading),
        _bench("genetic", "genetic.md", bench_tables("genetic", 0)),
        _bench("memory", "memory.md", bench_tables("memory", 0)),
        _bench("memory-reading", "memory.json", solvers.memory_reading),
        _bench("casegraph-speed", "casegraph_speed.md", bench_tables("casegraph_speed", 0, 1)),
        _bench("casegraph-retention", "casegraph_retention.md",
               bench_tables("casegraph_retention", 0)),
        _bench("casegraph-retention-reading", "casegraph_retention.json",
               cases.retention_reading),
        _bench("casegraph-movingai", "casegraph_movingai.md",
               bench_tables("casegraph_movingai", 0, 1, 2)),
        _bench("casegraph-egraph", "casegraph_egraph.md", bench_tables("casegraph_egraph", 0)),
        _bench("casegraph-egraph-maps", "casegraph_egraph.json", cases.egraph_maps),
        _bench("casegraph-egraph-reading", "casegraph_egraph.json", cases.egraph_reading),
        _bench("pathcases-speed", "pathcases_speed.md",
               bench_tables("pathcases_speed", 0, 1, 2, 3)),
        _bench("world2d-speed", "world2d_speed.md", bench_tables("world2d_speed", 0, 1)),
        _bench("landmarks-retrieval", "landmarks_retrieval.md",
               bench_columns("landmarks_retrieval", 0,
                             ["matching", "search", "median ms per query", "p90 ms",
                              "equal to the scan"])),
        _bench("landmarks-retrieval-by-size", "landmarks_retrieval.md",
               bench_tables("landmarks_retrieval", 1)),
        _bench("landmarks-consultation", "landmarks_consultation.md",
               bench_tables("landmarks_consultation", 0, 1, 2)),
        _bench("rupart-retrieval", "rupart_retrieval.md",
               bench_columns("rupart_retrieval", 0, ["what", "median ms per query", "p90 ms"])),
        _bench("rupart-ceiling", "rupart_ceiling.md", bench_tables("rupart_ceiling", 0)),
        _bench("landmarks-config", "landmarks_config.md", bench_tables("landmarks_config", 0)),
        _bench("landmarks-config-reading", "landmarks_config.json",
               world2d.landmarks_config_reading),
        _bench("kinematics-pooled", "kinematics_speed.md",
               bench_columns("kinematics_speed", 1,
                             ["model", "solved", "edge A* / A*", "edge Dijkstra / A*",
                              "exhaustive", "cost / optimum (median, max)"])),
        _bench("experiment-sweep", "experiment_sweep.md", solvers.experiment_sweep),
        _bench("engine-overhead-reading", "engine_overhead.json", solvers.engine_overhead_reading),
        _bench("recording-cost", "recording_cost.md", bench_tables("recording_cost", 0)),
        _bench("recording-cost-reading", "recording_cost.json",
               recording.recording_cost_reading),
        _bench("solvers-targets", "solvers.json", solvers.solvers_targets),
        _bench("genetic-reading", "genetic.json", solvers.genetic_reading),
        _bench("casegraph-speed-reading", "casegraph_speed.json", cases.casegraph_speed_reading),
        _bench("casegraph-movingai-reading", "casegraph_movingai.json", cases.movingai_reading),
        _bench("pathcases-speed-reading", "pathcases_speed.json", cases.pathcases_speed_reading),
        _bench("kinematics-reading", "kinematics_speed.json", solvers.kinematics_reading),
        _bench("kinematics-summary", "kinematics_speed.json", solvers.kinematics_summary),
        _bench("world2d-tour", "world2d_speed.json", world2d.world2d_tour),
        _bench("world2d-irsim-path", "world2d_speed.json", world2d.world2d_irsim_path),
        _bench("world2d-reading", "world2d_speed.json", world2d.world2d_reading),
        _bench("landmarks-retrieval-reading", "landmarks_retrieval.json",
               world2d.landmarks_retrieval_reading),
        _bench("landmarks-retrieval-notes", "landmarks_retrieval.json",
               world2d.landmarks_retrieval_notes),
        _bench("rupart-retrieval-reading", "rupart_retrieval.json",
               world2d.rupart_retrieval_reading),
        _bench("rupart-retrieval-agreement", "rupart_retrieval.json",
               world2d.rupart_retrieval_agreement),
        _bench("rupart-retrieval-by-size", "rupart_retrieval.md",
               world2d.rupart_retrieval_by_size),
        _experiment("ros2005-baseline-output", baseline.BASELINE, baseline.baseline_output),
        _experiment("ros2005-baseline-table", baseline.BASELINE, baseline.baseline_table),
        _experiment("ros2005-baseline-reading", baseline.BASELINE, baseline.baseline_reading),
        _experiment("ros2005-baseline-world2d", baseline.BASELINE, baseline.baseline_world2d),
        _experiment("landmark-scenarios-table", "landmark-scenarios", landmarks.scenarios_table),
        _experiment("landmark-scenarios-reading", "landmark-scenarios",
                    landmarks.scenarios_reading),
        _experiment("landmark-scenarios-differences", "landmark-scenarios",
                    landmarks.scenarios_differences),
        _experiment("landmark-scenarios-in-short", "landmark-scenarios",
                    landmarks.scenarios_in_short),
        _experiment("landmark-scenarios-robustness", "landmark-scenarios",
                    landmarks.scenarios_robustness),
        _experiment("path-cases-learning-header", "path-cases-learning",
                    pathcases.learning_header),
        _experiment("path-cases-learning-paired", "path-cases-learning",
                    pathcases.learning_paired),
        _experiment("path-cases-learning-reading", "path-cases-learning",
                    pathcases.learning_reading),
        _experiment("landmark-learning-setup", "landmark-learning", landmarks.learning_setup),
        _experiment("landmark-learning-tables", "landmark-learning", landmarks.learning_tables),
        _experiment("landmark-learning-reading", "landmark-learning",
                    landmarks.learning_reading),
        _experiment("rupart-delivery-header", "rupart-delivery", delivery.delivery_header),
        _experiment("rupart-delivery-table", "rupart-delivery",
                    experiment_table("rupart-delivery", 0)),
        _experiment("rupart-delivery-paired", "rupart-delivery",
                    experiment_table("rupart-delivery", 1)),
        _experiment("rupart-delivery-learning", "rupart-delivery",
                    experiment_table("rupart-delivery", 2)),
        _experiment("rupart-delivery-empty", "rupart-delivery",
                    experiment_table("rupart-delivery", 3)),
        _experiment("rupart-delivery-ablation", "rupart-delivery",
                    experiment_table("rupart-delivery", 4)),
        _experiment("rupart-delivery-reading", "rupart-delivery", delivery.delivery_reading),
        _bench("similarity-radius", "casegraph_similarity_radius.md",
               bench_tables("casegraph_similarity_radius", 0)),
        _bench("similarity-radius-reproductions", "casegraph_similarity_radius.json",
               cases.radius_reproductions),
        _bench("similarity-radius-casegraph", "casegraph_similarity_radius.json",
               cases.radius_casegraph),
        _experiment("deviation-against-paper", "deviation-table",
                    casegraph.deviation_against_paper),
        _experiment("map-size-reading", "time-vs-map-size", casegraph.map_size_reading),
        _experiment("vertices-reading", "time-vs-vertices", casegraph.vertices_reading),
        _experiment("cbr-share-growth", "cbr-share", casegraph.share_growth),
        _experiment("cbr-share-failures", "cbr-share", casegraph.share_failures),
        _experiment("deviation-differences", "deviation-table", casegraph.deviation_differences),
        _experiment("cbr-share-against-paper", "cbr-share", casegraph.share_against_paper),
        _experiment("fleet-reading", "fleet", fleet.fleet_reading),
        _experiment("depot-route-graph-reading", route_graph.ROUTE_GRAPH,
                    route_graph.route_graph_reading),
        *[_experiment(f"{name}-table-{k + 1}", name, experiment_table(name, k))
          for name, count in (("cbr-share", 1), ("deviation-table", 2),
                              ("path-cases-learning", 2),
                              ("time-vs-map-size", 1), ("time-vs-vertices", 1),
                              ("fleet", 1))
          for k in range(count)],
    ]


BLOCKS = {block.name: block for block in _blocks()}
