"""Experiments: reproductions that plugins register and ``cbr experiment`` runs.

An experiment is a component of kind ``experiment`` whose instance has a ``run`` method.
:func:`run_experiment` writes what it returns into the output folder: ``results.json``,
``results.md`` (the markdown table, usually the paper's numbers beside ours), one PNG per
figure, and ``manifest.json``; each file appears whole or not at all (:mod:`cbrcore.files`).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any, Literal, Protocol, runtime_checkable

import attrs
import numpy as np

from cbr_experiments.tasks import TASKS, LocalTasks, TaskRunner
from cbrcore import files
from cbrcore.context import Context
from cbrcore.engine import output_folder
from cbrcore.errors import CbrError, PluginError
from cbrcore.plugins import Plugins
from cbrcore.run import manifest, write_json, writing

Size = Literal["ci", "full"]


@attrs.frozen
class ExperimentResult:
    """What an experiment produced: data, a markdown table and matplotlib figures by file stem."""

    results: Mapping[str, Any]
    table: str
    figures: Mapping[str, Any] = attrs.field(factory=dict)


@runtime_checkable
class Experiment(Protocol):
    """A registered experiment."""

    def run(self, size: Size, out_dir: Path, progress: Callable[[int, int], None]
            ) -> ExperimentResult:
        """Run at ``size`` (``ci``: minutes at most, for the test suite; ``full``: the paper's
        scale), calling ``progress(done, total)`` with no work done as soon as the total is
        known (a display shows it from then on), then as work completes.

        Independent work goes through :func:`cbr_experiments.tasks.task_runner` of the factory's
        context, so that ``cbr experiment --scheduler`` can spread it over processes or
        machines."""
        ...


def spread(values: Sequence[float]) -> dict[str, float | None]:
    """Mean, standard deviation (n - 1; 0 for one value), minimum and maximum of ``values``,
    as an experiment reports a figure over seeds; None for no values (results.json stays
    strict JSON)."""
    if not len(values):
        return {"mean": None, "std": None, "min": None, "max": None}
    array = np.asarray(values, dtype=float)
    return {"mean": float(array.mean()),
            "std": float(array.std(ddof=1)) if len(array) > 1 else 0.0,
            "min": float(array.min()), "max": float(array.max())}


def run_experiment(name: str, plugins: Plugins, *, size: Size, out_dir: Path, seed: int = 0,
                   progress: Callable[[int, int], None] | None = None,
                   tasks: TaskRunner | None = None) -> list[Path]:
    """Run the experiment ``name`` and write its files into ``out_dir``; return their paths.

    ``tasks`` runs the experiment's independent tasks (:mod:`cbr_experiments.tasks`; default:
    :class:`~cbr_experiments.tasks.LocalTasks`); the experiment finds it with
    :func:`~cbr_experiments.tasks.task_runner`. The results do not depend on it.
    """
    component = plugins.registry.get("experiment", name)
    ctx = Context(registry=plugins.registry, seed=seed, out_dir=out_dir)
    runner = tasks if tasks is not None else LocalTasks()
    ctx.stash[TASKS] = runner
    output_folder(out_dir)
    try:
        experiment = component.factory(component.options(), ctx)
        result = experiment.run(size, out_dir, progress or (lambda done, total: None))
    except CbrError:
        raise
    except Exception as exc:
        raise PluginError(f"experiment {name!r} (plugin {component.plugin!r}) failed: "
                          f"{type(exc).__name__}: {exc}") from exc
    if not isinstance(result, ExperimentResult):
        raise PluginError(f"experiment {name!r} returned {type(result).__name__}, "
                          "expected ExperimentResult")
    written = [out_dir / "results.json", out_dir / "results.md", out_dir / "manifest.json"]
    write_json(written[0], dict(result.results))
    with writing(written[1]):
        files.write_text(written[1], result.table.rstrip() + "\n")
    write_json(written[2], manifest(None, plugins, seed=seed,
                                    extra={"experiment": name, "size": size,
                                           "tasks": runner.description}))
    for stem, figure in result.figures.items():
        path = out_dir / f"{stem}.png"
        with writing(path), files.replacing(path, "wb") as image:
            figure.savefig(image, format="png", dpi=120, bbox_inches="tight")
        written.append(path)
    return written
