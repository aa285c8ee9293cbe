"""The prose of the benchmarks of the case-based planners: the case graph's speed, on the Moving
AI maps and by similarity radius, and whole-path cases' speed."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from .results import FiguresError, bench
from .wording import grouped, listed, span


def retention_reading() -> str:
    """What retaining a path costs as the case graph grows, at each similarity radius, and the
    target."""
    data = bench("casegraph_retention")
    rows = data["rows"]
    first, last = rows[0], rows[-1]
    target = data["target"]
    radii = sorted(int(r) for r in target["measured_ms_by_radius"])
    growth = listed([f"δr = {r}: {first[f'median_ms_radius_{r}']:.2f} to "
                     f"{last[f'median_ms_radius_{r}']:.2f} ms" for r in radii])
    return (f"From {grouped(first['vertices'])} to {grouped(last['vertices'])} vertices a "
            f"path's retention goes from {growth} (the more of the map the graph covers, the "
            "fewer new segments a path brings). The target of at most "
            f"{target['ms_per_path']:g} ms per path at "
            f"{listed([grouped(v) for v in target['at_vertices']])} vertices is "
            f"{'met' if target['met_every_radius'] else 'not met'} at every radius. "
            "At δr > 0 eq. 12 looks only at the vertices near each new segment's first end, so "
            "no radius costs in proportion to the graph, and cutting the path into its "
            "candidate segments, the test and the writes of its segments (splitting, pricing "
            "and indexing them) are two compiled calls per path, with no Python per segment.")


def casegraph_speed_reading() -> str:
    data = bench("casegraph_speed")
    rows = {row["size"]: row for row in data["rows"]}
    targets = data["targets"]
    met = sum(target["met"] for target in targets.values())
    small, mid, large = rows[min(rows)], rows[600], rows[max(rows)]
    coverage = small["vertices"] / small["size"] ** 2
    ratios = listed([f"1/{1 / rows[size]['cbr_over_astar']:.0f} on {size}x{size}"
                     for size in sorted(rows) if size >= 600])
    pieces = large["pieces_us"]
    verdict_text = ("All" if met == len(targets) else f"{met} of the") + (
        f" {len(targets)} targets are met" if met != 1 else f" {len(targets)} targets is met")
    return (f"{verdict_text}. CBR's time hardly grows with the map "
            f"({small['cbr_ms']:.2f} ms on {small['size']}x{small['size']}, where "
            f"{data['vertices']} vertices cover {coverage * 100:.0f}% of the map and many cases "
            f"meet each neighbourhood, {mid['cbr_ms']:.2f} ms on 600x600, "
            f"{large['cbr_ms']:.2f} ms on {large['size']}x{large['size']}), while A*'s grows "
            f"with the cells it settles: CBR takes {ratios} of A*'s time on the same "
            "queries.\n\n"
            f"Where CBR's time goes ({large['size']}x{large['size']}, medians per query): "
            f"finding the cases near a terminal {pieces['cases_near']:.0f} µs, one local sweep "
            f"and its temporary edges {pieces['local_links']:.0f} µs, the whole adaptation "
            f"(both sweeps, the splits, the search of the extended graph and the path) "
            f"{pieces['adapt']:.0f} µs: a constant number of compiled calls per query, none "
            "of them in proportion to the map.")


def movingai_reading() -> str:
    results = bench("casegraph_movingai")
    rows, settings, targets = results["maps"], results["settings"], results["targets"]

    def name(row: dict[str, Any]) -> str:
        return Path(row["map"]).stem

    def over(row: dict[str, Any], hybrid: str) -> float:
        return row["decided"][hybrid]["over_solver_median"]

    recovered = sorted((row for row in rows
                        if row["cbr_share_landmarks"] - row["cbr_share"] >= 0.05),
                       key=lambda r: r["cbr_share"] - r["cbr_share_landmarks"])
    papers = max(rows, key=lambda r: r["hybrid_over_astar_median"])
    worst = max((r for r in rows if r["cbr_deviation_max_pct"] is not None),
                key=lambda r: r["cbr_deviation_max_pct"])
    loosest = min(rows, key=lambda r: r["octile_tightness_median"])
    fixed = settings["thresholds"]
    fixed_worst = max(rows, key=lambda r: over(r, "thresholds"))
    saving = sorted((row for row in rows if over(row, "learned_astar") < 0.95),
                    key=lambda r: over(r, "learned_astar"))
    jps_saving = sorted((row for row in rows if over(row, "learned_jps") < 0.95),
                        key=lambda r: over(r, "learned_jps"))
    held = [row for row in rows if row["set"] == "held out"]
    # where the thresholds tuned on these very maps save more than the learned choice
    behind = sorted((row for row in rows
                     if over(row, "thresholds") < min(0.95, over(row, "learned_astar") - 0.05)),
                    key=lambda r: over(r, "thresholds") - over(r, "learned_astar"))
    learned_worst = {hybrid: max(rows, key=lambda r, h=hybrid: over(r, h))
                     for hybrid in ("learned_astar", "learned_jps")}
    large = [row for row in rows if row["cbr_over_jps_median"] is not None
             and min(int(side) for side in row["size"].split("x")) >= 512]
    goal = targets["learned_over_solver_max"]
    jps_goal = targets["cbr_over_jps_large_max"]

    def verdict(entry: dict[str, Any]) -> str:
        return "met" if entry["met"] else "not met"

    return ("Scenario files list problems by growing length, so the retained half holds the "
            "shorter paths and the planned half the longer ones. The papers' quality test, a "
            f"path of at most {settings['max_ratio']} times the octile distance, was made for "
            "open maps: in mazes and caves the optimal paths of the longer problems are "
            "themselves longer than that (the octile distance is a median "
            f"{span([r['octile_tightness_median'] for r in rows], 2)} of the optimum, "
            f"{loosest['octile_tightness_median']:.2f} on {name(loosest)}). The landmark "
            f"bound of {settings['landmarks']} landmarks is a median "
            f"{span([r['landmark_tightness_median'] for r in rows], 2)} of the optimum on every "
            "map, and the same test against it accepts "
            + listed([f"{r['cbr_share_landmarks'] * 100:.0f}% of {name(r)}'s queries where the "
                      f"octile test accepts {r['cbr_share'] * 100:.0f}%" for r in recovered])
            + ". Accepted paths are good on average, but the octile test bounds nothing: up to "
            f"{worst['cbr_deviation_max_pct']:.0f}% above the optimum on {name(worst)} (the "
            "experience-graph reuser below bounds every path it returns).\n\n"
            "The papers' hybrid, which tries CBR on every query and tests against the octile "
            f"distance, takes up to {papers['hybrid_over_astar_median']:.1f} times A*'s median "
            f"time ({name(papers)}). The fixed thresholds (`min_cells: {fixed['min_cells']}`, "
            f"`min_distance: {fixed['min_distance']}`) with the landmark test take at most "
            f"{over(fixed_worst, 'thresholds'):.3f} times A*'s ({name(fixed_worst)}). The "
            "learned choice (`payoff: learned`), with the landmark test, takes at most "
            f"{over(learned_worst['learned_astar'], 'learned_astar'):.3f} times A*'s median "
            f"time ({name(learned_worst['learned_astar'])}) when it falls back to A*, and at "
            f"most {over(learned_worst['learned_jps'], 'learned_jps'):.3f} times jump point "
            f"search's ({name(learned_worst['learned_jps'])}) when it falls back to jps: the "
            f"target of {goal['target'].removeprefix('<= ')} is {verdict(goal)}. Its constants "
            f"were tuned on the {listed(settings['tuned_on'])} maps; on the {len(held)} maps "
            "held out of the tuning it takes at most "
            f"{max(over(r, 'learned_astar') for r in held):.3f} times A*'s and "
            f"{max(over(r, 'learned_jps') for r in held):.3f} times jps's median time. Against "
            "A* it saves time where A* is slow: "
            + (", ".join(f"{name(r)} {over(r, 'learned_astar'):.2f}" for r in saving)
               or "nowhere") + " of A*'s time; against jps "
            + (", ".join(f"{name(r)} {over(r, 'learned_jps'):.2f}" for r in jps_saving)
               or "nowhere") + ". It is safe rather than greedy: where the fixed thresholds, "
            "measured on these very maps, save more ("
            + (listed([f"{name(r)} {over(r, 'thresholds'):.2f} against "
                       f"{over(r, 'learned_astar'):.2f}" for r in behind]) if behind else "none")
            + "), the times of CBR and of A* within a distance band are spread over several "
            "modes, so the band's medians often judge CBR no cheaper and it leaves about half "
            "the band's queries to A*.\n\n"
            "Jump point search is the yardstick a user choosing a solver faces: on these maps "
            "of uniform costs it takes a median "
            f"{span([r['jps_over_astar_median'] for r in rows], 2)} of A*'s time. On the "
            f"{len(large)} maps of 512 x 512 cells and more, a CBR query answered takes "
            + listed([f"{r['cbr_over_jps_median']:.2f} of jps's time on {name(r)}"
                      for r in large])
            + f": the target of at most {jps_goal['target'].removeprefix('<= ')} is "
            f"{verdict(jps_goal)}.")


def egraph_maps() -> str:
    """One row per map for the experience-graph reuser at its default bound, beside the 9-step
    planner: share, deviation, time against A* and jump point search (with the retriever's gate
    and without it) and whether the bound held on every query."""
    from cbr_casegraph.experience_reuser import ExperienceOptions

    defaults = ExperienceOptions()
    method = f"egraph {defaults.epsilon:g}x{defaults.experience_factor:g}"
    lines = [f"| map | queries | A* ms | 9-step share | {method} share | dev. mean / max % "
             "| 9-step dev. max % | time / A* | time / JPS | reuser / A* | reuser / JPS "
             "| hybrid / A* | worst ratio (bound) | bound held |",
             "|---" * 14 + "|"]

    def ratio(value: float | None) -> str:
        return "n/a" if value is None else f"{value:.2f}"

    for row in bench("casegraph_egraph")["maps"]:
        ours, nine = row["methods"][method], row["methods"]["9-step"]
        nine_max = ("n/a" if nine["deviation_max_pct"] is None
                    else f"{nine['deviation_max_pct']:.1f}")
        dev = ("n/a" if ours["deviation_mean_pct"] is None else
               f"{ours['deviation_mean_pct'] + 0.0:.2f} / {ours['deviation_max_pct']:.1f}")
        worst = "n/a" if ours["worst_ratio"] is None else f"{ours['worst_ratio']:.3f}"
        lines.append(f"| {Path(row['map']).stem} | {row['queries']} "
                     f"| {row['astar_ms_median']:.3f} | {nine['share']:.3f} "
                     f"| {ours['share']:.3f} | {dev} | {nine_max} "
                     f"| {ratio(ours['over_astar_median'])} | {ratio(ours['over_jps_median'])} "
                     f"| {ratio(ours['reuser_over_astar_median'])} "
                     f"| {ratio(ours['reuser_over_jps_median'])} "
                     f"| {ours['hybrid_over_astar_median']:.3f} | {worst} ({ours['bound']:.3f}) "
                     f"| {'yes' if ours['bound_held'] else '**no**'} |")
    return "\n".join(lines)


def egraph_reading() -> str:
    data = bench("casegraph_egraph")
    pooled = data["pooled"]
    nine = pooled["9-step"]
    graphs = {name: m for name, m in pooled.items() if name != "9-step"}
    held = all(m["bound_held"] for row in data["maps"] for name, m in row["methods"].items()
               if name != "9-step")
    from cbr_casegraph.experience_reuser import ExperienceOptions

    defaults = ExperienceOptions()
    name = f"egraph {defaults.epsilon:g}x{defaults.experience_factor:g}"
    ours = graphs[name]
    per_map = [(Path(row["map"]).stem, row["methods"][name]) for row in data["maps"]
               if row["methods"][name]["reuser_over_astar_median"] is not None]
    reuser = max(m["reuser_over_astar_median"] for _, m in per_map)
    gated = max(per_map, key=lambda item: item[1]["over_astar_median"])
    return (("The bound held on every query of every map for every (ε, ε^E) measured. "
             if held else "**The bound failed on some query.** ")
            + f"At the default ε = {defaults.epsilon:g}, ε^E = {defaults.experience_factor:g} "
            f"(bound {ours['bound']:.3f}) the experience graph answers "
            f"{ours['share'] * 100:.0f}% of the queries against the 9-step planner's "
            f"{nine['share'] * 100:.0f}% behind the same retriever, every path accepted on its "
            f"guarantee, with a largest deviation of {ours['deviation_max_pct']:.1f}% against "
            f"{nine['deviation_max_pct']:.1f}% (mean {ours['deviation_mean_pct']:.2f}% against "
            f"{nine['deviation_mean_pct']:.2f}%), in a median {ours['over_astar_median']:.2f} of "
            f"A*'s time against {nine['over_astar_median']:.2f} "
            f"({ours['over_jps_median']:.2f} of jump point search's). The reuser alone, the "
            f"retriever's gate left out, takes at most {reuser:.2f} of A*'s time (median) on "
            f"any map: the target of 1.1 is {'met' if reuser <= 1.1 else 'not met'}. With the "
            f"gate the most is {gated[1]['over_astar_median']:.2f} ({gated[0]}), where a "
            f"query of A* takes {_astar_ms(data, gated[0]):.3f} ms and the gate (deciding "
            f"whether the case graph is used, paid by either reuser) "
            f"{gated[1]['gate_over_astar_median']:.2f} of it. "
            f"At ε = ε^E = 1 every path is optimal, in "
            f"{graphs['egraph 1x1']['over_astar_median']:.2f} of A*'s time; looser bounds than "
            "max_ratio fall back to the octile test and answer fewer.")


def _astar_ms(data: dict, stem: str) -> float:
    return next(row["astar_ms_median"] for row in data["maps"] if Path(row["map"]).stem == stem)


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
            "near-duplicates cost more per pair. Retrieval, from "
            f"{grouped(mid['size'])} paths on, grows about {per_path:.0f} ns per stored path "
            f"(four numpy distance calls over the end points), {big['retrieve_us'] / 1000:.2f} ms "
            f"at {grouped(big['size'])} paths, beside {data['astar_ms_mean']:.1f} ms for one A* "
            "query on this map (mean).\n\n" + _pathcases_retention(data))


def _pathcases_retention(data: dict[str, Any]) -> str:
    """The retainer's own comparison through the index of stored cells, and the target."""
    rows = sorted(data["retention"], key=lambda row: row["size"])
    largest = rows[-1]
    target = data["retention_target"]
    mismatches = sum(row["mismatches"] for row in rows)
    return ("The retainer does not run that kernel over every stored path: an index of the "
            "8x8-cell squares each stored path passes through hands it only the paths near both "
            "ends of the new path (a median of "
            f"{span([row['candidates_median'] for row in rows], 0)} candidates from "
            f"{grouped(rows[0]['size'])} to {grouped(largest['size'])} stored paths), and "
            + ("finds exactly what the kernel over every path finds" if mismatches == 0 else
               f"disagrees with the kernel over every path {mismatches} times")
            + f". The comparison then takes {span([row['indexed_ms'] for row in rows], 2)} ms "
            f"against {span([row['every_path_ms'] for row in rows], 1)} ms over every path (plus "
            f"{largest['concatenate_ms']:.0f} ms at {grouped(largest['size'])} paths for the "
            "concatenation of all stored cells it no longer redoes after each write). The whole "
            "retain hook, one learn step per path without the A* of the path's ideal cost, takes "
            f"{span([row['retain_without_ideal_ms'] for row in rows], 2)} ms: the target of at "
            f"most {target['ms_per_path']:g} ms per path at {grouped(target['at_paths'])} paths "
            f"is {'met' if target['met'] else 'not met'} ({target['measured_ms']:.2f} ms).")


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
