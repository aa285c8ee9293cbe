"""The prose of the recording's cost: what recording adds to the main job and to a delivery
day, against the target."""

from __future__ import annotations

from .results import bench


def recording_cost_reading() -> str:
    data = bench("recording_cost")
    target = data["target"]
    parts, others = [], []
    for run in data["runs"]:
        unit = run["unit"]
        share = f"{100 * (run['ratio'] - 1):.1f}% of the run's time"
        cost = f"{run[f'overhead_us_per_{unit}']:.0f} µs a {unit}"
        if run["targeted"]:
            verdict = "within" if run["ratio"] <= 1 + target else "over"
            parts.append(f"{run['name']}: {share} ({cost}, {verdict} the {target:.0%} target), "
                         f"{run['bytes'] / 1e6:.1f} MB for {run['units']} {unit}s")
        else:
            others.append(f"{run['name']}, whose whole run takes {run['median_off']:.2f} s, "
                          f"pay {share} ({cost})")
    reading = (f"Medians of {data['repeats']} runs a side, recorded and not, alternating in "
               f"one process: " + "; ".join(parts) + ".")
    if others:
        reading += (" Outside the target, the " + "; ".join(others) + ": their simulation "
                    "step is a few times cheaper than a delivery day's, while a recorded "
                    "instant costs the same.")
    return reading
