"""The prose of the benchmarks of the case-based planners: the case graph's speed, on the Moving
AI maps and by similarity radius, and whole-path cases' speed."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from .results import FiguresError, bench
from .wording import grouped, listed, span


def retention_reading() -> str:
    """What retaining a path costs as the case graph grows, and the target."""
    data = bench("casegraph_retention")
    rows = data["rows"]
    first, last = rows[0], rows[-1]
    target = data["target"]
    return (f"From {grouped(first['vertices'])} to {grouped(last['vertices'])} vertices a "
            f"path's retention at δr = 0 goes from {first['median_ms_radius_0']:.2f} to "
            f"{last['median_ms_radius_0']:.2f} ms, while at δr = 1, which compares each new "
            f"segment with every stored one, it goes from {first['median_ms_radius_1']:.2f} to "
            f"{last['median_ms_radius_1']:.2f} ms (the more of the map the graph covers, the "
            f"fewer new segments a path brings). The target of at most "
            f"{target['ms_per_path']:g} ms per path at {grouped(target['at_vertices'])} "
            f"vertices is {'met' if target['met'] else 'not met'}; what is left at δr = 0 is "
            "the work on the path's own segments (cutting, splitting and pricing them), in "
            "Python per segment.")


def casegraph_speed_reading() -> str:
    data = bench("casegraph_speed")
    rows = {row["size"]: row for row in data["rows"]}
    targets = data["targets"]
    met = sum(target["met"] for target in targets.values())
    small, mid, large = rows[min(rows)], rows[600], rows[max(rows)]
    coverage = small["vertices"] / small["size"] ** 2
    mid_target = targets["cbr_over_astar_600"]
    goal = float(mid_target["target"].split()[-1])
    verdicts = {0: "None of the three targets is met", 1: "One of the three targets is met",
                2: "Two of the three targets are met", 3: "All three targets are met"}
    sweep = profile_per_call(large["profile"], "_propagate")[1]
    search = profile_per_call(large["profile"], "graph_search")[1]
    adapt = [line for line in large["profile"].splitlines() if line.rstrip().endswith("(adapt)")]
    if not adapt:
        raise FiguresError("casegraph_speed.json: the profile has no line for adapt")
    fields = adapt[0].split()
    per_query = float(fields[3]) * 1000 / int(fields[0])
    return (f"{verdicts[met]}. CBR's time does not grow with the "
            f"map ({small['cbr_ms']:.1f} ms on {small['size']}x{small['size']}, where "
            f"{data['vertices']} vertices cover {coverage * 100:.0f}% of the map and many cases "
            f"meet each neighbourhood, {large['cbr_ms']:.1f} ms on "
            f"{large['size']}x{large['size']}), and on {large['size']}x{large['size']} CBR "
            f"takes 1/{1 / large['cbr_over_astar']:.0f} of A*'s time on the same queries. On "
            f"600x600 it takes 1/{1 / mid['cbr_over_astar']:.0f}, "
            + (f"short of the 1/{1 / goal:.0f} target" if not mid_target["met"]
               else f"within the 1/{1 / goal:.0f} target")
            + f": A* needs {mid['astar_ms']:.0f} ms there, CBR {mid['cbr_ms']:.1f} ms.\n\n"
            "Where CBR's time goes (the profile in the JSON, "
            f"{large['size']}x{large['size']}: {per_query:.1f} ms per query under the "
            "profiler): the two local Dijkstra sweeps that make the temporary edges (compiled, "
            "stopped once every case cell in the neighbourhood is settled, about "
            f"{sweep:.2f} ms each), the compiled search of the extended graph ({search:.2f} ms), "
            "and the NumPy and Python around them (finding the cases, building the per-query "
            "overlay, tracing and joining the path). No part depends on the map's size"
            + ("; reaching the target on 600x600 would need the whole query in compiled code."
               if not mid_target["met"] else "."))


def profile_per_call(profile: str, function: str) -> tuple[int, float]:
    """Calls and milliseconds per call of ``function`` (its own time) in a cProfile listing."""
    for line in profile.splitlines():
        fields = line.split()
        if len(fields) >= 6 and fields[-1].endswith(f"({function})"):
            calls = int(fields[0].split("/")[0])
            return calls, float(fields[1]) * 1000 / calls
    raise FiguresError(f"casegraph_speed.json: the profile has no line for {function}")


def movingai_reading() -> str:
    rows = bench("casegraph_movingai")["maps"]
    settings = bench("casegraph_movingai")["settings"]

    def name(row: dict[str, Any]) -> str:
        return Path(row["map"]).stem

    most = [row for row in rows if row["cbr_share"] >= 0.5]
    fewer = sorted((row for row in rows if row["cbr_share"] < 0.5), key=lambda r: r["cbr_share"])
    timed = [row for row in rows if row["cbr_over_astar_median"] is not None]
    faster = sorted((row for row in timed if row["cbr_over_astar_median"] < 1),
                    key=lambda r: r["cbr_over_astar_median"])
    slower = [row for row in timed if row["cbr_over_astar_median"] >= 1]
    text = ("Scenario files list problems by growing length, so the retained half holds the "
            "shorter paths and the planned half the longer ones. CBR answers "
            f"{span([r['cbr_share'] * 100 for r in most], 0)}% of the queries on "
            f"{len(most)} of the {len(rows)} maps ({listed([name(r) for r in most])}), at a "
            "mean cost deviation from the optimal length of "
            f"{span([r['cbr_deviation_mean_pct'] for r in most], 1)}% (median "
            f"{span([r['cbr_deviation_median_pct'] for r in most], 1)}%). On the others it "
            "answers fewer: "
            + listed([f"{name(r)} {r['cbr_share'] * 100:.0f}%" for r in fewer])
            + ". The quality test of the papers, made for open maps, accepts a path of at most "
            f"{settings['max_ratio']} times the octile distance, and in mazes and narrow caves "
            "the optimal paths of the longer problems are themselves longer than that, so the "
            "test rejects them whoever plans them. CBR is faster than A* where A* is slow ("
            + ", ".join(f"{name(r)}: {r['cbr_over_astar_median']:.2f}" for r in faster)
            + "); where A* takes "
            f"{span([r['astar_ms_median'] for r in slower], 1)} ms, CBR's "
            f"{span([r['cbr_ms_median'] for r in slower], 1)} ms of fixed cost dominates.")
    return text


def pathcases_speed_reading() -> str:
    data = bench("pathcases_speed")
    retain, retrieve = data["retain"], data["retrieve"]
    mismatches = sum(sum(row["mismatches"].values()) for row in retain)
    anchors = ("brute", "pruned", "kdtree")
    scipy = [1 / row["ours_over"]["scipy"] for row in retain]
    others = [1 / row["ours_over"][k] for row in retain for k in anchors]
    limit = [1 / row["ours_over"]["ours_inf"] for row in retain]
    exact = [1 / row["ours_over"]["ours_inf_over_scipy"] for row in retain]
    boxes = [row["boxes_within_limit_median"] / row["size"] * 100 for row in retain]
    pruning = [(1 - row["ms"]["pruned"] / row["ms"]["brute"]) * 100 for row in retain]
    similar = {row["similar_total"] for row in retain}
    largest = max(retain, key=lambda row: row["size"])
    big = max(retrieve, key=lambda row: row["size"])
    mid = sorted(retrieve, key=lambda row: row["size"])[-2]
    per_path = (big["retrieve_us"] - mid["retrieve_us"]) / (big["size"] - mid["size"]) * 1000
    fastest = all(row["ours_over"][k] < 1 for row in retain for k in ("scipy", *anchors))
    similar_text = (f"Only {similar.pop()} of the {data['queries']} new paths per size had"
                    if len(similar) == 1 else
                    f"{span([row['similar_total'] for row in retain], 0)} of the "
                    f"{data['queries']} new paths per size had")
    return (("All methods agree on every pair (no mismatch). " if mismatches == 0 else
             f"The methods disagree on {mismatches} pairs. ")
            + ("Our kernel is faster than every anchor at every size: " if fastest else
               "Our kernel against the anchors: ")
            + f"{span(scipy, 0)} times faster than the scipy loop and "
            f"{span(others, 0)} times faster than the brute forces and the KD-trees, growing "
            f"linearly with the stored cells ({largest['ms']['ours']:.0f} ms for "
            f"{grouped(largest['size'])} paths). A factor of {span(limit, 0)} of that comes "
            f"from the limit (the exact kernel is still {span(exact, 0)} times faster than the "
            "scipy loop, which pays a Python call and a shuffle per pair). The limit works "
            f"through the early stop, not the bounding boxes: on this map {span(boxes, 0)}% of "
            f"the stored paths' boxes come within {data['limit']:g} cells of the new path's box, "
            f"and pruning by boxes saves the brute force only {span(pruning, 0)}%. "
            f"{similar_text} a stored path within the limit, which is the common case while "
            "the robot still meets new tasks; a pair within the limit cannot stop at it, so "
            "near-duplicates cost more per pair. Two costs outside the kernel grow too: "
            "concatenating the stored paths again after a step that added or forgot one takes "
            f"{largest['concatenate_ms']:.0f} ms at {grouped(largest['size'])} paths, "
            f"{largest['concatenate_ms'] / largest['ms']['ours'] * 100:.0f}% of the comparison "
            f"itself, and retrieval, from {grouped(mid['size'])} paths on, grows about "
            f"{per_path:.0f} ns per stored path (four numpy distance calls over the end points), "
            f"{big['retrieve_us'] / 1000:.2f} ms at {grouped(big['size'])} paths, beside "
            f"{data['astar_ms_mean']:.1f} ms for one A* query on this map (mean). The papers' "
            "case bases are far smaller (a capacity of tens of paths); a spatial index of the "
            "end points is left for case bases of tens of thousands.")


def _radius_row(radius: int, coverage: float) -> dict[str, Any]:
    rows = bench("casegraph_similarity_radius")["rows"]
    for row in rows:
        if row["radius"] == radius and round(row["coverage"] * 100) == coverage:
            return row
    raise FiguresError(f"casegraph_similarity_radius.json has no row for δr = {radius} at "
                       f"{coverage}% coverage")


def radius_reproductions() -> str:
    """The similarity radius sentence of the reproductions page."""
    ten, fifteen = _radius_row(1, 10), _radius_row(1, 15)
    base_ten, base_fifteen = _radius_row(0, 10), _radius_row(0, 15)
    return (f"**The similarity radius matters most.** With eq. 12 at δr = 1, CBR's cost "
            f"deviation is {ten['cost_deviation']:.1f}% at 10% coverage and "
            f"{fifteen['cost_deviation']:.1f}% at 15% on the same map (δr = 0: "
            f"{base_ten['cost_deviation']:.1f}% and {base_fifteen['cost_deviation']:.1f}%; "
            "`python benchmarks/casegraph_similarity_radius.py --size full`): staircase paths "
            "lose every other step to the similarity test and the graph search has to detour "
            "around the gaps. The default δr = 0 keeps them (see "
            "[the case graph page](casegraph.md)).")


def radius_casegraph() -> str:
    """The similarity radius sentence of the case graph page."""
    rows = {r: _radius_row(r, 10) for r in (0, 1, 2)}
    shares = ", ".join(f"{rows[r]['cbr_share']:.3f}" for r in rows)
    return (f"On the reproductions' 200x200 map, at {rows[0]['target_vertices']} vertices (10% "
            f"coverage), CBR's mean cost deviation from the optimum is "
            f"{rows[0]['cost_deviation']:.1f}% with δr = 0, {rows[1]['cost_deviation']:.1f}% "
            f"with δr = 1 and {rows[2]['cost_deviation']:.1f}% with δr = 2 (CBR shares "
            f"{shares}; `python benchmarks/casegraph_similarity_radius.py --size full`, the "
            "setting of the [deviation table](reproductions.md#deviations-from-the-best-path-"
            "section-64-table-1-and-fig-5)).")
