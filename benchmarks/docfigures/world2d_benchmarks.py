"""The prose of the 2D world's benchmarks: the simulator's speed, landmark retrieval and RUPART's
retrieval, read from their results."""

from __future__ import annotations

import statistics
from typing import Any

from .results import FiguresError, bench, result_md, table
from .wording import all_of, goal, grouped, listed, verdict


def world2d_tour() -> str:
    data = bench("world2d_speed")
    tour = data["tour"]
    collisions = ("no collision" if tour["collisions"] == 0 else
                  f"{tour['collisions']} collisions")
    return (f"In the {grouped(data['steps'])} steps of a repeat that is {tour['legs']} legs, "
            f"{tour['reached']} reached (the others trapped by the linear obstacles until the "
            f"timeout, as the potential field is meant to be), {tour['distance_m']:.0f} m, "
            f"{collisions}.")


def world2d_irsim_path() -> str:
    data = bench("world2d_speed")
    runs = data["irsim"].values()
    apart = max(run["largest_apart_from_ours_m"] for run in runs)
    crashed = sum(run["steps_in_collision"] for run in runs)
    return (f"ir-sim replays, leg by leg, the velocities our robot had, so it drives the same "
            f"path: every leg of its {grouped(data['irsim_steps'])} steps ends within "
            f"{apart * 100:.1f} cm of where ours did (its Euler step against our exact "
            "arc), " + ("without a collision." if crashed == 0 else
                        f"with {crashed} steps in collision."))


def world2d_reading() -> str:
    data = bench("world2d_speed")
    rows = data["rows"]
    step, bare = rows[0], rows[1]
    targets = {target["target"]: target for target in data["targets"]}
    goal = targets["Simulation.step steps/s"]["goal"].split()[-1]
    met = all(target["met"] for target in targets.values())
    low, high = step["steps_per_s_range"]
    irsim = data["irsim"]
    objects = {run["objects"] for run in irsim.values()}
    over = step["over_irsim"]
    parts = data["parts_median_s"]
    whole = step["us"]

    def share(part: str) -> float:
        return parts[part] * 1e6 / whole

    sensing = share("Sensors.observe (sonar, camera, odometry, bumper)")
    sonar = share("sonar ring (SonarRing.read)")
    robot = share("robot step (robot.step)")
    navigator = share("navigator (Navigator.command, with the pilot)")
    return (
        f"Reading against the targets:\n\n"
        f"- **At least {grouped(float(goal))} steps per second: {verdict(met)}**, "
        f"{grouped(step['steps_per_s'])} for `Simulation.step` and "
        f"{grouped(bare['steps_per_s'])} for the bare loop, medians over the repeats. This "
        "machine is a shared two-core virtual machine and its speed wanders: the repeats of "
        f"this run range from {grouped(round(low, -2))} to {grouped(round(high, -2))} steps/s "
        "for the step.\n"
        f"- **Beside ir-sim: about {statistics.mean(over.values()):.0f} times its "
        f"steps per second** ({over['16']:.1f} against its 16-beam lidar, {over['48']:.1f} "
        "against 48 beams), though its step leaves out the camera and the pilot. Where "
        "ir-sim's time goes (cProfile of its steps in this world): most of it in its status "
        f"update, where each of the {objects.pop()} objects (200 line obstacles, 30 circles, "
        "the robot), static ones included, checks arrival and collision in Python every step "
        "(the collisions come from one shapely tree query); the rest in stepping the objects "
        "and in the lidar (a shapely broad phase, then numpy). Its cost grows with the number "
        "of obstacles as Python objects, which is why 48 beams cost it no more than 16. Our "
        "rays and the sonar's cone check look only at the obstacles within their reach, in "
        "compiled code.\n\n"
        f"Where our time goes: sensing is {sensing * 100:.0f}% of a step (the sonar "
        f"{sonar * 100:.0f}%; the camera's compiled visibility test and one `Sighting` object "
        "per landmark seen; odometry; the `Observation` and its poses); the robot step and the "
        f"navigator take {robot * 100:.0f}% and {navigator * 100:.0f}% (the compiled swept-disc "
        "move, the limits, the new state; the pilot's compiled field and the monitor's "
        "window), and the rest is the simulation's own bookkeeping (events, the trajectory "
        f"row, the target check). Of the sonar's {parts['sonar ring (SonarRing.read)'] * 1e6:.1f}"
        f" µs, the {data['sonar_rays']} rays take the larger part; the rest is the check that "
        "makes each beam's reading exact, which gathers the candidates within the sonar's "
        "reach (segment ends, feet of perpendiculars, disc centres) once and tests them "
        "against the 16 beams.")


def _landmarks_sizes(search: str = "best") -> tuple[str, str]:
    """The medians of the default options' ``search`` for queries of 2 to 4 landmarks and for
    6 to 8, as ranges in ms."""
    data = bench("landmarks_retrieval")
    by = {int(k): v for k, v in data["searches"]["partial"][search]["by_landmarks"].items()}
    few = [by[n] for n in (2, 3, 4) if n in by]
    many = [by[n] for n in (6, 7, 8) if n in by]
    if not few or not many:
        raise FiguresError("landmarks_retrieval.json: no medians for 2-4 or 6-8 landmarks")
    return f"{min(few):.2f} to {max(few):.2f} ms", f"{min(many):.1f} to {max(many):.1f} ms"


def _prefilter_speedup(data: dict[str, Any]) -> float:
    """How many times faster the landmark search for every case over the threshold is than
    the branch and bound over every stored graph (default options)."""
    partial = data["searches"]["partial"]
    return partial["scan"]["median"] / partial["all"]["median"]


def _all_equal(data: dict[str, Any]) -> str:
    """How many queries every search of every matching agreed with the full scan on."""
    counts = {v["equal_to_scan"] for kinds in data["searches"].values()
              for v in kinds.values() if "equal_to_scan" in v}
    return " and ".join(all_of(c) for c in sorted(counts))


def landmarks_retrieval_reading() -> str:
    data = bench("landmarks_retrieval")
    target, brute = data["target"], data["brute_force"]
    few, many = _landmarks_sizes()
    return (f"Reading against the target, **a median of {goal(target)} ms per "
            f"query over {grouped(data['stored'])} stored situations, for the retriever's "
            f"search (the best {data['best']}, default options): "
            f"{verdict(target['met'])}** ({target['measured']:.2f} ms{_loaded(data)}; {few} for "
            f"queries of 2 to 4 landmarks, {many} for 6 to 8). Every search, in both matchings, "
            f"returns what the branch and bound over every stored graph returns on "
            f"{_all_equal(data)} queries, and the brute force on "
            f"{all_of(brute['results_equal'])} it was run for; the search for every case over "
            f"the threshold is {_prefilter_speedup(data):.1f} times faster than that scan, the "
            f"index {grouped(brute['ratio'])} times faster than the brute force over "
            f"{brute['stored']} stored situations.")


def landmarks_retrieval_notes() -> str:
    """The bullets under the landmark page's benchmark tables."""
    data = bench("landmarks_retrieval")
    brute, prefilter, target = data["brute_force"], data["prefilter"], data["target"]
    few, many = _landmarks_sizes()
    every_few, every_many = _landmarks_sizes("all")
    hits = data["hits"]
    return "\n".join([
        "- **Nodes.** Over the small store, every graph and no threshold, the branch and bound "
        f"expanded {grouped(brute['branch_and_bound_nodes'])} nodes where the enumeration went "
        f"through {grouped(brute['exhaustive_mappings'])} matchings.",
        f"- **The prefilter** sends a median {prefilter['pass_rate_median'] * 100:.1f} % of the "
        f"stored graphs and {prefilter['reference_pairs_share_median'] * 100:.2f} % of their "
        "reference pairs to the branch and bound (a test of the supports alone would pass "
        f"{prefilter['supports_alone_pass_rate_median'] * 100:.2f} %), "
        f"{_prefilter_speedup(data):.1f} times "
        "faster than the branch and bound over every graph.",
        f"- **Every case over the threshold** costs more with `partial` matching: a view "
        f"finds a median {hits['partial']['median']:g} stored situations (mean "
        f"{hits['partial']['mean']:.0f}; `paper`: {hits['paper']['median']:g}), since a view "
        f"of many landmarks holds many sub-situations of a small case's size; that search "
        f"takes {every_few} for 2 to 4 landmarks and {every_many} for 6 to 8.",
        f"- **The best {data['best']}** found with `partial` matching are 2-landmark "
        f"situations in {grouped(data['best_landmarks'][0])} of "
        f"{grouped(sum(data['best_landmarks']))} cases (by landmark count, 2 to 8: "
        f"{', '.join(grouped(c) for c in data['best_landmarks'])}).",
        f"- **The target, a median of {goal(target)} ms per query over "
        f"{grouped(data['stored'])} stored situations for the retriever's search, is "
        f"{verdict(target['met'])}**: {target['measured']:.2f} ms over the benchmark's "
        f"mix{_loaded(data)}, {'and' if target['met_at_every_count'] else 'but not'} at "
        f"every landmark count. Queries of 2 to 4 landmarks, the size of 002's cases and of "
        f"our scenarios' views, take {few}; those of 6 to 8 landmarks {many}.",
    ])


def _loaded(data: dict[str, Any]) -> str:
    """`` on a loaded machine`` when other work kept at least one CPU busy as the run began
    (the 1-minute load average), else nothing: results written before the load was recorded
    say nothing either."""
    load = data.get("load_average")
    return " on a loaded machine" if load is not None and load["before"] >= 1.0 else ""


def rupart_retrieval_reading() -> str:
    data = bench("rupart_retrieval")
    target = data["target"]
    return (f"Reading against the target, **a median of {goal(target)} ms per "
            f"query over {grouped(data['cases'])} cases: {verdict(target['met'])}** "
            f"({target['measured']:.2f} ms{_loaded(data)}). CBRkit takes "
            f"{grouped(round(data['ratio'], -1))} times as long; both return the same five "
            f"cases in the same order on {all_of(data['agreement']['top5_equal'])} queries, and "
            "the table's distances equal the reference's"
            + ("." if data["reference"]["max_distance_difference"] == 0 else
               f" within {data['reference']['max_distance_difference']:.1g}."))


def rupart_retrieval_agreement() -> str:
    data = bench("rupart_retrieval")
    same = data["agreement"]["top5_equal"].split("/")
    return (f"CBRkit takes {grouped(round(data['ratio'], -1))} times as long and returns the "
            f"same five cases in the same order in {same[0]} of {same[1]} queries (largest "
            "difference of similarity "
            f"{data['agreement']['max_similarity_difference']:.1e}).")


def rupart_retrieval_by_size() -> str:
    """The table of retrieval time at the memory sizes the robot holds (table 2 of the
    results), and what it reads."""
    data = bench("rupart_retrieval")
    rows = data.get("by_size")
    if not rows:
        raise FiguresError("benchmarks/results/rupart_retrieval.json times no memory sizes "
                           "(by_size): run benchmarks/rupart_retrieval.py")
    medians = [row["nearest_ms"]["median"] for row in rows]
    ratios = [row["reference_over_nearest"] for row in rows]
    counts = [row["top5_equal"] for row in rows]
    # every query at every size reads as one phrase; anything less names each size's count
    same = (f"{all_of(counts[0])} queries at each size" if len(set(counts)) == 1
            else f"{listed([all_of(c) for c in counts])} queries")
    low, high = f"{min(medians):.2f}", f"{max(medians):.2f}"
    took = f"{low} ms" if low == high else f"{low} to {high} ms"
    return (table(result_md("rupart_retrieval"), 1) + "\n\n"
            f"At the {listed([str(row['cases']) for row in rows])} cases the robot's memory "
            f"holds, `nearest` takes a median of {took} per query, {min(ratios):.0f} to "
            f"{max(ratios):.0f} times less than the plain Python reference, and both find the "
            f"same five cases on {same}. Over {grouped(data['cases'])} cases CBRkit takes "
            f"{grouped(round(data['ratio'], -1))} times as long as `nearest`.")


def landmarks_config_reading() -> str:
    """The shipped landmark configuration on generated worlds against its target: at least
    95% of the trials in every held-out world."""
    worlds = bench("landmarks_config")["worlds"]
    held = [w for w in worlds if w["held_out"]]
    good = [w for w in held if w["reached"] >= 0.95 * w["trials"]]
    short = [w for w in held if w not in good]
    text = (f"On the {len(held)} held-out worlds {sum(w['reached'] for w in held)} of "
            f"{sum(w['trials'] for w in held)} trials reached the target, and "
            f"{len(good)} of the {len(held)} worlds reached it in at least 95% of their "
            f"trials (the target, every world: {verdict(not short)})")
    if short:
        text += "; short of it: " + ", ".join(
            f"{w['shape']} {w['seed']} ({w['reached']} of {w['trials']})" for w in short)
    return text + "."
