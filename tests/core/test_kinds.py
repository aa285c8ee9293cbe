"""Component kinds that plugins declare, and the top-level slots those kinds own.

cbrcore declares the kinds its engine uses; a plugin declares more with ``registry.add_kind``.
Plugins register in name order, so the kinds are checked once all have registered. The test
plugins below declare the kind ``gauge`` (a run-wide measuring instrument), which owns the slot
``gauge`` with the default ``plain``.
"""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path
from typing import Any

import attrs
import pytest
import yaml

import cbrcore.builtins
import toy_domain
from cbrcore import hookimpl
from cbrcore.config import ComponentRef, _Marks, config_from_text, parse_config
from cbrcore.errors import ConfigError, PluginError
from cbrcore.options import option
from cbrcore.plugins import Plugins, load_plugins
from cbrcore.reference import config_reference
from cbrcore.registry import KINDS, Kind, NoOptions, Registry, Slot
from cbrcore.stash import StashKey
from cbrcore.testing import CliResult

GAUGE = StashKey[Any]()
CORE_KINDS = ("experiment, forgetter, metric, observer, retainer, retriever, reuser, reviser, "
              "solver, store, workload, world")


@attrs.frozen
class PreciseOptions:
    digits: int = option(2, "Digits after the point.", validator=attrs.validators.ge(0))


class Plain:
    """Reads to the unit."""

    def __init__(self, options: object, ctx: object) -> None:
        pass


class Precise:
    """Reads to the given digits."""

    def __init__(self, options: PreciseOptions, ctx: object) -> None:
        self.digits = options.digits


class Declares:
    """Declares the kind ``gauge`` with ``declare`` (keyword arguments of ``add_kind``)."""

    def __init__(self, **declare: Any) -> None:
        self.declare = declare

    @hookimpl
    def cbr_register(self, registry: Registry) -> None:
        registry.add_kind("gauge", "a run-wide measuring instrument", **self.declare)


class Gauges:
    """Registers the gauges ``plain`` and ``precise``."""

    @hookimpl
    def cbr_register(self, registry: Registry) -> None:
        registry.add("gauge", "plain", Plain)
        registry.add("gauge", "precise", Precise, options=PreciseOptions)


class DeclaresAndRegisters:
    """Declares ``gauge`` with its slot and registers both gauges: a whole family in one."""

    @hookimpl
    def cbr_register(self, registry: Registry) -> None:
        registry.add_kind("gauge", "a run-wide measuring instrument", slot="gauge",
                          default="plain", key=GAUGE)
        Gauges().cbr_register(registry)


class DeclaresThenRaises:
    """Declares ``gauge``, then fails."""

    @hookimpl
    def cbr_register(self, registry: Registry) -> None:
        registry.add_kind("gauge", "a run-wide measuring instrument")
        raise RuntimeError("calibration lost")


def load(*plugins: tuple[str, Any], environ: dict[str, str] | None = None) -> Plugins:
    return load_plugins(list(plugins), entry_points=False, environ=environ or {})


def problems_of(text: str, registry: Registry) -> list[str]:
    """The problems ``parse_config`` reports for the YAML ``text``."""
    with pytest.raises(ConfigError) as caught:
        parse_config(yaml.safe_load(text), registry,
                     marks=_Marks(yaml.compose(text, Loader=yaml.SafeLoader)))
    return caught.value.problems


@pytest.fixture
def gauges() -> Plugins:
    """The toy domain, the core stores and the gauge family with its slot."""
    return load(("core", cbrcore.builtins), ("gauges", DeclaresAndRegisters()),
                ("toy", toy_domain))


# -- declaring kinds --------------------------------------------------------------------------


def test_cbrcore_declares_only_its_own_kinds() -> None:
    registry = Registry()
    assert ", ".join(sorted(registry.kinds)) == CORE_KINDS
    assert set(KINDS) == set(registry.kinds)
    assert all(kind.plugin is None and kind.slot is None for kind in registry.kinds.values())
    assert registry.slots == {}


def test_a_plugin_declares_a_kind_and_registers_its_components(gauges: Plugins) -> None:
    assert gauges.failed == []
    kind = gauges.registry.kinds["gauge"]
    assert kind == Kind("gauge", "a run-wide measuring instrument", "gauges",
                        Slot("gauge", "gauge", "plain", GAUGE))
    assert gauges.registry.slots == {"gauge": kind.slot}
    assert list(gauges.registry.kinds)[-1] == "gauge"  # after cbrcore's own
    info = gauges.info("gauges")
    assert info.kinds == ("gauge",)
    assert info.components == ("gauge:plain", "gauge:precise")
    assert gauges.info("toy").kinds == ()


def test_components_may_come_before_the_plugin_declaring_their_kind() -> None:
    """Plugins register in name order: ``a_gauges`` registers gauges before ``b_kind``
    declares the kind, and both load."""
    plugins = load(("a_gauges", Gauges()), ("b_kind", Declares()))

    assert plugins.failed == []
    assert [p.name for p in plugins.loaded] == ["a_gauges", "b_kind"]
    assert plugins.registry.get("gauge", "precise").plugin == "a_gauges"
    assert plugins.registry.kinds["gauge"].plugin == "b_kind"


def test_components_of_a_kind_nobody_declares_fail_their_plugin() -> None:
    with pytest.warns(UserWarning, match="plugin 'gauges' failed to register"):
        plugins = load(("gauges", Gauges()), ("toy", toy_domain))

    assert [p.name for p in plugins.loaded] == ["toy"]
    [failure] = plugins.failed
    assert (failure.name, failure.stage) == ("gauges", "register")
    assert failure.error == (f"no plugin declares the component kind 'gauge' of plain, precise; "
                             f"kinds: {CORE_KINDS}")
    assert [c for c in plugins.registry if c.kind == "gauge"] == []
    assert plugins.pm.get_plugin("gauges") is None


def test_a_misspelt_core_kind_names_the_kinds() -> None:
    class Typo:
        @hookimpl
        def cbr_register(self, registry: Registry) -> None:
            registry.add("retreiver", "nearest", Plain)

    with pytest.warns(UserWarning):
        plugins = load(("typo", Typo()))
    [failure] = plugins.failed
    assert failure.error == (f"no plugin declares the component kind 'retreiver' of nearest; "
                             f"kinds: {CORE_KINDS}")


def test_an_undeclared_kind_is_fatal_when_strict() -> None:
    with pytest.raises(PluginError, match=r"^plugin 'gauges' failed to register: no plugin "
                                          r"declares the component kind 'gauge' of plain"):
        load(("gauges", Gauges()), environ={"CBR_STRICT_PLUGINS": "1"})


def test_the_users_of_a_failed_plugins_kind_fail_too() -> None:
    """A plugin that fails takes the kinds it declared with it, and then the plugins whose
    components are of those kinds."""
    with pytest.warns(UserWarning):
        plugins = load(("a_gauges", Gauges()), ("b_kind", DeclaresThenRaises()),
                       ("toy", toy_domain))

    assert [p.name for p in plugins.loaded] == ["toy"]
    assert [(f.name, f.stage) for f in plugins.failed] == [("b_kind", "register"),
                                                            ("a_gauges", "register")]
    assert plugins.failed[0].error == "RuntimeError: calibration lost"
    assert plugins.failed[1].error.startswith(
        "no plugin declares the component kind 'gauge' of plain, precise")
    assert "gauge" not in plugins.registry.kinds


def test_a_kind_declared_twice_fails_the_second_plugin() -> None:
    with pytest.warns(UserWarning, match="plugin 'second' failed to register"):
        plugins = load(("first", DeclaresAndRegisters()), ("second", Declares()))

    assert [p.name for p in plugins.loaded] == ["first"]
    [failure] = plugins.failed
    assert failure.error == ("PluginError: component kind 'gauge' is already declared by "
                             "plugin 'first'")
    assert plugins.registry.kinds["gauge"].plugin == "first"


def test_a_core_kind_cannot_be_declared_again() -> None:
    class Solvers:
        @hookimpl
        def cbr_register(self, registry: Registry) -> None:
            registry.add_kind("solver", "my own solvers")

    with pytest.warns(UserWarning):
        plugins = load(("mine", Solvers()))
    assert plugins.failed[0].error == ("PluginError: component kind 'solver' is already declared "
                                       "by cbrcore")


@pytest.mark.parametrize(("declare", "error"), [
    ({"slot": "gauge"}, "component kind 'gauge': a slot needs a StashKey to store its component "
                        "under, and a key needs a slot"),
    ({"key": GAUGE}, "component kind 'gauge': a slot needs a StashKey to store its component "
                     "under, and a key needs a slot"),
    ({"default": "plain"}, "component kind 'gauge': a default needs a slot"),
    ({"slot": "seed", "key": GAUGE},
     "component kind 'gauge': slot 'seed' is a key of cbrcore's own configuration"),
    ({"slot": "retrieve", "key": GAUGE},
     "component kind 'gauge': slot 'retrieve' is a key of cbrcore's own configuration"),
    ({"slot": "gauge.main", "key": GAUGE},
     "component kind 'gauge': slot 'gauge.main' must be a name of letters, digits and "
     "underscores"),
    ({"slot": "gauge", "key": "gauge"},
     "component kind 'gauge': key must be a cbrcore.stash.StashKey, got 'gauge'"),
])
def test_a_slot_declaration_is_checked(declare: dict[str, Any], error: str) -> None:
    with pytest.warns(UserWarning):
        plugins = load(("gauges", Declares(**declare)))
    [failure] = plugins.failed
    assert (failure.stage, failure.error) == ("register", f"PluginError: {error}")
    assert "gauge" not in plugins.registry.kinds


@pytest.mark.parametrize(("name", "doc", "error"), [
    ("robot arm", "an arm", "component kind 'robot arm': expected a name of letters, digits and "
                            "underscores"),
    ("arm", " ", "component kind 'arm': the doc must say what a component of the kind provides"),
])
def test_a_kind_has_a_plain_name_and_a_doc(name: str, doc: str, error: str) -> None:
    class Arms:
        @hookimpl
        def cbr_register(self, registry: Registry) -> None:
            registry.add_kind(name, doc)

    with pytest.warns(UserWarning):
        plugins = load(("arms", Arms()))
    assert plugins.failed[0].error == f"PluginError: {error}"


def test_a_slot_is_owned_by_one_kind() -> None:
    class Meters:
        @hookimpl
        def cbr_register(self, registry: Registry) -> None:
            registry.add_kind("meter", "another instrument", slot="gauge", key=StashKey[Any]())

    with pytest.warns(UserWarning):
        plugins = load(("a", DeclaresAndRegisters()), ("b", Meters()))
    assert plugins.failed[0].error == ("PluginError: component kind 'meter': slot 'gauge' is "
                                       "already taken by kind 'gauge' of plugin 'a'")


def test_a_slot_default_nobody_registers_fails_the_declaring_plugin() -> None:
    with pytest.warns(UserWarning):
        plugins = load(("gauges", Declares(slot="gauge", default="exact", key=GAUGE)),
                       ("more", Gauges()))

    assert [f.name for f in plugins.failed] == ["gauges", "more"]  # "more" loses its kind
    assert plugins.failed[0].error == ("the default of slot 'gauge': unknown gauge 'exact'; "
                                       "registered: plain (plugin more), precise (plugin more)")


def test_the_kinematics_plugin_declares_its_kind() -> None:
    everything = load_plugins(environ={})
    assert everything.registry.kinds["kinematics"].plugin == "kinematics"
    assert "kinematics" not in KINDS
    without = load_plugins(environ={"CBR_DISABLE_PLUGINS": "kinematics"})
    assert "kinematics" not in without.registry.kinds


# -- the slot of a plugin's kind in a configuration ---------------------------------------------


def test_an_absent_slot_holds_its_default(gauges: Plugins) -> None:
    for data in (None, {}, {"gauge": None}):
        config = parse_config(data, gauges.registry)
        assert config.slots == {"gauge": ComponentRef("gauge", "plain", NoOptions(), "gauge")}
        assert config.resolved() == {"seed": 0, "casebase": {"use": "memory", "initial": None,
                                                             "worlds": "one"},
                                     "gauge": {"use": "plain"}}


def test_a_slot_takes_a_name_or_a_mapping_with_options(gauges: Plugins) -> None:
    by_name = parse_config({"gauge": "precise"}, gauges.registry)
    assert by_name.slots["gauge"] == ComponentRef("gauge", "precise", PreciseOptions(2), "gauge")
    with_options = parse_config({"gauge": {"use": "precise", "digits": 4}}, gauges.registry)
    assert with_options.slots["gauge"].options == PreciseOptions(4)
    assert with_options.resolved()["gauge"] == {"use": "precise", "digits": 4}
    assert parse_config(with_options.resolved(), gauges.registry) == with_options


@pytest.mark.parametrize(("text", "problem"), [
    ("seed: 1\ngauge: exact\n", "gauge (line 2, column 8): unknown gauge 'exact'; registered: "
                                "plain (plugin gauges), precise (plugin gauges)"),
    ("gauge:\n  use: exact\n", "gauge.use (line 2, column 8): unknown gauge 'exact'; "
                               "registered: plain (plugin gauges), precise (plugin gauges)"),
    ("gauge: {use: precise, digits: -1}\n",
     "gauge.digits (line 1, column 31): must be >= 0: -1"),
    ("gauge: {use: precise, digit: 3}\n",
     "gauge.digit (line 1, column 30): unknown key; expected one of: digits"),
    ("gauge: [plain]\n", "gauge (line 1, column 8): expected a gauge name or a mapping with a "
                         "'use' key naming the gauge, got ['plain']"),
    ("gauges: plain\n", "line 1, column 1: unknown key; expected one of: casebase, "
                        "forget, gauge, metrics, observers, retain, retrieve, reuse, revise, "
                        "seed, solver, workload, world"),
])
def test_slot_problems_are_located(gauges: Plugins, text: str, problem: str) -> None:
    assert problems_of(text, gauges.registry) == [problem]


def test_set_overrides_a_slot(gauges: Plugins) -> None:
    config = config_from_text("seed: 2\n", gauges.registry, ["gauge=precise"])
    assert config.slots["gauge"].name == "precise"
    config = config_from_text("gauge: precise\n", gauges.registry, ["gauge.digits=5"])
    assert config.slots["gauge"].options == PreciseOptions(5)
    with pytest.raises(ConfigError) as caught:
        config_from_text("gauge: precise\n", gauges.registry, ["gauge.digits='5'"])
    assert caught.value.problems == ["--set gauge.digits='5': expected an integer, got '5'"]


def test_a_slot_is_unknown_without_the_plugin_declaring_it() -> None:
    plugins = load(("core", cbrcore.builtins))
    assert problems_of("gauge: plain\n", plugins.registry)[0].startswith(
        "line 1, column 1: unknown key; expected one of: casebase, forget, metrics")


# -- what the command line and the reference show ------------------------------------------------


def test_validate_lists_the_slot(cbr_plugins: Callable[..., Plugins],
                                 invoke_cbr: Callable[..., CliResult], tmp_path: Path) -> None:
    cbr_plugins(("core", cbrcore.builtins), ("gauges", DeclaresAndRegisters()))
    path = tmp_path / "run.yaml"
    path.write_text("seed: 1\n", encoding="utf-8")

    result = invoke_cbr("validate", str(path), "--set", "gauge=precise")

    assert result.exit_code == 0, result.stderr
    assert result.stdout.splitlines() == [f"{path}: ok", "  seed: 1", "  casebase: memory",
                                          "  gauge: precise"]
    path.write_text("gauge: exact\n", encoding="utf-8")
    refused = invoke_cbr("validate", str(path))
    assert refused.exit_code == 2
    assert refused.stderr == (f"error: {path}: 1 problem:\n  - gauge (line 1, column 8): "
                              "unknown gauge 'exact'; registered: plain (plugin gauges), "
                              "precise (plugin gauges)\n")


def test_cbr_plugins_shows_the_declared_kinds(cbr_plugins: Callable[..., Plugins],
                                              invoke_cbr: Callable[..., CliResult]) -> None:
    cbr_plugins(("gauges", DeclaresAndRegisters()), ("toy", toy_domain))

    data = json.loads(invoke_cbr("plugins", "--json").stdout)
    assert [(p["name"], p["kinds"]) for p in data["plugins"]] == [("gauges", ["gauge"]),
                                                                  ("toy", [])]
    rows = [line for line in invoke_cbr("plugins").stdout.splitlines() if line.startswith("│ ")]
    assert rows[0].startswith("│ gauges ") and "│ gauge (slot" in rows[0]


def test_the_reference_shows_each_kind_with_its_declarer(gauges: Plugins) -> None:
    text = config_reference(gauges.registry)

    assert "| `gauge` | one component (default `plain`) | gauge (plugin `gauges`) |" in text
    gauge = text[text.index("## gauge (slot `gauge`)"):]
    assert gauge.startswith("## gauge (slot `gauge`)\n\nA run-wide measuring instrument.\n\n"
                            "Declared by plugin `gauges`.\n\n### `plain`\n")
    assert "## solver (slot `solver`)\n\nImplements cbr_solve" in text
    assert text.count("Declared by cbrcore.") == len(KINDS)


def test_a_mapping_override_sets_a_slot_and_names_its_key(gauges: Plugins) -> None:
    """A plugin's slot takes mapping overrides as ``--set`` does: by name, gaining options on
    the way, and a bad value is named by its key, not by the line the file wrote."""
    config = config_from_text("seed: 2\n", gauges.registry, {"gauge": "precise"})
    assert config.slots["gauge"].name == "precise"
    config = config_from_text("gauge: precise\n", gauges.registry, {"gauge.digits": 5})
    assert config.slots["gauge"].options == PreciseOptions(5)
    with pytest.raises(ConfigError) as caught:
        config_from_text("gauge: precise\n", gauges.registry, {"gauge.digits": "5"})
    assert caught.value.problems == ["overrides['gauge.digits']: expected an integer, got '5'"]
