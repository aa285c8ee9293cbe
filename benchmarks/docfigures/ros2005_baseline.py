"""The navigation system without CBR (Ros et al. 2005, 002): what the kept trials of its
baseline say on the reproductions and 2D world pages."""

from __future__ import annotations

import math
import statistics
from collections import Counter
from typing import Any

from .results import KEPT, FiguresError, load_json

#: the kept baseline, docs/figures/<BASELINE>.json, and how it is run
BASELINE = "ros2005-baseline"
BASELINE_TRIALS = 100
BASELINE_TIMEOUT = 300.0


#: 002's Figure 6 and its optimal paths, for the rows beside ours
ROS_2005_PAPER = {"scenario1": {"reached": "not given", "time": 162.36, "distance": 802.13,
                                "optimal": (107.0, 539.82)},
                  "scenario2": {"reached": "none", "time": None, "distance": None,
                                "optimal": (173.69, 868.46)}}


def _kept() -> dict[str, Any]:
    """The kept baseline: ``trials`` and ``timeout``, and per scenario its ``landmarks`` and
    ``trials``."""
    return load_json(KEPT / f"{BASELINE}.json")


def _trials() -> dict[str, list[dict[str, Any]]]:
    data = _kept()
    try:
        return {name: scenario["trials"] for name, scenario in data["scenarios"].items()}
    except (KeyError, TypeError):
        raise FiguresError(f"docs/figures/{BASELINE}.json: no trials per scenario") from None


def _reached(trials: list[dict[str, Any]]) -> list[dict[str, Any]]:
    return [trial for trial in trials if trial["success"]]


def baseline_output() -> str:
    """What the page's ``baseline.py`` prints, from the kept trials."""
    lines = ["```text"]
    for name, trials in _trials().items():
        reached = _reached(trials)
        lines.append(f"{name}: reached {len(reached)} of {len(trials)}")
        if reached:
            lines.append(f"  mean time {statistics.mean(t['time'] for t in reached):.2f} s, "
                         f"mean distance "
                         f"{statistics.mean(100 * t['distance'] for t in reached):.2f} cm")
    return "\n".join([*lines, "```"])


def baseline_table() -> str:
    lines = ["| scenario | | reached | mean time (s) | mean distance (cm) |",
             "|---|---|---|---|---|"]
    collisions = 0
    for name, trials in _trials().items():
        number = name.removeprefix("scenario")
        paper = ROS_2005_PAPER[name]
        reached = _reached(trials)
        collisions += sum(trial["collisions"] for trial in trials)

        def cell(value: float | None) -> str:
            return "-" if value is None else f"{value:.2f}"

        lines.append(f"| {number} | 002, without CBR | {paper['reached']} | "
                     f"{cell(paper['time'])} | {cell(paper['distance'])} |")
        if reached:
            times = [t["time"] for t in reached]
            cms = [100 * t["distance"] for t in reached]
            ours = (f"{statistics.mean(times):.2f} ({min(times):.1f}-{max(times):.1f}) | "
                    f"{statistics.mean(cms):.2f} ({min(cms):.1f}-{max(cms):.1f})")
        else:
            ours = "- | -"
        lines.append(f"| {number} | ours, without CBR | {len(reached)} of {len(trials)} | "
                     f"{ours} |")
        time, distance = paper["optimal"]
        lines.append(f"| {number} | optimal (002) | | {time:g} | {distance:.2f} |")
    note = ("No collision in any trial." if collisions == 0 else
            f"{collisions} collisions over all trials.")
    return "\n".join(lines) + f"\n\n(Minimum-maximum in brackets. {note})"


def first_way(trial: dict[str, Any], landmarks: dict[str, list[float]]) -> str | None:
    """The landmark nearest the trial's first diverting target: the way it was sent round."""
    if not trial["diverting"]:
        return None
    x, y = trial["diverting"][0]
    return min(landmarks, key=lambda k: math.dist((x, y), landmarks[k]))


def baseline_reading() -> str:
    data = _kept()
    one, two = data["scenarios"]["scenario1"], data["scenarios"]["scenario2"]
    reached = _reached(one["trials"])
    paper = ROS_2005_PAPER["scenario1"]
    time = statistics.mean(t["time"] for t in reached)
    distance = statistics.mean(100 * t["distance"] for t in reached)
    ways = Counter(first_way(t, one["landmarks"]) for t in reached)

    def faster(ours: float, theirs: float) -> str:
        change = (1 - ours / theirs) * 100
        return f"{abs(change):.0f}% {'less' if change >= 0 else 'more'}"

    groups = []
    for way, count in ways.most_common():
        chosen = [t for t in reached if first_way(t, one["landmarks"]) == way]
        groups.append((way, count, statistics.mean(t["time"] for t in chosen),
                       statistics.mean(t["distance"] for t in chosen)))
    short, *others = groups
    split = (f"In {short[1]} trials the first diversion goes past `{short[0]}`, the short way "
             f"({short[2]:.0f} s and {short[3]:.1f} m on average)")
    for way, count, mean_time, mean_distance in others:
        split += (f"; in {count} the sonar's noise makes it turn the other way, towards "
                  f"`{way}`, and a second diversion is needed ({mean_time:.0f} s, "
                  f"{mean_distance:.1f} m)")
    failed = len(two["trials"]) - len(_reached(two["trials"]))
    second = ("fails every trial" if failed == len(two["trials"]) else
              f"fails {failed} of {len(two['trials'])} trials")
    return (f"- **Scenario 1** takes {faster(time, paper['time'])} time than 002's and "
            f"{faster(distance, paper['distance'])} distance. The robot drives straight at the "
            "linear obstacle, is reported blocked in front of it and the Rescuer diverts it "
            f"past an end. {split}. 002 does not say which way round its robot went.\n"
            f"- **Scenario 2** {second}, as in 002 (\"the current system (without CBR) is not "
            "able to finish any trial\"): the robot drives into the V, the Rescuer's diverting "
            "targets lead back towards its mouth and the pilot drives straight back in. 002 "
            f"gives no timeout (\"a given time\"); ours is {data['timeout']:.0f} s.\n"
            "- The layouts are ours (002 gives no coordinates), set so that the shortest paths "
            "are 002's optimal distances; scenario 2 is a V of two linear obstacles.")


def baseline_world2d() -> str:
    """The 2D world page's summary of the baseline."""
    data = _kept()
    trials = _trials()
    one, two = _reached(trials["scenario1"]), _reached(trials["scenario2"])
    paper = ROS_2005_PAPER["scenario1"]
    if len(one) == len(trials["scenario1"]):
        first = (f"reaches scenario 1's target every time, in "
                 f"{statistics.mean(t['time'] for t in one):.2f} s over "
                 f"{statistics.mean(100 * t['distance'] for t in one):.2f} cm on average")
    else:
        first = (f"reaches scenario 1's target in {len(one)} of {len(trials['scenario1'])} "
                 "trials" + (f", in {statistics.mean(t['time'] for t in one):.2f} s over "
                             f"{statistics.mean(100 * t['distance'] for t in one):.2f} cm on "
                             "average" if one else ""))
    second = "none" if not two else f"{len(two)} of {len(trials['scenario2'])}"
    return (f"**Against 002.** Over {data['trials']} trials each (002 ran 100 per scenario; ours "
            "differ by the sensor noise's seed), the navigation system without CBR with 002's "
            f"robot {first}, against 002's {paper['time']:.2f} s and {paper['distance']:.2f} cm "
            f"(Figure 6); and it reaches scenario 2's target in {second}, at a timeout of "
            f"{data['timeout']:.0f} s, where 002 reports that it \"is not able to finish any "
            "trial\". The command and the details are in "
            "[Reproductions](reproductions.md#ros-et-al-2005-002-the-navigation-system-without-"
            "cbr).")
