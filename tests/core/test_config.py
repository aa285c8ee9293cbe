"""Reading configurations: ``cbrcore.config`` and ``cbrcore.options``.

Every bad input must come back as a problem naming its YAML path, line and column, the bad value
and what was expected; every problem of a file is reported at once. The expected lines and
columns below are counted by hand from the YAML texts (both 1-based).
"""

from __future__ import annotations

import copy
from pathlib import Path
from typing import Any, Literal

import attrs
import pytest
import yaml
from hypothesis import given, settings
from hypothesis import strategies as st

import cbr_observers
import cbr_stores
import cbrcore.builtins
import toy_domain
from cbrcore.config import (
    Config,
    _Marks,
    apply_overrides,
    config_from_data,
    config_from_text,
    load_config,
    parse_config,
)
from cbrcore.errors import ConfigError
from cbrcore.hookspecs import hookimpl
from cbrcore.options import option, option_problems, structure_options, unstructure
from cbrcore.plugins import load_plugins
from cbrcore.registry import Registry

TOP_KEYS = ("casebase, forget, metrics, observers, retain, retrieve, reuse, revise, seed, solver, "
            "workload, world")


@attrs.frozen
class ProbeOptions:
    """Options of every type a component may declare."""

    level: int = option(doc="A required integer.")
    mode: Literal["fast", "exact"] = option("fast", "A choice of strings.")
    ratio: float = option(0.5, "A share.", validator=[attrs.validators.ge(0),
                                                     attrs.validators.le(1)])
    auto: Literal[True, False, "auto"] = option("auto", "A choice mixing booleans and a string.")
    data: Path | None = option(None, "A file.")


class ProbePlugin:
    """Registers the world ``probe`` whose options are :class:`ProbeOptions`."""

    @hookimpl
    def cbr_register(self, registry: Registry) -> None:
        registry.add("world", "probe", lambda options, ctx: options, options=ProbeOptions)


@pytest.fixture(scope="module")
def registry() -> Registry:
    plugins = load_plugins(extra=[("toy", toy_domain), ("core", cbrcore.builtins),
                                  ("stores", cbr_stores),
                                  ("observers", cbr_observers), ("probe", ProbePlugin())],
                           entry_points=False, environ={})
    return plugins.registry


def problems_of(text: str, registry: Registry) -> list[str]:
    """The problems ``parse_config`` reports for the YAML ``text``."""
    marks = _Marks(yaml.compose(text, Loader=yaml.SafeLoader))
    with pytest.raises(ConfigError) as caught:
        parse_config(yaml.safe_load(text), registry, marks=marks)
    return caught.value.problems


def write(folder: Path, text: str, name: str = "run.yaml") -> Path:
    path = folder / name
    path.write_text(text, encoding="utf-8")
    return path


# --- one problem per bad-input class -----------------------------------------------------------


@pytest.mark.parametrize(("text", "problem"), [
    ('world:\n  use: probe\n  level: "3"\n',
     "world.level (line 3, column 10): expected an integer, got '3'"),
    ("world:\n  use: probe\n  level: true\n",
     "world.level (line 3, column 10): expected an integer, got True"),
    ("world:\n  use: probe\n  level: 3.5\n",
     "world.level (line 3, column 10): expected an integer, got 3.5"),
    ('world:\n  use: probe\n  level: 1\n  ratio: "0.5"\n',
     "world.ratio (line 4, column 10): expected a number, got '0.5'"),
    ("world:\n  use: probe\n  level: 1\n  ratio: 1.5\n",
     "world.ratio (line 4, column 10): must be <= 1: 1.5"),
    ("retrieve: {use: nearest, radius: -1}\n",
     "retrieve.radius (line 1, column 34): must be >= 0: -1"),
    ("world:\n  use: probe\n  level: 1\n  mode: slow\n",
     "world.mode (line 4, column 9): expected one of 'fast', 'exact', got 'slow'"),
    ("world:\n  use: probe\n  level: 1\n  auto: 1\n",
     "world.auto (line 4, column 9): expected one of True, False, 'auto', got 1"),
    ("world:\n  use: probe\n  level: 1\n  data: 7\n",
     "world.data (line 4, column 9): expected a file path, got 7"),
    ("world:\n  use: probe\n",
     "world.level (line 2, column 3): required option is missing"),
    ("world:\n  use: probe\n  level: 1\n  levle: 2\n",
     "world.levle (line 4, column 10): unknown key; expected one of: level, mode, ratio, auto, "
     "data"),
    ("revise: {use: tolerance, tolerance: 1, strict: true}\n",
     "revise.strict (line 1, column 48): unknown key; expected one of: tolerance"),
    ("reuse: {use: tangent, k: 2}\n",
     "reuse.k (line 1, column 26): unknown key; expected no options"),
    # a key the schema does not know is located, never quoted: it may be a secret's line
    ("retreive: nearest\n", f"line 1, column 1: unknown key; expected one of: {TOP_KEYS}"),
    ("retrieve: nearst\n", "retrieve (line 1, column 11): unknown retriever 'nearst'; "
                           "registered: nearest (plugin toy)"),
    ("retrieve:\n  use: nearst\n  radius: 1\n",
     "retrieve.use (line 2, column 8): unknown retriever 'nearst'; registered: nearest "
     "(plugin toy)"),
    ("casebase: mongo\n", "casebase (line 1, column 11): unknown store 'mongo'; "
                          "registered: memory (plugin core), postgres (plugin stores), sqlite "
                          "(plugin stores)"),
    ("retain: [keep, {use: nope}]\n", "retain.1.use (line 1, column 22): unknown retainer "
                                      "'nope'; registered: keep (plugin toy)"),
    ("retrieve: 3\n", "retrieve (line 1, column 11): expected a retriever name or a mapping "
                      "with a 'use' key naming the retriever, got 3"),
    ("solver: {compute: true}\n", "solver (line 1, column 9): expected a solver name or a "
                                  "mapping with a 'use' key naming the solver, got "
                                  "{'compute': True}"),
    ("seed: -1\n", "seed (line 1, column 7): expected a non-negative integer, got -1"),
    ("seed: '7'\n", "seed (line 1, column 7): expected a non-negative integer, got '7'"),
    ("seed: true\n", "seed (line 1, column 7): expected a non-negative integer, got True"),
])
def test_each_bad_input_is_one_located_problem(registry: Registry, text: str,
                                               problem: str) -> None:
    """The problem gives the YAML path, line and column, what was wrong and what was expected."""
    assert problems_of(text, registry) == [problem]


def test_every_problem_is_reported_at_once(registry: Registry) -> None:
    """Problems in several slots and keys come back together, in one error."""
    text = ("seed: -2\n"
            "retreive: nearest\n"
            "reuse: tangnet\n"
            "revise: {use: tolerance, tolerance: '1'}\n"
            "forget: [{use: capacity, limit: -1}]\n")
    with pytest.raises(ConfigError) as caught:
        parse_config(yaml.safe_load(text), registry,
                     marks=_Marks(yaml.compose(text, Loader=yaml.SafeLoader)))
    assert caught.value.problems == [
        "line 2, column 1: unknown key; expected one of: " + TOP_KEYS,
        "seed (line 1, column 7): expected a non-negative integer, got -2",
        "reuse (line 3, column 8): unknown reuser 'tangnet'; registered: tangent (plugin toy)",
        "revise.tolerance (line 4, column 37): expected a number, got '1'",
        "forget.0.limit (line 5, column 33): must be >= 0: -1",
    ]
    assert str(caught.value).startswith("configuration: 5 problems:\n  - line 2, column 1")


def test_a_top_level_that_is_not_a_mapping_is_refused(registry: Registry) -> None:
    """A YAML list is not a configuration; what it holds is not quoted."""
    with pytest.raises(ConfigError) as caught:
        parse_config(["retrieve", "nearest"], registry)
    assert caught.value.problems == ["the top level: expected a mapping of settings, got a list"]


def test_an_empty_document_is_the_default_configuration(registry: Registry) -> None:
    """Nothing configured: seed 0 and the memory case base, nothing else."""
    config = parse_config(None, registry)
    assert config.seed == 0
    assert config.casebase is not None and config.casebase.name == "memory"
    assert config.resolved() == {"seed": 0, "casebase": {"use": "memory", "initial": None,
                                                         "worlds": "one"}}


def test_a_list_slot_accepts_a_single_component(registry: Registry) -> None:
    """``forget: capacity`` is a list of one, with the slot itself as its path."""
    config = parse_config({"forget": "capacity", "retain": ["keep"]}, registry)
    assert [(ref.name, ref.path) for ref in config.forget] == [("capacity", "forget")]
    assert [(ref.name, ref.path) for ref in config.retain] == [("keep", "retain.0")]
    assert config.forget[0].options == toy_domain.CapacityOptions(5)


def test_mixed_literal_values_accept_each_of_their_values(registry: Registry) -> None:
    """``Literal[True, False, 'auto']`` accepts each of the three and nothing that only equals
    one of them."""
    for value in (True, False, "auto"):
        config = parse_config({"world": {"use": "probe", "level": 1, "auto": value}}, registry)
        assert config.world is not None and config.world.options.auto is value
    assert option_problems(ProbeOptions, {"level": 1, "auto": 0}, "w")[1] == [
        ("w.auto", "expected one of True, False, 'auto', got 0")]


# --- files ------------------------------------------------------------------------------------


@pytest.mark.parametrize(("text", "where", "problem"), [
    ("seed: 3\n\tretrieve: nearest\n", "line 2, column 1",
     "found character '\\t' that cannot start any token"),
    ("world: {use: probe\nseed: 1\n", "line 2, column 5", "expected ',' or '}', but got ':'"),
    ("retrieve: nearest: 2\n", "line 1, column 18", "mapping values are not allowed here"),
])
def test_malformed_yaml_names_line_and_column(registry: Registry, tmp_path: Path, text: str,
                                              where: str, problem: str) -> None:
    """A YAML syntax error is one problem giving the position of the fault."""
    path = write(tmp_path, text)
    with pytest.raises(ConfigError) as caught:
        load_config(path, registry)
    assert caught.value.source == str(path.resolve())
    assert caught.value.problems == [f"{where}: malformed YAML: {problem}"]


def test_a_missing_file_is_reported(registry: Registry, tmp_path: Path) -> None:
    with pytest.raises(ConfigError) as caught:
        load_config(tmp_path / "absent.yaml", registry)
    assert caught.value.source == str(tmp_path.resolve() / "absent.yaml")
    assert caught.value.problems == ["file not found"]


def test_an_unreadable_file_is_reported(registry: Registry, tmp_path: Path) -> None:
    """A folder, or bytes that are not UTF-8, cannot be read as a configuration."""
    folder = tmp_path / "folder.yaml"
    folder.mkdir()
    binary = tmp_path / "binary.yaml"
    binary.write_bytes(b"seed: \xff\xfe\n")
    for path in (folder, binary):
        with pytest.raises(ConfigError) as caught:
            load_config(path, registry)
        (problem,) = caught.value.problems
        assert problem.startswith("cannot read the file: ")


def test_file_problems_carry_lines_from_the_file(registry: Registry, tmp_path: Path) -> None:
    """``load_config`` locates problems in the file it read."""
    path = write(tmp_path, "seed: 1\nworkload:\n  use: squares\n  count: many\n")
    with pytest.raises(ConfigError) as caught:
        load_config(path, registry)
    assert caught.value.problems == [
        "workload.count (line 4, column 10): expected an integer, got 'many'"]
    assert str(caught.value).startswith(f"{path.resolve()}: 1 problem:\n")


def test_relative_paths_resolve_against_the_config_folder(registry: Registry,
                                                          tmp_path: Path) -> None:
    """Relative ``Path`` options, in the file or in an override, are relative to its folder;
    absolute ones stay as written."""
    (tmp_path / "configs").mkdir()
    folder = (tmp_path / "configs").resolve()
    elsewhere = tmp_path / "elsewhere" / "trace.jsonl"
    path = write(folder, f"world: {{use: probe, level: 1, data: data/map.csv}}\n"
                         f"observers: [{{use: trace, file: {elsewhere}}}]\n")
    config = load_config(path, registry)
    assert config.world is not None and config.world.options.data == folder / "data" / "map.csv"
    assert config.observers[0].options.file == elsewhere
    assert config.base_dir == folder
    overridden = load_config(path, registry, ["world.data=../other.csv"])
    assert overridden.world is not None
    assert overridden.world.options.data == folder / ".." / "other.csv"


def test_relative_paths_without_a_file_resolve_against_the_working_folder(
        registry: Registry, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(tmp_path)
    tmp_path = Path.cwd()
    config = parse_config({"world": {"use": "probe", "level": 1, "data": "map.csv"}}, registry)
    assert config.world is not None and config.world.options.data == tmp_path / "map.csv"
    assert config.base_dir == tmp_path


# --- overrides --------------------------------------------------------------------------------


def test_overrides_set_nested_keys_and_list_items() -> None:
    """Dotted paths reach into mappings and, by index, into lists; values are read as YAML."""
    data = yaml.safe_load(toy_domain.TOY_CONFIG)
    result = apply_overrides(data, ["retrieve.radius=2", "forget.0.limit=3", "seed=9",
                                    "metrics.0=abs_error", "workload.high='8'",
                                    "observers=[trace]"], "toy.yaml")
    assert result is data
    assert data["retrieve"] == {"use": "nearest", "radius": 2}
    assert data["forget"] == [{"use": "capacity", "limit": 3}]
    assert data["seed"] == 9
    assert data["workload"] == {"use": "squares", "count": 30, "high": "8"}
    assert data["observers"] == ["trace"]


def test_a_component_given_by_name_gains_options() -> None:
    """``revise: tolerance`` plus ``revise.tolerance=2.5`` becomes a mapping with ``use``; the
    same holds for a list item given by name and for a slot not written at all."""
    data = {"revise": "tolerance", "retain": ["keep"], "forget": ["capacity"]}
    apply_overrides(data, ["revise.tolerance=2.5", "forget.0.limit=4",
                           "retrieve.use=nearest"], "run.yaml")
    assert data == {"revise": {"use": "tolerance", "tolerance": 2.5}, "retain": ["keep"],
                    "forget": [{"use": "capacity", "limit": 4}],
                    "retrieve": {"use": "nearest"}}


def test_overrides_of_an_empty_document_start_from_nothing() -> None:
    assert apply_overrides(None, ["seed=4"], "run.yaml") == {"seed": 4}


def test_invalid_overrides_are_all_reported() -> None:
    """Each bad ``--set`` is one problem; none of them stops the others being checked."""
    data = {"seed": 3, "forget": [{"use": "capacity"}]}
    with pytest.raises(ConfigError) as caught:
        apply_overrides(data, ["radius", "=3", "seed=[1", "forget.5.limit=1", "seed.x=1",
                               "seed.x.y=1", "forget.x.limit=1", "forget.3=keep"], "run.yaml")
    problems = caught.value.problems
    assert caught.value.source == "run.yaml"
    assert problems[:2] == ["--set 'radius': expected KEY.PATH=VALUE",
                            "--set '=3': expected KEY.PATH=VALUE"]
    assert problems[2].startswith("--set 'seed=[1': the value is not valid YAML (")
    assert problems[3:] == [
        "--set 'forget.5.limit=1': forget.5: the list has no item 5 (it has 1)",
        "--set 'seed.x=1': seed.x cannot be set: seed holds int, not a mapping or a list",
        "--set 'seed.x.y=1': seed.x.y cannot be set: seed holds int, not a mapping or a list",
        "--set 'forget.x.limit=1': forget.x: the list has no item x (it has 1)",
        "--set 'forget.3=keep': forget.3: the list has no item 3 (it has 1)",
    ]


def test_overridden_values_are_checked_like_written_ones(registry: Registry,
                                                         tmp_path: Path) -> None:
    """An override's value goes through the same strict checks, located at the slot it set."""
    path = write(tmp_path, toy_domain.TOY_CONFIG)
    config = load_config(path, registry, ["revise.tolerance=1", "retrieve=nearest"])
    assert config.revise is not None and config.revise.options.tolerance == 1.0
    assert config.retrieve is not None
    assert config.retrieve.options == toy_domain.NearestOptions(2)
    with pytest.raises(ConfigError) as caught:
        load_config(path, registry, ["revise.tolerance='1'"])
    assert caught.value.problems == ["--set revise.tolerance='1': expected a number, got '1'"]


# (overrides, the one problem reported) for TOY_CONFIG, whose retrieve slot is line 4:
# "retrieve: {use: nearest, radius: 1}"
OVERRIDE_PROBLEMS = {
    "an option": (["retrieve.radius=-1"], "--set retrieve.radius=-1: must be >= 0: -1"),
    "a whole slot": (["retrieve={use: nearest, radius: -1}"],
                     "--set retrieve={use: nearest, radius: -1}: retrieve.radius: must be >= 0: "
                     "-1"),
    "a list item": (["forget.0.limit=x"], "--set forget.0.limit=x: expected an integer, got 'x'"),
    "the later of two": (["retrieve.radius=-1", "retrieve={use: nearest, radius: -2}"],
                         "--set retrieve={use: nearest, radius: -2}: retrieve.radius: must be >= "
                         "0: -2"),
    "a slot the file lacks": (["world.level=1"],
                              "--set world.level=1: world: expected a world name or a mapping with "
                              "a 'use' key naming the world, got {'level': 1}"),
    "a component's name": (["retrieve.use=nearst"],
                           "--set retrieve.use=nearst: unknown retriever 'nearst'; registered: "
                           "nearest (plugin toy)"),
    "a sibling of a bad written option": (
        ["retrieve.use=nearest"], "retrieve.radius (line 4, column 34): must be >= 0: -1"),
}


@pytest.mark.parametrize(("overrides", "problem"), OVERRIDE_PROBLEMS.values(),
                         ids=OVERRIDE_PROBLEMS.keys())
def test_a_problem_in_an_overridden_value_names_the_option(
        registry: Registry, tmp_path: Path, overrides: list[str], problem: str) -> None:
    """A value set by ``--set`` is no longer where the file's lines say: its problem names the
    option; values the override left alone keep their line and column."""
    text = toy_domain.TOY_CONFIG
    if problem.startswith("retrieve.radius (line 4"):
        text = text.replace("radius: 1", "radius: -1")
    path = write(tmp_path, text)
    for load in (lambda: load_config(path, registry, overrides),
                 lambda: config_from_text(text, registry, overrides)):
        with pytest.raises(ConfigError) as caught:
            load()
        assert caught.value.problems == [problem]


def test_overrides_are_attributed_only_with_the_document_marks(registry: Registry) -> None:
    """Without marks, ``apply_overrides`` changes the data alone, as callers without a document
    use it; with them, each applied override is recorded at its dotted path."""
    marks = _Marks(yaml.compose(toy_domain.TOY_CONFIG, Loader=yaml.SafeLoader))
    data = apply_overrides(yaml.safe_load(toy_domain.TOY_CONFIG),
                           ["retrieve.radius=5", "seed=1"], "toy.yaml", marks)
    assert marks.overrides == [("retrieve.radius", "--set retrieve.radius=5"),
                               ("seed", "--set seed=1")]
    assert marks.option("retrieve.radius") == ("retrieve.radius", "--set retrieve.radius=5")
    assert marks.option("retrieve") is None and marks.option("retrieve.use") is None
    assert parse_config(data, registry, marks=marks).seed == 1


# --- the default store -------------------------------------------------------------------------


def test_the_default_store_without_its_plugin_says_what_is_missing(tmp_path: Path) -> None:
    """With the ``core`` plugin not loaded, a configuration naming no case base learns that the
    default ``memory`` comes from ``core``, at no invented line: the file has no casebase."""
    bare = load_plugins(extra=[("toy", toy_domain)], entry_points=False, environ={}).registry
    text = "# the toy run without a case base\n\n" + toy_domain.TOY_CONFIG.replace(
        "casebase: memory\n", "")
    path = write(tmp_path, text)
    with pytest.raises(ConfigError) as caught:
        load_config(path, bare)
    assert caught.value.problems == [
        "casebase: no case base is named, so the default store 'memory' is used, but plugin "
        "'core', which provides it, is not loaded (see CBR_PLUGINS and CBR_DISABLE_PLUGINS); "
        "load it or name a store; registered stores: none"]

    # a store the file names is an unknown component like any other, at its line
    with pytest.raises(ConfigError) as named:
        load_config(write(tmp_path, toy_domain.TOY_CONFIG, "named.yaml"), bare)
    assert named.value.problems == [
        "casebase (line 2, column 11): unknown store 'memory'; registered: none"]


def test_the_core_plugin_provides_the_default_store(registry: Registry) -> None:
    from cbrcore.config import DEFAULT_STORE, DEFAULT_STORE_PLUGIN
    from cbrcore.plugins import builtin_plugins

    assert registry.get("store", DEFAULT_STORE).plugin == DEFAULT_STORE_PLUGIN
    assert builtin_plugins()[DEFAULT_STORE_PLUGIN] == "cbrcore.builtins"
    config = parse_config({}, registry)
    assert config.casebase is not None and config.casebase.name == DEFAULT_STORE


# --- options ----------------------------------------------------------------------------------


def test_structure_options_raises_one_error_listing_the_problems() -> None:
    with pytest.raises(ConfigError) as caught:
        structure_options(ProbeOptions, {"level": "x", "mode": "slow"}, "world probe")
    assert caught.value.source == "world probe"
    assert sorted(caught.value.problems) == [
        "world probe.level: expected an integer, got 'x'",
        "world probe.mode: expected one of 'fast', 'exact', got 'slow'",
    ]


def test_options_that_are_not_a_mapping_are_refused() -> None:
    assert option_problems(toy_domain.NearestOptions, [1, 2], "retrieve") == (
        None, [("retrieve", "expected a mapping of options, got [1, 2]")])
    assert option_problems(toy_domain.NearestOptions, None, "retrieve") == (
        toy_domain.NearestOptions(2), [])


def test_integers_are_accepted_as_numbers_and_stay_floats() -> None:
    """A YAML ``1`` for a float option is the float 1.0; a YAML ``1.0`` for an int is refused."""
    value, problems = option_problems(ProbeOptions, {"level": 1, "ratio": 1}, "w")
    assert problems == [] and type(value.ratio) is float
    assert option_problems(ProbeOptions, {"level": 1.0}, "w")[1] == [
        ("w.level", "expected an integer, got 1.0")]


def test_registry_create_checks_a_mapping_of_options(registry: Registry) -> None:
    """``Registry.create`` builds from plain data through the same strict checks."""
    built = registry.create("world", "probe", {"level": 2, "mode": "exact"}, None)
    assert built == ProbeOptions(level=2, mode="exact")
    with pytest.raises(ConfigError) as caught:
        registry.create("world", "probe", {"level": True}, None)
    assert caught.value.problems == ["world probe.level: expected an integer, got True"]


def test_unstructure_gives_plain_data(tmp_path: Path) -> None:
    options = ProbeOptions(level=3, data=tmp_path / "x.csv")
    assert unstructure(options) == {"level": 3, "mode": "fast", "ratio": 0.5, "auto": "auto",
                                    "data": str(tmp_path / "x.csv")}


# --- resolved configurations ------------------------------------------------------------------


def test_resolved_fills_in_every_default(registry: Registry) -> None:
    """The resolved TOY_CONFIG, with the defaults written out by hand."""
    config = parse_config(yaml.safe_load(toy_domain.TOY_CONFIG), registry)
    assert config.resolved() == {
        "seed": 3,
        "casebase": {"use": "memory", "initial": None, "worlds": "one"},
        "retrieve": {"use": "nearest", "radius": 1},
        "reuse": {"use": "tangent"},
        "revise": {"use": "tolerance", "tolerance": 0.0},
        "solver": {"use": "compute"},
        "workload": {"use": "squares", "count": 30, "high": 8},
        "retain": [{"use": "keep"}],
        "forget": [{"use": "capacity", "limit": 6}],
        "metrics": [{"use": "abs_error"}],
    }


def _round_trip(config: Config, registry: Registry) -> Config:
    return parse_config(copy.deepcopy(config.resolved()), registry, source=config.source)


def test_resolved_round_trips_a_file(registry: Registry, tmp_path: Path) -> None:
    """A configuration with paths, lists and the sqlite store parses back equal from its
    resolved form."""
    text = toy_domain.TOY_CONFIG.replace("casebase: memory",
                                         "casebase: {use: sqlite, path: cb.sqlite}")
    path = write(tmp_path, text + "observers: [{use: trace, file: trace.jsonl}]\n"
                 "world: {use: probe, level: 4, mode: exact, data: map.csv, auto: false}\n")
    config = load_config(path, registry)
    assert config.casebase is not None
    assert config.casebase.options.path == Path("cb.sqlite")  # a file in the run folder
    assert _round_trip(config, registry) == config


@settings(max_examples=40, deadline=None)
@given(
    seed=st.integers(0, 2**32),
    radius=st.integers(0, 50),
    tolerance=st.floats(0, 1e9, allow_nan=False),
    limits=st.lists(st.integers(0, 100), max_size=3),
    level=st.integers(-(2**40), 2**40),
    mode=st.sampled_from(["fast", "exact"]),
    auto=st.sampled_from([True, False, "auto"]),
    ratio=st.floats(0, 1),
)
def test_resolved_round_trips(registry: Registry, seed: int, radius: int, tolerance: float,
                              limits: list[int], level: int, mode: str, auto: Any,
                              ratio: float) -> None:
    """For any valid options, ``parse_config(config.resolved())`` equals ``config``."""
    data = {"seed": seed, "retrieve": {"use": "nearest", "radius": radius},
            "revise": {"use": "tolerance", "tolerance": tolerance},
            "forget": [{"use": "capacity", "limit": limit} for limit in limits],
            "world": {"use": "probe", "level": level, "mode": mode, "auto": auto,
                      "ratio": ratio}}
    config = parse_config(data, registry)
    assert _round_trip(config, registry) == config
    assert ("forget" in config.resolved()) == bool(limits)


def test_a_key_written_twice_is_refused_with_its_line(tmp_path: Path, registry: Registry) -> None:
    """PyYAML keeps the last of two equal keys; the loader names each repeat instead."""
    path = tmp_path / "twice.yaml"
    path.write_text("seed: 1\nsolver: compute\nseed: 2\nretrieve:\n  use: nearest\n  use: x\n")
    with pytest.raises(ConfigError) as caught:
        load_config(path, registry)
    assert caught.value.problems == ["seed (line 3, column 1): key written twice",
                                     "retrieve.use (line 6, column 3): key written twice"]


# --- overrides as a mapping: the same edits as --set -------------------------------------------

# one set of edits, written as --set strings and as a mapping of Python values
EDITS_AS_STRINGS = ["retrieve.radius=2", "forget.0.limit=3", "seed=9", "metrics.0=abs_error",
                    "reuse.x=1", "world.level=4", "observers=[trace]", "workload.high='8'"]
EDITS_AS_MAPPING = {"retrieve.radius": 2, "forget.0.limit": 3, "seed": 9, "metrics.0": "abs_error",
                    "reuse.x": 1, "world.level": 4, "observers": ["trace"], "workload.high": "8"}


def test_both_forms_of_overrides_edit_the_configuration_alike() -> None:
    """Strings and a mapping reach the same data: options set in mappings, a list item by
    index, a component written by name gaining options, a slot the file lacks made."""
    expected = {"seed": 9, "casebase": "memory",
                "workload": {"use": "squares", "count": 30, "high": "8"},
                "retrieve": {"use": "nearest", "radius": 2}, "reuse": {"use": "tangent", "x": 1},
                "revise": {"use": "tolerance", "tolerance": 0}, "solver": "compute",
                "retain": ["keep"], "forget": [{"use": "capacity", "limit": 3}],
                "metrics": ["abs_error"], "world": {"level": 4}, "observers": ["trace"]}
    for edits in (EDITS_AS_STRINGS, EDITS_AS_MAPPING):
        assert apply_overrides(yaml.safe_load(toy_domain.TOY_CONFIG), edits, "toy.yaml") == expected


def test_both_forms_record_each_override_in_the_marks() -> None:
    marks = {}
    for form, edits in (("strings", EDITS_AS_STRINGS), ("mapping", EDITS_AS_MAPPING)):
        marks[form] = _Marks(yaml.compose(toy_domain.TOY_CONFIG, Loader=yaml.SafeLoader))
        apply_overrides(yaml.safe_load(toy_domain.TOY_CONFIG), edits, "toy.yaml", marks[form])
    paths = [text.partition("=")[0] for text in EDITS_AS_STRINGS]
    assert marks["strings"].overrides == [(text.partition("=")[0], f"--set {text}")
                                          for text in EDITS_AS_STRINGS]
    assert marks["mapping"].overrides == [(path, f"overrides[{path!r}]") for path in paths]


# (the --set string, the same edit as a mapping key and value, what is wrong with its key)
BAD_KEYS = [
    ("forget.5.limit=1", ("forget.5.limit", 1), "forget.5: the list has no item 5 (it has 1)"),
    ("forget.x.limit=1", ("forget.x.limit", 1), "forget.x: the list has no item x (it has 1)"),
    ("forget.1=keep", ("forget.1", "keep"), "forget.1: the list has no item 1 (it has 1)"),
    ("seed.x=1", ("seed.x", 1), "seed.x cannot be set: seed holds int, not a mapping or a list"),
    ("seed.x.y=1", ("seed.x.y", 1),
     "seed.x.y cannot be set: seed holds int, not a mapping or a list"),
    ("retain.0.x.y=1", ("retain.0.x.y", 1),
     "retain.0.x.y cannot be set: retain.0 holds int, not a mapping or a list"),
]


@pytest.mark.parametrize(("text", "setting", "problem"), BAD_KEYS,
                         ids=[text for text, _, _ in BAD_KEYS])
def test_a_key_that_cannot_be_set_is_the_same_problem_in_both_forms(
        text: str, setting: tuple[str, Any], problem: str) -> None:
    data = {"seed": 3, "forget": [{"use": "capacity"}], "retain": [7]}
    for edits, label in (([text], f"--set {text!r}"),
                         (dict([setting]), f"overrides[{setting[0]!r}]")):
        with pytest.raises(ConfigError) as caught:
            apply_overrides(copy.deepcopy(data), edits, "run.yaml")
        assert caught.value.problems == [f"{label}: {problem}"]


def test_the_top_level_that_is_not_a_mapping_cannot_be_set() -> None:
    with pytest.raises(ConfigError) as caught:
        apply_overrides(5, {"seed": 1}, "run.yaml")
    assert caught.value.problems == [
        "overrides['seed']: seed cannot be set: the top level holds int, not a mapping or a list"]


def test_mapping_values_are_copied() -> None:
    """The configuration never shares a value with the caller: changing one changes neither."""
    value = {"use": "nearest", "radius": 2}
    data = apply_overrides({}, {"retrieve": value, "retrieve.radius": 3}, "run.yaml")
    assert data == {"retrieve": {"use": "nearest", "radius": 3}}
    assert value == {"use": "nearest", "radius": 2}


# (a mapping override, the one problem reported) for TOY_CONFIG, whose retrieve slot is line 4:
# "retrieve: {use: nearest, radius: 1}"; the mapping counterparts of OVERRIDE_PROBLEMS
MAPPING_OVERRIDE_PROBLEMS = {
    "an option": ({"retrieve.radius": -1}, "overrides['retrieve.radius']: must be >= 0: -1"),
    "a whole slot": ({"retrieve": {"use": "nearest", "radius": -1}},
                     "overrides['retrieve']: retrieve.radius: must be >= 0: -1"),
    "a list item": ({"forget.0.limit": "x"},
                    "overrides['forget.0.limit']: expected an integer, got 'x'"),
    "the later of two": ({"retrieve.radius": -1, "retrieve": {"use": "nearest", "radius": -2}},
                         "overrides['retrieve']: retrieve.radius: must be >= 0: -2"),
    "a slot the file lacks": ({"world.level": 1},
                              "overrides['world.level']: world: expected a world name or a "
                              "mapping with a 'use' key naming the world, got {'level': 1}"),
    "a component's name": ({"retrieve.use": "nearst"},
                           "overrides['retrieve.use']: unknown retriever 'nearst'; registered: "
                           "nearest (plugin toy)"),
    "a sibling of a bad written option": (
        {"retrieve.use": "nearest"}, "retrieve.radius (line 4, column 34): must be >= 0: -1"),
}


@pytest.mark.parametrize(("overrides", "problem"), MAPPING_OVERRIDE_PROBLEMS.values(),
                         ids=MAPPING_OVERRIDE_PROBLEMS.keys())
def test_a_problem_in_a_mapping_override_names_its_key(
        registry: Registry, tmp_path: Path, overrides: dict[str, Any], problem: str) -> None:
    """As for ``--set``: a value a mapping override set is named by its key, not by the line
    of the file that held the value it replaced; from data, a value the data wrote is named by
    its path alone, there being no line."""
    text = toy_domain.TOY_CONFIG
    if problem.startswith("retrieve.radius (line 4"):
        text = text.replace("radius: 1", "radius: -1")
    path = write(tmp_path, text)
    for load, expected in (
            (lambda: load_config(path, registry, overrides), problem),
            (lambda: config_from_text(text, registry, overrides), problem),
            (lambda: config_from_data(yaml.safe_load(text), registry, overrides),
             problem.replace(" (line 4, column 34)", ""))):
        with pytest.raises(ConfigError) as caught:
            load()
        assert caught.value.problems == [expected]


def test_from_data_a_problem_the_data_wrote_is_not_blamed_on_an_override_beneath_it(
        registry: Registry) -> None:
    """The data held ``world`` (without a ``use``) before ``world.level`` was set below it."""
    with pytest.raises(ConfigError) as caught:
        config_from_data({"world": {"mode": "exact"}}, registry, {"world.level": 1})
    assert caught.value.problems == [
        "world: expected a world name or a mapping with a 'use' key naming the world, got "
        "{'mode': 'exact', 'level': 1}"]


def test_config_from_data_leaves_the_mapping_alone(registry: Registry) -> None:
    data = {"retrieve": "nearest", "forget": ["capacity"]}
    config = config_from_data(data, registry, {"retrieve.radius": 4, "forget.0.limit": 2})
    assert config.retrieve is not None and config.retrieve.options.radius == 4
    assert [ref.options.limit for ref in config.forget] == [2]
    assert data == {"retrieve": "nearest", "forget": ["capacity"]}


@attrs.frozen
class Radii:
    robot_radius: float = option(doc="")
    inflation_radius: float | None = option(None, "")


@attrs.frozen
class NestingOptions:
    inflation: Radii | None = option(None, "")
    sites: list[Radii] = option(factory=list)


@pytest.mark.parametrize(("data", "problems"), [
    ({"inflation": 0.3}, [("w.inflation", "expected a mapping with keys robot_radius, "
                                          "inflation_radius, got 0.3")]),
    ({"sites": [0.3, {"robot_radius": 1}, "x", [1]]},
     [("w.sites.0", "expected a mapping with keys robot_radius, inflation_radius, got 0.3"),
      ("w.sites.2", "expected a mapping with keys robot_radius, inflation_radius, got 'x'"),
      ("w.sites.3", "expected a mapping with keys robot_radius, inflation_radius, got [1]")]),
])
def test_a_nested_option_given_a_scalar_asks_for_a_mapping_of_its_keys(
        data: dict[str, Any], problems: list[tuple[str, str]]) -> None:
    assert option_problems(NestingOptions, data, "w") == (None, problems)
    # the mappings themselves are read as before, null leaving an optional one out
    assert option_problems(NestingOptions, {"inflation": {"robot_radius": 1}, "sites": [
        {"robot_radius": 2, "inflation_radius": 3}]}, "w") == (
        NestingOptions(Radii(1.0), [Radii(2.0, 3.0)]), [])
    assert option_problems(NestingOptions, {"inflation": None}, "w") == (NestingOptions(), [])
