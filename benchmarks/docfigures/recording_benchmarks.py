"""The prose of the recording's cost: what recording adds to the main job and to a delivery
day, against the target."""

from __future__ import annotations

from .results import bench


def recording_cost_reading() -> str:
    data = bench("recording_cost")
    target = data["target"]
    parts = []
    for run in data["runs"]:
        unit = run["unit"]
        verdict = "within" if run["ratio"] <= 1 + target else "over"
        parts.append(
            f"{run['name']}: {100 * (run['ratio'] - 1):.1f}% of the run's time "
            f"({run[f'overhead_us_per_{unit}']:.0f} µs a {unit}, {verdict} the {target:.0%} "
            f"target), {run['bytes'] / 1e6:.1f} MB for {run['units']} {unit}s")
    return (f"Medians of {data['repeats']} runs a side, recorded and not, alternating in one "
            f"process: " + "; ".join(parts) + ".")
