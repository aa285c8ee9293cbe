"""Retrieval time of the RUPART index (``cbr_behaviors``) over 10,000 cases, beside CBRkit,
and at the few cases the robot really holds.

Cases and queries are random full indices (all 25 features of
:data:`cbr_behaviors.index.FEATURES`: the fourteen of 004 Figure 5 and the eleven of
:data:`~cbr_behaviors.index.SITUATION`) of a robot on an office floor of ``FLOOR``
metres with ``ROOMS`` rooms: sonar ranges up to 5.5 m (cut to 5 m), motor values within the
behaviors' top speed and turn rate, 1 to 5 of the landmark ids, doors and transient kinds within
reach, a location and a task location on the floor, 2 to 5 active behaviors of Table 1, a plan
of 1 to 6 places, a goal ``(deliver place priority)``, 1 to 4 pending places and sixteen numbers
in [0, 1] (Figure 5's five and the eleven situation features, each uniform: the benchmark times
the pass, which reads every number alike, not how the situations of a floor spread). A tenth
of the cases hold a variable in their plan or goal, as hand-made cases do. Half the queries are
fresh, half are stored cases moved a little (every number by a few percent of its range, one
name swapped), so that some have a clear nearest case. The features are weighted by
``WEIGHTS``: Figure 5's unequally, so that the weighting is exercised, the situation features
1 each (the retriever's default; nothing here favours one of them over another).

Timed (medians over the queries of each query's median over ``--repeats`` calls, after a
warm-up call that loads or compiles the kernel; each query's ``nearest`` calls come right after
the previous query's CBRkit call, which leaves the caches full of CBRkit's data, as a robot's
other work between two retrievals would):

- ``IndexTable.nearest(query, weights, k=5)`` over every case;
- CBRkit's retrieval (``cbrkit.retrieval.build(..., limit=5)`` applied with
  ``cbrkit.retrieval.apply``) over the same cases as attribute-value data: its
  ``attribute_value`` similarity with one similarity function per attribute, ``1 - D_f``
  (CBRkit's ``numbers.linear(max=1)`` for the sixteen numbers in [0, 1], which is exactly
  that; functions of our own for the rest, as CBRkit has no sonar, 2D, term or empty-safe
  Jaccard measure), pooled by its ``aggregator("mean", pooling_weights=WEIGHTS)``, a weighted
  mean, which over full indices is ``1 - D``. One call per query (it takes long);
- the plain Python reference (:func:`cbr_behaviors.index.feature_distances` and
  :func:`~cbr_behaviors.index.overall` over every case) for the first ``--reference-queries``;
- at the memory sizes the robot really holds (``--sizes``: 24, 50 and 100 cases, the first that
  many of the stored cases), ``nearest`` (k=5) and the plain Python reference side by side,
  every query, each with its median over ``--repeats`` calls, one after the other per query
  (so that a change of load hits both alike). At this size the pass over the cases costs
  little beside what every call pays (encoding the query, calling the kernel, making the
  hits), which this table shows.

Agreement: the best case of CBRkit's ranking against ``nearest``'s (CBRkit ranks by
similarity, ties in case order, as ``nearest`` breaks them by row), the top five as lists,
and the largest difference between CBRkit's similarity and ``1 - D`` over the top five; the
reference's five nearest against ``nearest``'s, at 10,000 cases and at each small size.

    python benchmarks/rupart_retrieval.py [--cases 10000] [--queries 200] [--seed 0]
        [--repeats 3] [--reference-queries 10] [--sizes 24 50 100] [--out benchmarks/results]

Writes ``rupart_retrieval.json`` and ``rupart_retrieval.md`` (table 1: the 10,000 cases beside
CBRkit and the reference; table 2: by memory size).
"""

from __future__ import annotations

import argparse
import importlib.metadata
import math
import os
import statistics
import time
from collections.abc import Callable
from functools import partial
from pathlib import Path
from typing import Any

import numpy as np
from docfigures.provenance import script_command, write_results

from cbr_behaviors.index import (
    FRACTIONS,
    SETS,
    SITUATION,
    SONAR_BEAMS,
    SONAR_MAX,
    Index,
    IndexTable,
    Scales,
    feature_distances,
    jaccard,
    overall,
    term_distance,
    weight_vector,
)
from cbr_world2d.pilots.behaviors import BEHAVIORS, TOP_SPEED, TOP_TURN_RATE

FLOOR = (40.0, 30.0)
"""Metres: the office floor's width and depth."""
ROOMS = 30
LANDMARKS = [f"sign_{i}" for i in range(1, ROOMS + 1)] + [
    f"door_{i}" for i in range(1, ROOMS + 1)] + ["person", "object"]
PLACES = [f"room_{i}" for i in range(1, ROOMS + 1)] + ["hall_west", "hall_east", "mailroom"]
PRIORITIES = ["low", "med", "high"]
SONAR_REACH = 5.5
"""Metres: the longest raw range drawn (past 5 m the index keeps 5 m)."""
WEIGHTS = {"sonar": 2.0, "motors": 1.0, "map": 1.5, "location": 2.0, "behaviors": 1.0,
           "task-loc": 1.0, "task-urgency": 0.5, "plan": 1.0, "goal": 1.5,
           "goal-urgency": 0.5, "pending-goals": 0.5, "loc-conf": 1.0, "plan-conf": 0.5,
           "behav-conf": 0.5, **{f: 1.0 for f in SITUATION}}
"""The features' weights: Figure 5's unequal so that the weighting is exercised, the situation
features 1 each (the default weight; no reason here to favour one)."""
K = 5
TARGET_MS = 1.0
"""Median ms per query of ``nearest`` over 10,000 cases the issue asks for."""
FULL = {"cases": 10_000, "queries": 200}
SIZES = (24, 50, 100)
"""Cases in the memories the robot really holds, timed in the second table."""


def _names(rng: np.random.Generator, pool: list[str], low: int, high: int) -> list[str]:
    return [pool[int(i)] for i in rng.choice(len(pool), int(rng.integers(low, high + 1)),
                                             replace=False)]


def random_data(rng: np.random.Generator, variables: bool) -> dict[str, Any]:
    """A full index as plain data; its plan or goal holds a variable when ``variables``."""
    plan = [PLACES[int(i)] for i in rng.integers(0, len(PLACES), int(rng.integers(1, 7)))]
    goal = ["deliver", PLACES[int(rng.integers(len(PLACES)))],
            PRIORITIES[int(rng.integers(len(PRIORITIES)))]]
    if variables:
        if rng.random() < 0.5:
            plan[int(rng.integers(len(plan)))] = "?place"
        else:
            goal[1] = "?place"
    data: dict[str, Any] = {
        "sonar": rng.uniform(0.2, SONAR_REACH, SONAR_BEAMS).tolist(),
        "motors": [float(rng.uniform(0.0, TOP_SPEED)),
                   float(rng.uniform(-TOP_TURN_RATE, TOP_TURN_RATE))],
        "map": _names(rng, LANDMARKS, 1, 5),
        "location": [float(rng.uniform(0, FLOOR[0])), float(rng.uniform(0, FLOOR[1]))],
        "behaviors": _names(rng, list(BEHAVIORS), 2, 5),
        "task-loc": [float(rng.uniform(0, FLOOR[0])), float(rng.uniform(0, FLOOR[1]))],
        "plan": plan,
        "goal": goal,
        "pending-goals": _names(rng, PLACES, 1, 4),
    }
    # Figure 5's five numbers in [0, 1] and the eleven situation features
    for feature in FRACTIONS:
        data[feature] = float(rng.uniform(0.0, 1.0))
    return data


def moved(data: dict[str, Any], rng: np.random.Generator) -> dict[str, Any]:
    """``data`` moved a little: every number by up to a few percent of its range (kept in
    range), one name of one set swapped for another, variables replaced by atoms (a query
    has none)."""
    out = dict(data)
    out["sonar"] = np.clip(np.asarray(data["sonar"]) + rng.normal(0, 0.1, SONAR_BEAMS),
                           0.0, SONAR_REACH).tolist()
    out["motors"] = [data["motors"][0] + float(rng.normal(0, 0.02)),
                     data["motors"][1] + float(rng.normal(0, 0.05))]
    for feature in ("location", "task-loc"):
        out[feature] = [c + float(rng.normal(0, 0.3)) for c in data[feature]]
    for feature in FRACTIONS:
        out[feature] = float(np.clip(data[feature] + rng.normal(0, 0.03), 0.0, 1.0))
    swapped = SETS[int(rng.integers(len(SETS)))]
    pool = list(BEHAVIORS) if swapped == "behaviors" else LANDMARKS if swapped == "map" \
        else PLACES
    names = list(data[swapped])
    names[int(rng.integers(len(names)))] = pool[int(rng.integers(len(pool)))]
    out[swapped] = sorted(set(names))
    for feature in ("plan", "goal"):
        out[feature] = [PLACES[0] if a.startswith("?") else a for a in data[feature]]
    return out


def cases_and_queries(cases: int, queries: int, seed: int
                      ) -> tuple[list[dict[str, Any]], list[dict[str, Any]]]:
    """``cases`` stored indices and ``queries`` queries (fresh and moved, interleaved), as
    plain data."""
    rng = np.random.default_rng(seed)
    stored = [random_data(rng, variables=rng.random() < 0.1) for _ in range(cases)]
    fresh = [random_data(rng, variables=False) for _ in range(queries - queries // 2)]
    picks = rng.choice(cases, queries // 2, replace=cases < queries // 2)
    near = [moved(stored[int(k)], rng) for k in picks]
    mixed = [q for pair in zip(fresh, near, strict=False) for q in pair]
    return stored, mixed + fresh[len(near):]


# --------------------------------------------------------------------------------------------
# CBRkit


def cbrkit_retriever(scales: Scales) -> Callable[..., Any]:
    """CBRkit's retriever of the five most similar cases, by ``1 - D_f`` per attribute and the
    weighted mean of :data:`WEIGHTS`."""
    import cbrkit

    def sonar(x: list[float], y: list[float]) -> float:
        squares = sum((a - b) ** 2 for a, b in zip(x, y, strict=True))
        return 1.0 - math.sqrt(squares / SONAR_BEAMS) / SONAR_MAX

    def motors(x: list[float], y: list[float]) -> float:
        dv = (x[0] - y[0]) / TOP_SPEED
        dw = (x[1] - y[1]) / TOP_TURN_RATE
        return 1.0 - min(1.0, math.sqrt((dv * dv + dw * dw) / 2.0))

    def point(x: list[float], y: list[float]) -> float:
        return 1.0 - min(1.0, math.hypot(x[0] - y[0], x[1] - y[1]) / scales.location)

    def names(x: frozenset[str], y: frozenset[str]) -> float:
        return 1.0 - jaccard(x, y)

    def term(x: list[str], y: list[str]) -> float:
        return 1.0 - term_distance(x, y)

    attributes = {"sonar": sonar, "motors": motors, "location": point, "task-loc": point,
                  "plan": term, "goal": term,
                  **{f: names for f in SETS},
                  **{f: cbrkit.sim.numbers.linear(max=1.0) for f in FRACTIONS}}
    similarity = cbrkit.sim.attribute_value(
        attributes=attributes,
        aggregator=cbrkit.sim.aggregator(pooling="mean", pooling_weights=dict(WEIGHTS)))
    return cbrkit.retrieval.build(similarity, limit=K)


def cbrkit_data(index: Index) -> dict[str, Any]:
    """``index`` as CBRkit attribute-value data: sonar ranges cut as the index cuts them, sets
    as frozensets."""
    data = index.to_data()
    for feature in SETS:
        data[feature] = frozenset(data[feature])
    return data


# --------------------------------------------------------------------------------------------


def _median_of(call: Callable[[], Any], repeats: int) -> tuple[float, Any]:
    seconds = []
    for _ in range(repeats):
        started = time.perf_counter()
        found = call()
        seconds.append(time.perf_counter() - started)
    return statistics.median(seconds), found


def _percentile(values: list[float], q: float) -> float:
    return float(np.percentile(values, q)) if values else math.nan


def _ms(seconds: list[float]) -> dict[str, float]:
    return {"median": statistics.median(seconds) * 1e3 if seconds else math.nan,
            "p90": _percentile(seconds, 90) * 1e3}


def reference_nearest(query: Index, stored: list[Index], weights: np.ndarray, scales: Scales
                      ) -> tuple[list[int], list[float]]:
    """The plain Python reference's ``K`` nearest of ``stored`` to ``query`` (ties by row) and
    every case's overall distance."""
    totals = [overall(feature_distances(query, case, scales), weights) for case in stored]
    return sorted(range(len(stored)), key=lambda r: (totals[r], r))[:K], totals


def against_reference(table: IndexTable, stored: list[Index], asked: list[Index],
                      weights: np.ndarray, scales: Scales) -> dict[str, Any]:
    """The plain Python reference (:func:`feature_distances` and :func:`overall` over every
    case) for each of ``asked``, against ``table.nearest``: its median ms, in how many queries
    the five nearest are equal, the largest difference of their distances."""
    seconds, equal, gap = [], 0, 0.0
    for query in asked:
        started = time.perf_counter()
        order, totals = reference_nearest(query, stored, weights, scales)
        seconds.append(time.perf_counter() - started)
        hits = table.nearest(query, weights, K)
        equal += order == [h.row for h in hits]
        gap = max(gap, *(abs(totals[h.row] - h.distance) for h in hits))
    return {"queries": len(seconds),
            "ms_median": statistics.median(seconds) * 1e3 if seconds else math.nan,
            "top5_equal": f"{equal}/{len(seconds)}", "max_distance_difference": gap}


def by_size(stored: list[Index], asked: list[Index], weights: np.ndarray, scales: Scales,
            sizes: list[int], repeats: int) -> list[dict[str, Any]]:
    """For each of ``sizes``, the table of the first that many ``stored`` cases: median and p90
    ms per query (over ``asked``, each query's median over ``repeats`` calls) of
    ``nearest`` (k=5) and of the plain Python reference, called one after the other per query,
    their ratio and in how many queries their five nearest are equal."""
    rows = []
    for size in sizes:
        cases = stored[:size]
        table = IndexTable.build(cases, scales)
        table.nearest(asked[0], weights, K)  # the kernel is loaded already; this fills caches
        ours_s, reference_s, equal = [], [], 0
        for query in asked:
            seconds, hits = _median_of(partial(table.nearest, query, weights, K), repeats)
            ours_s.append(seconds)
            seconds, (order, _) = _median_of(
                partial(reference_nearest, query, cases, weights, scales), repeats)
            reference_s.append(seconds)
            equal += order == [h.row for h in hits]
        ours, reference = _ms(ours_s), _ms(reference_s)
        rows.append({"cases": len(cases), "nearest_ms": ours, "reference_ms": reference,
                     "reference_over_nearest": reference["median"] / ours["median"],
                     "top5_equal": f"{equal}/{len(asked)}"})
    return rows


def main(argv: list[str] | None = None) -> dict[str, Any]:
    import cbrkit

    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--cases", type=int, default=FULL["cases"], help="cases (10000)")
    parser.add_argument("--queries", type=int, default=FULL["queries"], help="queries (200)")
    parser.add_argument("--seed", type=int, default=0, help="seed of the cases and queries")
    parser.add_argument("--repeats", type=int, default=3,
                        help="timed nearest calls per query (3)")
    parser.add_argument("--reference-queries", type=int, default=10,
                        help="queries the plain Python reference answers (10)")
    parser.add_argument("--sizes", type=int, nargs="*", default=list(SIZES),
                        help="small memories timed beside the reference, those under --cases "
                             "(24 50 100)")
    parser.add_argument("--out", type=Path, default=Path(__file__).parent / "results")
    args = parser.parse_args(argv)
    load_before = os.getloadavg()[0]
    began = time.perf_counter()
    stored_data, query_data = cases_and_queries(args.cases, args.queries, args.seed)
    stored = [Index.from_data(d, f"case {k}") for k, d in enumerate(stored_data)]
    asked = [Index.from_data(d, f"query {k}") for k, d in enumerate(query_data)]
    generate_s = time.perf_counter() - began
    scales = Scales()
    weights = weight_vector(WEIGHTS)
    started = time.perf_counter()
    table = IndexTable.build(stored, scales)
    build_s = time.perf_counter() - started
    started = time.perf_counter()
    table.nearest(asked[0], weights, K)
    first_s = time.perf_counter() - started
    casebase = {k: cbrkit_data(index) for k, index in enumerate(stored)}
    retriever = cbrkit_retriever(scales)

    ours_s, theirs_s, best_equal, top_equal, sim_gap, distances = [], [], 0, 0, 0.0, []
    for query in asked:
        seconds, hits = _median_of(lambda q=query: table.nearest(q, weights, K), args.repeats)
        ours_s.append(seconds)
        started = time.perf_counter()
        found = cbrkit.retrieval.apply(casebase, cbrkit_data(query), retriever)
        theirs_s.append(time.perf_counter() - started)
        ranking = found.ranking
        best_equal += ranking[0] == hits[0].row
        top_equal += ranking == [h.row for h in hits]
        distances.append(hits[0].distance)
        for hit in hits:
            if hit.row in found.similarities:
                sim = found.similarities[hit.row].value
                sim_gap = max(sim_gap, abs(sim - (1.0 - hit.distance)))

    reference = against_reference(table, stored, asked[:args.reference_queries], weights,
                                  scales)
    sizes = sorted({size for size in args.sizes if 0 < size < len(stored)})
    small = by_size(stored, asked, weights, scales, sizes, args.repeats)
    ours, cbrkits = _ms(ours_s), _ms(theirs_s)
    median, theirs = ours["median"], cbrkits["median"]
    summary: dict[str, Any] = {
        "cases": len(stored), "queries": len(asked), "seed": args.seed, "k": K,
        "repeats": args.repeats, "weights": WEIGHTS,
        "cbrkit_version": importlib.metadata.version("cbrkit"),
        "nearest_ms": ours,
        "cbrkit_ms": cbrkits,
        "ratio": theirs / median,
        "agreement": {"best_case_equal": f"{best_equal}/{len(asked)}",
                      "top5_equal": f"{top_equal}/{len(asked)}",
                      "max_similarity_difference": sim_gap},
        "reference": reference,
        "best_distance": {"median": statistics.median(distances),
                          "min": min(distances), "max": max(distances)},
        "target": {"what": f"median nearest ms over {FULL['cases']} cases",
                   "goal": f"<= {TARGET_MS}", "measured": median,
                   "met": median <= TARGET_MS and len(stored) >= FULL["cases"]},
        "by_size": small,
        "generate_s": generate_s, "build_s": build_s, "first_call_s": first_s,
        "elapsed_s": time.perf_counter() - began,
        # the 1-minute load average before and after: the other work the timings shared the
        # machine with
        "load_average": {"before": load_before, "after": os.getloadavg()[0],
                         "cpus": os.cpu_count()}}
    args.out.mkdir(parents=True, exist_ok=True)
    write_results(args.out / "rupart_retrieval.json", summary,
                  command=script_command(__file__, argv))
    text = report(summary)
    (args.out / "rupart_retrieval.md").write_text(text + "\n")
    print(text)
    return summary


def _ms_text(ms: float) -> str:
    return f"{ms:.3f}" if ms < 10 else f"{ms:.1f}"


def by_size_table(result: dict[str, Any]) -> list[str]:
    """The lines of the table by memory size: the small memories, then the whole case base
    with CBRkit's ratio."""
    reference = result["reference"]
    lines = ["| cases | `nearest` median ms | p90 ms | reference median ms | "
             "reference / nearest | CBRkit / nearest |", "|---|---|---|---|---|---|"]
    for row in result["by_size"]:
        ours, theirs = row["nearest_ms"], row["reference_ms"]
        lines.append(f"| {row['cases']} | {ours['median']:.3f} | {ours['p90']:.3f} | "
                     f"{_ms_text(theirs['median'])} | {row['reference_over_nearest']:,.0f}x "
                     "| - |")
    ours = result["nearest_ms"]
    lines.append(f"| {result['cases']} | {ours['median']:.3f} | {ours['p90']:.3f} | "
                 f"{_ms_text(reference['ms_median'])} | "
                 f"{reference['ms_median'] / ours['median']:,.0f}x | "
                 f"{result['ratio']:,.0f}x |")
    return lines


def report(result: dict[str, Any]) -> str:
    """The markdown of ``result``."""
    ours, theirs = result["nearest_ms"], result["cbrkit_ms"]
    agreement, reference = result["agreement"], result["reference"]
    lines = [
        "| what | median ms per query | p90 ms | note |", "|---|---|---|---|",
        f"| `IndexTable.nearest`, k={result['k']}, {result['cases']} cases | "
        f"{ours['median']:.3f} | {ours['p90']:.3f} | full indices, weighted |",
        f"| CBRkit {result['cbrkit_version']} attribute-value retrieval, limit "
        f"{result['k']} | {theirs['median']:.1f} | {theirs['p90']:.1f} | CBRkit / nearest: "
        f"{result['ratio']:,.0f}x; best case equal in {agreement['best_case_equal']} |",
        f"| plain Python reference (`feature_distances`, `overall`) | "
        f"{reference['ms_median']:.1f} | - | {reference['queries']} queries; five nearest "
        f"equal in {reference['top5_equal']} |"]
    target = result["target"]
    best = result["best_distance"]
    small = result["by_size"]
    load = result["load_average"]
    notes = [
        f"Agreement with CBRkit: best case {agreement['best_case_equal']}, the five best in "
        f"order {agreement['top5_equal']}, largest difference between CBRkit's similarity "
        f"and 1 - D over them {agreement['max_similarity_difference']:.1e}. Reference: "
        f"largest difference of D {reference['max_distance_difference']:.1e}.",
        f"Distance of the nearest case: median {best['median']:.3f}, from {best['min']:.3f} "
        f"to {best['max']:.3f} (half the queries are stored cases moved a little).",
        f"Target {target['what']}: {target['goal']}, measured {target['measured']:.3f}: "
        f"{'met' if target['met'] else 'not met'}.",
        "By memory size (`IndexTable.nearest`, k=5, beside the plain Python reference):",
        "\n".join(by_size_table(result)),
        (f"The first {', '.join(str(row['cases']) for row in small)} of the stored cases, "
         f"all {result['queries']} queries, the median of {result['repeats']} calls of each "
         "per query; the five nearest equal in "
         f"{', '.join(row['top5_equal'] for row in small)}. " if small else "")
        + f"The {result['cases']}-case row is the table above's (the reference over its "
        f"first {reference['queries']} queries, one call each).",
        f"Seed {result['seed']}, {result['repeats']} timed nearest calls per query (their "
        f"median), one CBRkit call per query. Generating the indices "
        f"{result['generate_s']:.1f} s, building the table {result['build_s']:.2f} s, first "
        f"call (numba cache load or compile) {result['first_call_s']:.2f} s, whole run "
        f"{result['elapsed_s']:.0f} s; load average {load['before']:.2f} before, "
        f"{load['after']:.2f} after, on {load['cpus']} CPUs."]
    return "\n\n".join(["\n".join(lines), *notes])


if __name__ == "__main__":
    main()
