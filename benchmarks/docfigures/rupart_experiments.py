"""RUPART: the delivery evaluation's header and reading, each target against what was measured."""

from __future__ import annotations

from typing import Any

from .results import kept, kept_results


def delivery() -> dict[str, Any]:
    return kept_results("rupart-delivery")


def delivery_header() -> str:
    results = delivery()
    seeds, tuning = results["seeds"], results["tuning_seeds"]
    days = {1: "one day", 2: "two days"}.get(results["days"], f"{results['days']} days")
    return (f"Measured (`{kept('rupart-delivery')['command']}`): office floors {seeds[0]} to "
            f"{seeds[-1]}, which no tuning saw (tuning used floors {tuning[0]} to "
            f"{tuning[-1]}), {days} in a row of {results['length'] / 60:.0f} minutes each; per "
            "day, mean ± sd over the floors:")


def _interval(s: dict[str, Any]) -> str:
    return f"{s['mean']:+.2f} [{s['low']:+.2f}, {s['high']:+.2f}]"


def _met(ok: bool) -> str:
    return "met" if ok else "**not met**"


def delivery_reading() -> str:
    results = delivery()
    s, paired, learning = results["summary"], results["paired"], results["learning"]

    def mean(arm: str, measure: str) -> float:
        return s[arm][measure]["mean"]

    base = mean("best-fixed", "delivered")
    lines = []
    for arm in ("cbr-learning", "cbr"):
        d = paired[arm]["delivered"]
        ratio = mean(arm, "delivered") / base if base else float("nan")
        fewer = mean(arm, "collisions") <= mean("best-fixed", "collisions")
        lines.append(
            f"- **`{arm}` against `best-fixed`**: {mean(arm, 'delivered'):.2f} against "
            f"{base:.2f} messages delivered on time a day, {ratio:.2f} times as many (target "
            f"1.25 for `cbr-learning`, above 1 for `cbr`: "
            f"{_met(ratio >= (1.25 if arm == 'cbr-learning' else 1.0) and d['low'] > 0)}); "
            f"paired per floor {_interval(d)}; collisions of the robot's "
            f"{mean(arm, 'collisions'):.2f} against {mean('best-fixed', 'collisions'):.2f} "
            f"({_met(fewer)}).")
    rate = max(mean(arm, "retrievals_per_minute") for arm in ("cbr", "cbr-learning"))
    install = min(mean(arm, "median_install") for arm in ("cbr", "cbr-learning"))
    stall = max(s[arm]["longest_stall"]["max"] for arm in ("cbr", "cbr-learning"))
    lines.append(f"- **Re-planning**: at most {rate:.1f} retrievals a minute (target 6: "
                 f"{_met(rate <= 6.0)}), a case installed {install:.1f} s at the median "
                 f"(target 5: {_met(install >= 5.0)}); the longest stall away from shut doors "
                 f"{stall:.0f} s (target 60: {_met(stall <= 60.0)}).")
    for arm, figures in learning.items():
        gain = figures["gain"]
        lines.append(f"- **Learning, `{arm}`**: {figures['first']['mean']:.2f} delivered on the "
                     f"first day, {figures['last']['mean']:.2f} on day {results['days']}; "
                     f"paired gain {_interval(gain)} (target: above 0, "
                     f"{_met(gain['low'] > 0)}).")
    empty = results["empty"]
    parts = [f"`{arm}` {row['delivered']:.0f} of {row['messages']:.0f} at "
             f"{row['busy_speed']:.2f} m/s" for arm, row in empty.items()]
    ok = all(empty[arm]["delivered"] >= 15 and empty[arm]["busy_speed"] >= 0.2
             for arm in ("cbr", "cbr-learning"))
    lines.append("- **The empty floor, doors open**: " + ", ".join(parts)
                 + f" (target for the CBR arms 15 of 17 at 0.2 m/s: {_met(ok)}).")
    return "\n".join(lines)
