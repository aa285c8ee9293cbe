"""The prose of the benchmarks of the engine's overhead and of the model-based planners: the grid
searches against other libraries, the genetic planner and the nonholonomic searches."""

from __future__ import annotations

import statistics
from collections import Counter
from typing import Any

from .results import FiguresError, bench, paragraphs, records, result_md, table
from .wording import about, grouped, listed, span, verdict


def engine_overhead_reading() -> str:
    data = bench("engine_overhead")
    return (f"The engine adds about {data['engine_overhead_us']:.0f} µs per query: negligible "
            "beside a grid planner's milliseconds, and the reason hooks are called once per "
            "query, never per cell or per case pair.")


def search_loop_reading() -> str:
    data = bench("search_loop")
    ratios = [row["one_loop_over_kernel"] for row in data["rows"]]
    return (f"Written once, the loop takes {span(ratios, 2)}x the time of the kernels written "
            "for their graph, on the same queries and with the same costs. So each search keeps "
            "its own loop and they share the heap (`cbr_grid.search_base`).")


def experiment_sweep() -> str:
    """The sweep benchmark's table and verdict."""
    data = bench("experiment_sweep")
    verdict_line = (
        f"Speed-up {data['speedup']:.2f}x on {data['cores']} cores: "
        f"{verdict(data['speedup'] >= data['target_speedup'])} (target: at least "
        f"{data['target_speedup']:g}x); results identical but for the measured "
        f"`{'`, `'.join(data['timed_fields_ignored'])}`: {'yes' if data['identical'] else 'NO'}. "
        f"Load average (1 min) {data['load_average_before']:.1f} before and "
        f"{data['load_average_after']:.1f} after (the cluster's two workers included).")
    return table(result_md("experiment_sweep"), 0) + "\n\n" + verdict_line


def solvers_maps() -> str:
    text = result_md("solvers")
    return table(text, 0) + "\n\n" + paragraphs(text, "\\* pyastar2d")


def solvers_pooled() -> str:
    text = result_md("solvers")
    rows = table(text, 1, ["map", "queries (nx)", "A* ms", "Dijkstra ms", "pyastar2d ms*",
                           "tcod ms", "scipy ms", "networkx ms", "A*/pyastar2d*", "A*/tcod",
                           "A*/networkx", "Dijkstra/scipy"])
    return rows + "\n\n" + paragraphs(text, "One-time costs")


def _median_ratio(samples: dict[str, list[float | None]], ours: str, other: str) -> float:
    """Median of ``ours`` over median of ``other``, on the queries both ran (the table's ratio)."""
    pairs = [(a, b) for a, b in zip(samples[ours], samples[other], strict=True)
             if a is not None and b is not None]
    if not pairs:
        raise FiguresError(f"solvers.json: no query timed for both {ours} and {other}")
    return statistics.median(a for a, _ in pairs) / statistics.median(b for _, b in pairs)


def solvers_targets() -> str:
    """The bullets reading the solver benchmark against the project's three targets."""
    data = bench("solvers")
    text = result_md("solvers")
    pooled = records(text, 1)
    maps = records(text, 0)
    big, thousand = pooled[0], pooled[1]
    samples = {row["map"]: row["samples_ms"] for row in data["targets"]}
    fast_nx = [1 / _median_ratio(samples[row["map"]], "astar", "networkx") for row in pooled]
    exact_nx = [_median_ratio(samples[row["map"]], "astar", "networkx") for row in pooled]
    py = [float(row["A*/pyastar2d*"]) for row in pooled]
    cuts = sum(row["pyastar2d"]["cutting_corners"] for row in data["maps"])
    queries = sum(row["queries"] for row in data["maps"])
    shortest = min(row["pyastar2d"]["min_excess"] for row in data["maps"])
    longest = max(row["pyastar2d"]["max_excess"] for row in data["maps"])
    slow_nx = [row for row in maps if float(row["A*/networkx"]) > 0.05]
    slow_scipy = [row for row in maps if float(row["Dijkstra/scipy"]) > 1]
    nx_met = all(ratio >= 20 for ratio in fast_nx)
    scipy_met = all(float(row["Dijkstra/scipy"]) <= 1 for row in pooled)
    shorter = (f"from {-shortest * 100:.0f}% shorter (through the corners)" if shortest < 0
               else "from the optimum")
    lines = [
        f"- **A\\* within 1.5x of pyastar2d on the 512 and 1000 maps: "
        f"{verdict(max(py) <= 1.5)}**, {py[0]:.2f}x on the 512 maps and {py[1]:.2f}x on the "
        "1000 map. pyastar2d does not solve our problem, though: every step costs 1 and "
        "diagonal steps squeeze past obstacles, its Chebyshev heuristic is then nearly exact, "
        f"and its paths cut corners on {cuts} of the {queries} map queries and in octile "
        f"length run {shorter} to {longest * 100:.0f}% longer than the optimum. On the same "
        "rules the C library to compare with is tcod, and our A\\* takes "
        f"{float(big['A*/tcod']):.2f}x of its time on the 512 maps and "
        f"{float(thousand['A*/tcod']):.2f}x on the 1000 map.",
        f"- **At least 20x faster than networkx: {verdict(nx_met)} in the pooled rows**, "
        f"{fast_nx[0]:.0f}x on the 512 maps (ratio {exact_nx[0]:.3f}) and {fast_nx[1]:.0f}x on "
        f"the 1000 map ({exact_nx[1]:.3f}), and at a ratio of 0.05 or below (as rounded in the "
        f"table) on {len(maps) - len(slow_nx)} of the {len(maps)} maps"
        + (f", **not on {listed([row['map'].split()[0] for row in slow_nx])}** "
           f"({span([float(row['A*/networkx']) for row in slow_nx], 2)}): maps whose queries "
           f"take our A\\* {span([float(row['A* ms']) * 1000 for row in slow_nx], 0)} µs, "
           "where the Python side of a call weighs most." if slow_nx else "."),
        f"- **Dijkstra no slower than scipy: {verdict(scipy_met)} in the pooled rows** "
        f"({float(big['Dijkstra/scipy']):.2f} and {float(thousand['Dijkstra/scipy']):.2f}) and "
        f"on {len(maps) - len(slow_scipy)} of the {len(maps)} maps"
        + (", **not on " + listed([f"{row['map'].split()[0]} ({row['Dijkstra/scipy']})"
                                   for row in slow_scipy]) + "**" if slow_scipy else "")
        + ". scipy settles the whole component on every query while ours stops at the goal; "
        "where the goal is far, ours settles nearly as many cells and scipy is the faster per "
        "cell. Against pyastar2d's A\\* Dijkstra cannot come near 1.5x: it settles every cell "
        "cheaper than the goal.",
        _jps_target(data),
    ]
    return "\n".join(lines)


def _jps_target(data: dict[str, Any]) -> str:
    """The bullet on jump point search: its speed target and its check on every scenario."""
    target = data["jps_target"]
    checked = data["jps_scenarios"]
    scenarios = sum(row["scenarios"] for row in checked)
    mismatches = sum(row["mismatches"] for row in checked)
    exact = ("the scenario's optimal length on every one" if mismatches == 0 else
             f"**{mismatches} lengths disagreeing with the files**")
    return (f"- **jps at most 1/3 of pyastar2d's median time on the 512 maps: "
            f"{verdict(target['met'])}**, {target['ratio']:.2f} of it "
            f"(1/{1 / target['ratio']:.0f}), on the exact problem. Over {grouped(scenarios)} "
            f"problems of the {len(checked)} shipped scenario files it gives {exact}.")


def genetic_reading() -> str:
    rows = bench("genetic")["maps"]
    rates = {f"{row['success_rate'] * 100:.0f}%" for row in rows}
    reached = (f"on {rates.pop()} of the queries of every size" if len(rates) == 1 else
               "on " + listed([f"{row['success_rate'] * 100:.0f}% ({row['map'].split()[-1]})"
                               for row in rows]) + " of the queries")
    above = listed([f"{(row['median_cost_ratio'] - 1) * 100:.0f}% ({row['map'].split()[-1]})"
                    for row in rows])
    slower = listed([f"{about(row['median_ms'] / row['dijkstra_median_ms'])} "
                     f"({row['map'].split()[-1]})" for row in rows])
    return ("A cost ratio is the genetic path's cost over the optimum, over the queries that "
            "reached the goal (optimal: those at ratio 1); times are one run per query, medians "
            "in milliseconds; genes decoded is the median `expanded`. The planner reaches the "
            f"goal {reached}, at a median {above} above the optimal cost and up to "
            f"{(max(row['max_cost_ratio'] for row in rows) - 1) * 100:.0f}% above, and takes "
            f"about {slower} times Dijkstra's time: "
            "most runs use the whole budget, as only a path at the octile lower bound ends a "
            "run early. The paper gives no figures to compare with.")


def _kinematic_queries() -> list[tuple[str, dict[str, Any], dict[str, Any]]]:
    """Every forward query the search solved: its map, the query and its forward searches."""
    found = []
    for row in bench("kinematics_speed")["maps"]:
        for query in row["queries"]:
            if query["forward"]["astar"]["cost"] is not None:
                found.append((row["map"].split()[0], query, query["forward"]))
    return found


def kinematics_reading() -> str:
    data = bench("kinematics_speed")
    pooled = {row["model"]: row for row in data["pooled"]}
    holonomic, forward = pooled["holonomic"], pooled["forward"]
    solved = _kinematic_queries()
    exhaustive = [(where, f["astar"]["expanded"]) for where, q, f in solved
                  if f["astar"]["settled_into_goal"] < q["entering"]]
    early = [f["astar"]["expanded"] / f["dijkstra"]["expanded"] for _, q, f in solved
             if f["astar"]["settled_into_goal"] >= q["entering"]]
    if len(exhaustive) != forward["exhaustive"]:
        raise FiguresError("kinematics_speed.json: the queries and the pooled row disagree on "
                           "the exhaustive searches")
    where, count = Counter(w for w, _ in exhaustive).most_common(1)[0]
    edges = statistics.median(e for w, e in exhaustive if w == where)
    unsolvable = [row["map"].split()[0] for row in data["rows"] if row["model"] != "holonomic"
                  and row["solved"] == 0]
    never = sorted({m for m in unsolvable if unsolvable.count(m) == 2})
    unsolved = forward["queries"] - forward["solved"]
    worst_where, worst_query, worst = max(
        solved, key=lambda s: s[2]["astar"]["cost"] / s[1]["optimal"])
    share = count / len(exhaustive)
    part = ("half" if abs(share - 0.5) < 0.05 else "a third" if abs(share - 1 / 3) < 0.05
            else f"{count}")
    return "\n".join([
        "- **A state is a directed edge, not a cell**: up to 8 per cell, so even the holonomic "
        f"model costs {holonomic['astar_expanded'] / holonomic['ordinary_expanded']:.1f} times "
        f"the ordinary A*'s states and {holonomic['astar_over_ordinary']:.1f} times its time. "
        "The solvers plan a holonomic robot with the ordinary searches; the edge-based ones "
        "serve constrained models.",
        "- **Exhaustive searches.** The paper's step 4 waits until every edge entering the goal "
        "is settled. When the robot can never drive along one of them (it would have to arrive "
        "from a wall's side, or turn where there is no room), the search settles every edge it "
        f"can reach before it stops: {len(exhaustive)} of the {forward['solved']} forward "
        f"queries solved, {part} of them on {where}, where such a query settles a median "
        f"{edges / 1e6:.2f} million edges. Where the search stops early the A* settles a median "
        f"{statistics.median(early):.2f} times the edges Dijkstra does.",
        "- **What cannot be driven.** "
        + (f"None of {listed(never)}'s queries is solvable for either constrained model: "
           "its corridors are one cell wide with right-angled corners and no corner cutting, "
           "and a turn of more than 45 degrees needs a manoeuvre through an edge within 45 "
           "degrees of the way the robot came, which a corner lacks. " if never else "")
        + f"{forward['blocked_start']} of the {unsolved} unsolved forward queries start facing "
        "a wall: no first step lies within 45 degrees of the heading, and the paper's "
        "manoeuvres begin with a forward step too.",
        f"- **Cost.** The median constrained path costs "
        f"{(forward['cost_ratio_median'] - 1) * 100:.0f}% more than the holonomic optimum; the "
        "maxima come from short trips where the robot must loop round to turn (a "
        f"{worst_query['optimal']:.0f}-step trip on {worst_where} costs "
        f"{worst['astar']['cost']:.2f}).",
    ])


def kinematics_summary() -> str:
    """The kinematics page's reading of the pooled table."""
    data = bench("kinematics_speed")
    mismatches = data["mismatches"]
    forward = {row["model"]: row for row in data["pooled"]}["forward"]
    never = sorted({row["map"].split()[0] for row in data["rows"]
                    if row["model"] == "forward" and row["solved"] == 0})
    agree = ("A* and Dijkstra agree on every cost" if mismatches["astar_vs_dijkstra"] == 0 else
             f"A* and Dijkstra disagree on {mismatches['astar_vs_dijkstra']} costs")
    equal = ("equals the ordinary optimum on every query"
             if mismatches["holonomic_vs_ordinary"] == 0 else
             f"differs from the ordinary optimum on {mismatches['holonomic_vs_ordinary']} queries")
    return (f"{agree}, and the holonomic model's edge-based cost {equal}. The rule of step 4 "
            f"makes {forward['exhaustive']} of the {forward['solved']} forward searches "
            "exhaustive: an edge into the goal that the robot cannot drive along is never "
            "settled, so the search settles every edge it can reach. "
            + (f"No query on {listed(never)} (one-cell corridors with right-angled corners) "
               "is solvable for a robot that turns at most 45 degrees per cell, and "
               if never else "")
            + f"{forward['blocked_start']} of the {forward['queries'] - forward['solved']} "
            "unsolved queries start facing a wall. See "
            "[Benchmarks](benchmarks.md#nonholonomic-searches).")


def memory_reading() -> str:
    """What an 8000 x 8000 map costs in memory, against the 2 GB target."""
    data = bench("memory")
    rows = {row["kind"]: row for row in data["measurements"]}
    limit = data["limit_bytes"]

    def gb(value: float) -> str:
        return f"{value / 1e9:.2f} GB"

    def within(kind: str) -> bool:
        return rows[kind]["peak_rss"] <= limit

    def per_cell(row: dict, value: float) -> str:
        return f"{value / row['cells']:.0f}"

    searches = [kind for kind in ("astar", "dijkstra") if kind in rows]
    side = data["side"]
    astar = rows["astar"]
    text = (f"On the {side} x {side} map one A* search peaks at {gb(astar['peak_rss'])} "
            f"and one Dijkstra search at {gb(rows['dijkstra']['peak_rss'])}: planning within "
            f"{gb(limit)} is {'met' if all(within(k) for k in searches) else 'not met'} for "
            f"both, the grid's {per_cell(astar, sum(astar['grid_bytes'].values()))} bytes per "
            f"cell and the search's {per_cell(astar, sum(astar['search_bytes'].values()))} "
            "being nearly all of it.")
    for kind, test in (("engine_octile", "octile"), ("engine", "landmark")):
        row = rows.get(kind)
        if row is None:
            continue
        graph = sum(row.get("case_graph", {}).get("per_cell_bytes", {}).values())
        text += (f" With the {test} quality test the hybrid engine peaks at "
                 f"{gb(row['peak_rss'])}, {'within' if within(kind) else '**not** within'} "
                 f"it: the case graph's cell arrays take {per_cell(row, graph)} bytes per cell")
        if row.get("landmarks"):
            text += (f" and the {row['landmarks']} landmark tables "
                     f"{per_cell(row, row['landmark_bytes'])} "
                     f"({gb(row['landmark_bytes'])} at this size)")
        text += "."
    return text
