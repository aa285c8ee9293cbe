"""RUPART behavior cases (Fox, 004): unified case-based reasoning for a message-delivery robot.

One case memory holds behavior cases (004 Figure 4: which primitive behaviors to activate,
their parameters and priorities), plan cases (high-level routes), meta-plans (fall-back
behaviors) and adaptation strategies (:mod:`cbr_behaviors.casetypes`, written in YAML or the
paper's s-expressions, :mod:`cbr_behaviors.sexpr`); one retrieval reads it, over the index of
Figure 5 (:mod:`cbr_behaviors.index`, :mod:`cbr_behaviors.memory`). The robot works days of
message delivery on an office floor (:mod:`cbr_behaviors.delivery`): messages become goals
(:mod:`cbr_behaviors.messages`, :mod:`cbr_behaviors.goals`), a global map keeps transient
objects (:mod:`cbr_behaviors.globalmap`), and re-planning triggers
(:mod:`cbr_behaviors.triggers`) consult the engine.

Registers the ``rupart`` retriever and reuser, the ``rupart_cases`` and ``rupart_weights``
retainers, the ``rupart_quality`` forgetter, the ``delivery`` workload, the experiment
``rupart-delivery`` and the ``cbr rupart`` commands. See docs/rupart.md.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from cbrcore.hookspecs import hookimpl

if TYPE_CHECKING:
    import typer

    from cbrcore.context import Context
    from cbrcore.registry import Registry

_COMPONENTS = "cbr_behaviors.components"


def _delivery_experiment(options: object, ctx: Context) -> object:
    # the engine, the simulator and the grid planners load when the experiment runs
    from cbr_behaviors.experiments.delivery import DeliveryExperiment

    return DeliveryExperiment(options, ctx)


@hookimpl
def cbr_register(registry: Registry) -> None:
    # named, not imported: the components load when a configuration uses them. Situations
    # and behaviors, not a floor's cells: the cases hold on any office floor
    registry.add("retriever", "rupart", f"{_COMPONENTS}:RupartRetriever",
                 options=f"{_COMPONENTS}:RetrieveOptions", world_independent=True)
    registry.add("reuser", "rupart", f"{_COMPONENTS}:RupartReuser",
                 options=f"{_COMPONENTS}:ReuseOptions", world_independent=True)
    registry.add("retainer", "rupart_cases", f"{_COMPONENTS}:CaseLearner",
                 options=f"{_COMPONENTS}:RetainOptions", world_independent=True)
    registry.add("retainer", "rupart_weights", f"{_COMPONENTS}:WeightLearner",
                 options=f"{_COMPONENTS}:WeightOptions", world_independent=True)
    registry.add("forgetter", "rupart_quality", f"{_COMPONENTS}:QualityForgetter",
                 options=f"{_COMPONENTS}:ForgetOptions", world_independent=True)
    registry.add("workload", "delivery", "cbr_behaviors.delivery:Delivery",
                 options="cbr_behaviors.delivery:DeliveryOptions")
    registry.add("experiment", "rupart-delivery", _delivery_experiment,
                 doc="004's delivery robot evaluated: a fixed behavior set against CBR "
                 "selection, with adaptation and learning, and with learned weights, over "
                 "seeds.")


@hookimpl
def cbr_cli(app: typer.Typer) -> None:
    """``cbr rupart add`` and ``cbr rupart show``."""
    from cbr_behaviors.cli import add_commands

    add_commands(app)
