"""The fleet experiment on the reproductions page: what sharing one case base is worth, how fast
the fleet learns and whether anything was lost."""

from __future__ import annotations

from .results import kept_results
from .wording import verdict


def fleet_reading() -> str:
    """The targets of the fleet experiment, as its kept run shows them."""
    results = kept_results("fleet")
    targets = results["targets"]
    integrity, throughput = targets["integrity"], targets["throughput"]
    shared = {(row["store"], row["robots"]): row for row in results["rows"]
              if row["mode"] == "shared"}
    largest = integrity["robots"]
    steps = ", ".join(f"{row['learn_steps']:,} on {store}"
                      for (store, n), row in sorted(shared.items()) if n == largest)
    lines = [
        f"- **Integrity** ({largest} robots sharing one case base, {steps}): "
        + ("no lost step, no uncovered path step, every check passed and the replay equal, "
           "in every fleet" if integrity["sound"] else "a fleet LOST or broke something")
        + f": {verdict(integrity['met'])} (wanted: 0 lost with 8 learners on both stores over "
          f"at least {integrity['wanted_learn_steps']:,} learn steps).",
        f"- **Throughput**: 2 robots sharing a SQLite case base learn "
        f"{throughput['sqlite_2_over_1_robot']:.2f}x as many steps per second as one robot on "
        f"{throughput['cores']} cores: {verdict(throughput['met'])} (wanted: at least "
        f"{throughput['wanted']}x).",
    ]
    if results.get("postgres_absent"):
        lines.append(f"- PostgreSQL rows absent: {results['postgres_absent']}.")
    return "\n".join(lines)
