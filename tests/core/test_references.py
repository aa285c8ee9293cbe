"""Options that name other components: ``cbrcore.options.reference``.

The reuser ``chain`` below names solvers in five ways: one name, an optional one, a list, and
inside nested option classes, alone and in a list. Reading a configuration checks every name
against the registry, each problem located at its YAML path, line and column (counted by hand,
1-based).
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import attrs
import pytest
import yaml

import cbrcore.builtins
import toy_domain
from cbrcore import hookimpl
from cbrcore.config import _Marks, parse_config
from cbrcore.errors import ConfigError
from cbrcore.options import option, reference, referenced_names, references
from cbrcore.plugins import Plugins, load_plugins
from cbrcore.reference import config_reference
from cbrcore.registry import Registry
from cbrcore.testing import CliResult

SOLVERS = "registered: compute (plugin toy), direct (plugin chain)"


@attrs.frozen
class Stage:
    solver: str = reference("solver", "compute", "The solver of this stage.")
    tries: int = option(1, "How often the stage is tried.")


@attrs.frozen
class ChainOptions:
    connector: str = reference("solver", "compute", "The solver joining the pieces.")
    fallback: str | None = reference("solver", None, "The solver used when joining fails.")
    improvers: list[str] = reference("solver", doc="Solvers shortening the joined path.",
                                     factory=list)
    first: Stage = option(Stage(), "The first stage.")
    stages: list[Stage] = option(doc="The stages after the first.", factory=list)


class Chain:
    """Join the pieces of retrieved cases with solvers."""

    def __init__(self, options: ChainOptions, ctx: object) -> None:
        self.options = options


@attrs.frozen
class StaleOptions:
    connector: str = reference("solver", "astar", "A solver that is not installed here.")


def only_direct(registry: Registry, name: str) -> str | None:
    """A ``fits`` check taking the solver ``direct`` alone."""
    return None if name == "direct" else f"{name!r} does not join pieces; direct does"


@attrs.frozen
class PickyOptions:
    connector: str = reference("solver", "direct", "The joining solver.", fits=only_direct)
    improvers: list[str] = reference("solver", doc="Improvers.", factory=list, fits=only_direct)


class ChainPlugin:
    """Registers the reusers ``chain``, ``stale`` and ``picky`` and the solver ``direct``."""

    @hookimpl
    def cbr_register(self, registry: Registry) -> None:
        registry.add("reuser", "chain", Chain, options=ChainOptions)
        registry.add("reuser", "stale", Chain, options=StaleOptions)
        registry.add("reuser", "picky", Chain, options=PickyOptions)
        registry.add("solver", "direct", toy_domain.Compute)


@pytest.fixture(scope="module")
def registry() -> Registry:
    plugins = load_plugins([("toy", toy_domain), ("core", cbrcore.builtins),
                            ("chain", ChainPlugin())], entry_points=False, environ={})
    assert plugins.failed == []
    return plugins.registry


def problems_of(text: str, registry: Registry) -> list[str]:
    with pytest.raises(ConfigError) as caught:
        parse_config(yaml.safe_load(text), registry,
                     marks=_Marks(yaml.compose(text, Loader=yaml.SafeLoader)))
    return caught.value.problems


def test_references_lists_every_referring_option() -> None:
    assert list(references(ChainOptions)) == [
        ("connector", "solver"), ("fallback", "solver"), ("improvers", "solver"),
        ("first.solver", "solver"), ("stages.solver", "solver")]
    assert list(references(Stage)) == [("solver", "solver")]


def test_referenced_names_walks_lists_and_nested_options() -> None:
    options = ChainOptions(improvers=["a", "b"], stages=[Stage(), Stage("c")])
    assert list(referenced_names(options, "reuse")) == [
        ("reuse.connector", "solver", "compute"), ("reuse.improvers.0", "solver", "a"),
        ("reuse.improvers.1", "solver", "b"), ("reuse.first.solver", "solver", "compute"),
        ("reuse.stages.0.solver", "solver", "compute"), ("reuse.stages.1.solver", "solver", "c")]


def test_registered_names_are_accepted(registry: Registry) -> None:
    config = parse_config({"reuse": {"use": "chain", "connector": "direct", "fallback": "compute",
                                     "improvers": ["direct"], "stages": [{"solver": "direct"}]}},
                          registry)
    assert config.reuse is not None
    assert config.reuse.options == ChainOptions("direct", "compute", ["direct"],
                                                stages=[Stage("direct")])


@pytest.mark.parametrize(("text", "problem"), [
    ("reuse: {use: chain, connector: astr}\n",
     f"reuse.connector (line 1, column 32): unknown solver 'astr'; {SOLVERS}"),
    ("reuse:\n  use: chain\n  fallback: astr\n",
     f"reuse.fallback (line 3, column 13): unknown solver 'astr'; {SOLVERS}"),
    ("reuse:\n  use: chain\n  improvers: [direct, astr]\n",
     f"reuse.improvers.1 (line 3, column 23): unknown solver 'astr'; {SOLVERS}"),
    ("reuse:\n  use: chain\n  first: {solver: astr}\n",
     f"reuse.first.solver (line 3, column 19): unknown solver 'astr'; {SOLVERS}"),
    ("reuse:\n  use: chain\n  stages:\n    - {tries: 2}\n    - {solver: astr}\n",
     f"reuse.stages.1.solver (line 5, column 16): unknown solver 'astr'; {SOLVERS}"),
    ("reuse: stale\n", f"reuse.connector (line 1, column 8): unknown solver 'astar'; {SOLVERS}"),
])
def test_an_unknown_name_is_located(registry: Registry, text: str, problem: str) -> None:
    """A written name is located where it is written; a default naming an unknown component
    is reported at its option, located where the component is written."""
    assert problems_of(text, registry) == [problem]


@pytest.mark.parametrize(("text", "problem"), [
    ("reuse: {use: picky, connector: compute}\n",
     "reuse.connector (line 1, column 32): 'compute' does not join pieces; direct does"),
    ("reuse: {use: picky, connector: astr}\n",
     "reuse.connector (line 1, column 32): 'astr' does not join pieces; direct does"),
    ("reuse: {use: picky, improvers: [direct, compute]}\n",
     "reuse.improvers.1 (line 1, column 41): 'compute' does not join pieces; direct does"),
])
def test_fits_narrows_the_components_an_option_takes(registry: Registry, text: str,
                                                     problem: str) -> None:
    """A registered name that does not fit, and an unknown one, get the option's own message."""
    assert problems_of(text, registry) == [problem]
    assert parse_config({"reuse": {"use": "picky", "improvers": ["direct"]}},
                        registry).reuse is not None


def test_option_problems_come_before_reference_checks(registry: Registry) -> None:
    """A value of the wrong type is reported as such, not as an unknown name."""
    assert problems_of("reuse: {use: chain, connector: 3}\n", registry) == [
        "reuse.connector (line 1, column 32): expected a string, got 3"]


def test_validate_names_the_unknown_solver(cbr_plugins: Callable[..., Plugins],
                                           invoke_cbr: Callable[..., CliResult],
                                           tmp_path: Path) -> None:
    cbr_plugins(("toy", toy_domain), ("core", cbrcore.builtins), ("chain", ChainPlugin()))
    path = tmp_path / "run.yaml"
    path.write_text("seed: 1\nsolver: compute\nreuse:\n  use: chain\n  connector: astr\n",
                    encoding="utf-8")

    result = invoke_cbr("validate", str(path))

    assert result.exit_code == 2
    assert result.stderr == (f"error: {path}: 1 problem:\n  - reuse.connector (line 5, column "
                             f"14): unknown solver 'astr'; {SOLVERS}\n")


def test_a_reference_to_a_kind_nobody_declares_fails_the_plugin() -> None:
    @attrs.frozen
    class Misnamed:
        stage: Stage = option(Stage(), "A stage.")
        connector: str = reference("solvr", "compute", "A misspelt kind.")

    class Plugin:
        @hookimpl
        def cbr_register(self, registry: Registry) -> None:
            registry.add("reuser", "misnamed", Chain, options=Misnamed)

    with pytest.warns(UserWarning, match="plugin 'bad' failed to register"):
        plugins = load_plugins([("toy", toy_domain), ("bad", Plugin())], entry_points=False,
                               environ={})
    [failure] = plugins.failed
    assert failure.error.startswith("reuser 'misnamed': option 'connector' refers to kind "
                                    "'solvr', which no plugin declares; kinds: experiment, ")
    assert [p.name for p in plugins.loaded] == ["toy"]


def test_a_reference_to_a_kind_a_later_plugin_declares_is_fine() -> None:
    @attrs.frozen
    class GaugeOptions:
        gauge: str = reference("gauge", "plain", "The gauge it reads.")

    class Reader:
        @hookimpl
        def cbr_register(self, registry: Registry) -> None:
            registry.add("reuser", "reader", Chain, options=GaugeOptions)

    class Gauges:
        @hookimpl
        def cbr_register(self, registry: Registry) -> None:
            registry.add_kind("gauge", "a measuring instrument")
            registry.add("gauge", "plain", toy_domain.Compute)

    plugins = load_plugins([("a", Reader()), ("b", Gauges()), ("core", cbrcore.builtins)],
                           entry_points=False, environ={})
    assert plugins.failed == []
    assert parse_config({"reuse": "reader"}, plugins.registry).reuse is not None


def test_options_whose_annotations_do_not_resolve_are_refused() -> None:
    broken = attrs.make_class("Broken", {"x": attrs.field(type="NoSuchType", default=1)})

    class Plugin:
        @hookimpl
        def cbr_register(self, registry: Registry) -> None:
            registry.add("reuser", "broken", Chain, options=broken)

    with pytest.warns(UserWarning):
        plugins = load_plugins([("bad", Plugin())], entry_points=False, environ={})
    assert plugins.failed[0].error == ("PluginError: reuser 'broken': the annotations of Broken "
                                       "do not resolve: name 'NoSuchType' is not defined")


def test_the_reference_shows_the_kind_an_option_names(registry: Registry) -> None:
    text = config_reference(registry)
    chain = text[text.index("### `chain`"):text.index("### `stale`")]
    assert "| `connector` | str naming a solver | `'compute'` | The solver joining the pieces. |" \
        in chain
    assert "| `fallback` | str \\| None naming a solver | `None` |" in chain
    assert "| `improvers` | list[str] naming a solver | `[]` |" in chain
    # a nested options class's options follow, by their dotted paths
    assert "| `first.solver` | str naming a solver | `'compute'` | The solver of this stage. |" \
        in chain
    assert "| `stages[].tries` | int | `1` | How often the stage is tried. |" in chain
    assert "| `tries` |" not in chain
