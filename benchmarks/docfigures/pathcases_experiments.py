"""Whole-path cases: the learning experiment's curves and their reading."""

from __future__ import annotations

import statistics
from typing import Any

from .results import kept_results
from .wording import span


def _learning() -> dict[str, Any]:
    return kept_results("path-cases-learning")


def mean_curve(costs: list[list[float]], window: int) -> list[float]:
    """The mean over seeds of each seed's moving mean of ``window`` trips (the plotted curve)."""
    curves = []
    for seed in costs:
        curve = []
        for end in range(1, len(seed) + 1):
            part = seed[max(0, end - window):end]
            curve.append(sum(part) / len(part))
        curves.append(curve)
    return [statistics.mean(values) for values in zip(*curves, strict=True)]


def below_from(results: dict[str, Any], robot: str, other: str) -> int | None:
    """The first trip from which ``robot``'s learning curve stays below ``other``'s."""
    from cbr_pathcases.experiments import WINDOW

    ours = mean_curve(results["curves"][robot], WINDOW)
    theirs = mean_curve(results["curves"][other], WINDOW)
    first = None
    for trip, (a, b) in enumerate(zip(ours, theirs, strict=True), start=1):
        if a >= b:
            first = None
        elif first is None:
            first = trip
    return first


def learning_header() -> str:
    results = _learning()
    return (f"Full size ({len(results['seeds'])} seeds, {results['trips']} trips per robot and "
            "seed; about a minute on 2 cores). Travel cost: mean over the trips of a half, then "
            "mean ± standard deviation (min-max) over the seeds:")


def learning_paired() -> str:
    ratio = _learning()["cbr_over_map_only"]
    every = ("below 1 for every seed" if ratio["max"] < 1 else
             "above 1 for every seed" if ratio["min"] > 1 else "below 1 for some seeds only")
    return (f"CBR over map-only, last half, paired by seed: **{ratio['mean']:.3f} ± "
            f"{ratio['std']:.3f} ({ratio['min']:.3f}-{ratio['max']:.3f})**, {every}.")


def learning_reading() -> str:
    results = _learning()
    summary = results["summary"]

    def last(robot: str) -> float:
        return summary[robot]["last_half_cost"]["mean"]

    def stops(robot: str) -> float:
        return summary[robot]["last_half_stops"]["mean"]

    cbr, only, learning = last("cbr"), last("map-only"), last("map-learning")
    ratio = results["cbr_over_map_only"]["mean"]
    since = below_from(results, "cbr", "map-only")
    if cbr < only and since is not None:
        first = ("- **The case-based robot's travel cost falls below the map-only planner's**, "
                 f"from trip {since} on (the curves' moving mean), and stays "
                 f"{(1 - ratio) * 100:.0f}% below it: it learns to take the ring corridor "
                 "round the crossing and room A's top door instead of its central one, and it "
                 f"stops at an obstacle {stops('cbr'):.2f} times per trip against the map-only "
                 f"planner's {stops('map-only'):.2f}.")
    else:
        first = ("- **The case-based robot's travel cost does not stay below the map-only "
                 f"planner's** ({cbr:.2f} against {only:.2f} in the last half; it stops at an "
                 f"obstacle {stops('cbr'):.2f} times per trip against "
                 f"{stops('map-only'):.2f}).")
    pairs = {robot: summary[robot]["last_half_cost_by_pair"]
             for robot in ("cbr", "map-learning")}
    kinder = pairs["cbr"].get("CD"), pairs["map-learning"].get("CD")
    if learning < cbr:
        second = (f"- **The map-learning robot does better still here** ({learning:.2f} against "
                  f"{cbr:.2f}). Blocking a cell for good after meeting an obstacle in it twice "
                  "suits doors shut 9 times in 10, and A* on that map finds the shortest "
                  "detour; the case-based robot keeps the detour it happened to drive first "
                  "(room A to B through the top door: 23 steps where 19 would do), since "
                  "nothing but exploration by the randomized search offers it another.")
    else:
        second = (f"- **The case-based robot does better than the map-learning one here** "
                  f"({cbr:.2f} against {learning:.2f}).")
    if kinder[0] is not None and kinder[1] is not None and kinder[0] < kinder[1]:
        second += (" Where the world is kinder than its map-learning makes it (room D's door, "
                   "shut 1 time in 10, becomes a wall on the learned map after two meetings), "
                   f"the case-based robot wins: {kinder[0]:.2f} against {kinder[1]:.2f} on "
                   "trips between C and D.")
    passive = [last(s) for s in ("least_recent_paths", "least_used_paths", "oldest_paths",
                                 "newest_paths")]
    third = (f"- **Forgetting at a capacity of {results['capacity']} paths**: success-driven "
             f"forgetting (`worst_paths`, {last('worst_paths'):.2f}) "
             + ("keeps the robot close to" if last("worst_paths") - cbr < 0.1 else
                "stays above") + f" the unconstrained case base ({cbr:.2f}); failure-driven "
             f"forgetting (`best_paths`, {last('best_paths'):.2f}) throws away exactly the "
             "routes that worked and is "
             + ("nearly back to" if abs(last("best_paths") - only) < 0.1 else "closest of all to")
             + f" map-only ({only:.2f}); forgetting the average cases "
             f"({last('average_paths'):.2f}) lies between. The passive and usage-based "
             "strategies (`least_recent`, `least_used`, `oldest`, `newest`: "
             f"{span(passive, 2)}) keep the routes in use, which are mostly the good ones.")
    return "\n".join([first, second, third])
