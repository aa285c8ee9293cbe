"""Reading a run's YAML composition into a checked :class:`Config`.

A configuration names one component for each single-answer slot and a list for the collect-all
ones. A component is written as its name, or as a mapping whose ``use`` key names it and whose
other keys are its options::

    seed: 7
    world: {use: office, width: 200}
    casebase: sqlite
    retrieve: {use: nearest, k: 3}
    retain: [keep_all]

A plugin's kind may own a top-level slot of its own (see
:meth:`cbrcore.registry.Registry.add_kind`), written the same way and filled with the kind's
default when absent: ``kinematics: forward_backward``. Options that name other components
(:func:`cbrcore.options.reference`) are checked against the registry.

Every problem found is reported at once, each with its YAML path, line and column, the bad value
and what was expected.
"""

from __future__ import annotations

import copy
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import attrs
import yaml

from cbrcore.documents import DocumentError, compose_yaml, construct_yaml, load_yaml, read_text
from cbrcore.errors import ConfigError
from cbrcore.options import (
    option_problems,
    paths_relative_to,
    referenced_names,
    slots_configured,
    unstructure,
)
from cbrcore.registry import CORE_KEYS, LIST_SLOTS, SINGLE_SLOTS, Registry, UnknownComponent

Overrides = Sequence[str] | Mapping[str, Any]
"""Settings that edit a configuration before it is checked: ``KEY.PATH=VALUE`` strings as
``cbr run --set`` takes them (values in YAML), or a mapping of ``KEY.PATH`` to Python values."""

DEFAULT_STORE = "memory"
"""The store of a configuration that names no case base."""
DEFAULT_STORE_PLUGIN = "core"
"""The plugin that provides :data:`DEFAULT_STORE` (:mod:`cbrcore.builtins`)."""


@attrs.frozen
class ComponentRef:
    """A configured component: its kind and name, validated options and where it was written."""

    kind: str
    name: str
    options: Any
    path: str


@attrs.frozen
class Config:
    """A checked configuration, ready to build an engine from.

    ``slots`` holds the components chosen in the slots that plugins' kinds own, by slot
    (``kinematics``), defaults filled in; each reference's ``kind`` names its kind.
    """

    seed: int = 0
    world: ComponentRef | None = None
    casebase: ComponentRef | None = None
    retrieve: ComponentRef | None = None
    reuse: ComponentRef | None = None
    revise: ComponentRef | None = None
    solver: ComponentRef | None = None
    workload: ComponentRef | None = None
    retain: tuple[ComponentRef, ...] = ()
    forget: tuple[ComponentRef, ...] = ()
    observers: tuple[ComponentRef, ...] = ()
    metrics: tuple[ComponentRef, ...] = ()
    slots: Mapping[str, ComponentRef] = attrs.field(factory=dict)
    source: Path | None = None

    @property
    def base_dir(self) -> Path:
        return self.source.parent if self.source is not None else Path.cwd()

    def resolved(self) -> dict[str, Any]:
        """The configuration as plain data with every default filled in (for a run's manifest)."""

        def plain(ref: ComponentRef) -> dict[str, Any]:
            return {"use": ref.name, **unstructure(ref.options)}

        data: dict[str, Any] = {"seed": self.seed}
        for slot in SINGLE_SLOTS:
            ref = getattr(self, slot)
            if ref is not None:
                data[slot] = plain(ref)
        for slot, ref in self.slots.items():
            data[slot] = plain(ref)
        for slot in LIST_SLOTS:
            refs = getattr(self, slot)
            if refs:
                data[slot] = [plain(ref) for ref in refs]
        return data


class _Marks:
    """Where each YAML path of a configuration came from, for error messages: the line and
    column it was written at in the document, or the ``--set`` option that set it."""

    def __init__(self, node: yaml.Node | None) -> None:
        self.marks: dict[str, yaml.Mark] = {}
        self.duplicates: list[str] = []
        # (path, option) for each override in the order applied: a later one replaces what an
        # earlier one set beneath its path
        self.overrides: list[tuple[str, str]] = []
        if node is not None:
            self._walk(node, "")

    def _walk(self, node: yaml.Node, path: str) -> None:
        self.marks[path] = node.start_mark
        if isinstance(node, yaml.MappingNode):
            for key, value in node.value:
                child = f"{path}.{key.value}" if path else str(key.value)
                if child in self.marks:  # PyYAML keeps the last of two equal keys silently
                    self.duplicates.append(f"{child}{self.at(key.start_mark)}: key written twice")
                self._walk(value, child)
                self.marks.setdefault(child, key.start_mark)
        elif isinstance(node, yaml.SequenceNode):
            for index, item in enumerate(node.value):
                self._walk(item, f"{path}.{index}" if path else str(index))

    @staticmethod
    def at(mark: yaml.Mark | None) -> str:
        return f" (line {mark.line + 1}, column {mark.column + 1})" if mark else ""

    def where(self, path: str) -> str:
        """`` (line L, column C)`` of ``path``, or of the nearest enclosing path written in the
        document (the component whose option is missing); empty for a top-level key the
        document does not hold, rather than the position of the document itself."""
        probe = path
        while probe and probe not in self.marks:
            probe = probe.rpartition(".")[0]
        return self.at(self.marks.get(probe)) if probe else ""

    def overridden(self, path: str, option: str) -> None:
        """Record that the ``--set`` ``option`` set the value at ``path``."""
        self.overrides.append((path, option))

    def option(self, path: str) -> tuple[str, str] | None:
        """The override (its path and option) that the value at ``path`` came from: one that
        set ``path`` or a path enclosing it, or one below ``path`` when the document does not
        hold ``path`` (the override made it)."""
        for set_path, option in reversed(self.overrides):
            if path == set_path or path.startswith(f"{set_path}."):
                return set_path, option
            if set_path.startswith(f"{path}.") and path not in self.marks:
                return set_path, option
        return None

    def describe(self, path: str, message: str) -> str:
        """One problem line: ``--set KEY=VALUE: ...`` for a value an override set, else the
        YAML path and where the document holds it."""
        found = self.option(path)
        if found is None:
            return f"{path}{self.where(path)}: {message}"
        set_path, option = found
        if path == set_path:
            return f"--set {option}: {message}"
        return f"--set {option}: {path}: {message}"


def parse_yaml(text: str, label: str) -> tuple[Any, _Marks]:
    """Parse YAML text safely within the document limits (:mod:`cbrcore.documents`); errors
    name ``label`` and the line and column of the fault."""
    try:
        node = compose_yaml(text, label)
        # the marks are taken before construction, which rewrites the nodes of '<<' merges
        marks = _Marks(node)
        data = construct_yaml(node, label)
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f"line {mark.line + 1}, column {mark.column + 1}: " if mark else ""
        problem = getattr(exc, "problem", None) or str(exc)
        raise ConfigError(label, [f"{where}malformed YAML: {problem}"]) from None
    except DocumentError as exc:
        raise ConfigError(label, [exc.problem]) from None
    if marks.duplicates:
        raise ConfigError(label, marks.duplicates)
    return data, marks


def read_yaml(path: Path) -> tuple[Any, _Marks]:
    """Read and parse a YAML file; errors name the file."""
    try:
        text = read_text(path)
    except FileNotFoundError:
        raise ConfigError(str(path), ["file not found"]) from None
    except (OSError, UnicodeDecodeError) as exc:
        raise ConfigError(str(path), [f"cannot read the file: {exc}"]) from None
    except DocumentError as exc:
        raise ConfigError(str(path), [exc.problem]) from None
    return parse_yaml(text, str(path))


def apply_overrides(data: Any, overrides: Sequence[str], source: str,
                    marks: _Marks | None = None) -> Any:
    """Apply ``key.path=value`` overrides (values parsed as YAML within the document limits) to
    the raw configuration.

    With the ``marks`` of the document, each override is recorded there, so that a problem in
    a value it set names the ``--set`` option rather than a line of the file.
    """
    if data is None:
        data = {}
    problems = []
    for text in overrides:
        key, sep, raw = text.partition("=")
        if not sep or not all(part.strip() for part in key.split(".")):
            problems.append(f"--set {text!r}: expected KEY.PATH=VALUE")
            continue
        try:
            value = load_yaml(raw, f"--set {key.strip()}")
        except yaml.YAMLError as exc:
            problems.append(f"--set {text!r}: the value is not valid YAML ({exc})")
            continue
        except DocumentError as exc:  # the value may be huge: name its key alone
            problems.append(f"--set {key.strip()}=...: the value is refused: {exc.problem}")
            continue
        parts = key.strip().split(".")
        node = data
        for depth, part in enumerate(parts[:-1]):
            node, problem = _descend(node, part, ".".join(parts[: depth + 1]))
            if problem:
                problems.append(f"--set {text!r}: {problem}")
                break
        else:
            last = parts[-1]
            if isinstance(node, list) and last.isdigit() and int(last) < len(node):
                node[int(last)] = value
            elif isinstance(node, dict):
                node[last] = value
            else:
                problems.append(f"--set {text!r}: {key} cannot be set")
                continue
            if marks is not None:
                marks.overridden(".".join(parts), text)
    if problems:
        raise ConfigError(source, problems)
    return data


def overridden(data: Any, overrides: Overrides, source: str,
               marks: _Marks | None = None) -> Any:
    """Raw configuration ``data`` with ``overrides`` applied (see :data:`Overrides`); errors
    name ``source``, and ``--set`` strings are recorded in the document's ``marks``."""
    if isinstance(overrides, Mapping):
        return apply_settings(data, overrides, source)
    if isinstance(overrides, str):  # a lone string would be taken letter by letter
        overrides = [overrides]
    return apply_overrides(data, overrides, source, marks)


def apply_settings(data: Any, settings: Mapping[str, Any], source: str) -> Any:
    """Set each ``KEY.PATH`` of ``settings`` to its Python value in raw configuration ``data``.

    A value replaces what the path held, as ``--set`` does: ``{"casebase": {"use": "memory"}}``
    replaces the whole slot, ``{"retrieve.k": 3}`` one option, and a component written by its
    name alone gains options on the way (``retrieve: casegraph`` becomes ``{use: casegraph}``).
    Values are copied, and checked with the rest of the configuration afterwards, so a bad value
    is reported at its key's path. A key that is not a dotted path, or that leads through a
    value that is not a mapping, is a :class:`~cbrcore.errors.ConfigError` naming the key.
    """
    data = {} if data is None else data
    problems = []
    for key, value in settings.items():
        label = f"overrides[{key!r}]"
        parts = key.split(".") if isinstance(key, str) else []
        if not parts or not all(part.strip() for part in parts):
            problems.append(f"{label}: expected a key of the form KEY.PATH (dots between "
                            "names), such as 'retrieve.k'")
            continue
        node, where = data, []
        for part in parts[:-1]:
            where.append(part)
            node, problem = _setting_child(node, part, ".".join(where))
            if problem:
                problems.append(f"{label}: {problem}")
                break
        else:
            last = parts[-1]
            if isinstance(node, list) and last.isdigit() and int(last) < len(node):
                node[int(last)] = copy.deepcopy(value)
            elif isinstance(node, dict):
                node[last] = copy.deepcopy(value)
            else:
                problems.append(f"{label}: {key} cannot be set: {'.'.join(where) or 'the top'} "
                                f"holds {type(node).__name__}, not a mapping")
    if problems:
        raise ConfigError(source, problems)
    return data


def _setting_child(node: Any, part: str, path: str) -> tuple[Any, str | None]:
    """The value under ``part`` of ``node`` that a setting descends into, made a mapping when
    it is a component's name or absent; or a problem."""
    if isinstance(node, list):
        if part.isdigit() and int(part) < len(node):
            if isinstance(node[int(part)], str):
                node[int(part)] = {"use": node[int(part)]}
            return node[int(part)], None
        return node, f"{path}: the list has no item {part} (it has {len(node)})"
    if not isinstance(node, dict):
        return node, f"{path}: cannot be descended into; it holds {type(node).__name__}"
    child = node.get(part)
    if isinstance(child, str):
        child = node[part] = {"use": child}
    elif child is None:
        child = node[part] = {}
    return child, None


def _descend(node: Any, part: str, path: str) -> tuple[Any, str | None]:
    if isinstance(node, list):
        if part.isdigit() and int(part) < len(node):
            if isinstance(node[int(part)], str):  # a list item given by name gains options
                node[int(part)] = {"use": node[int(part)]}
            return node[int(part)], None
        return node, f"{path}: no list item {part}"
    if not isinstance(node, dict):
        return node, f"{path}: not a mapping"
    child = node.get(part)
    if isinstance(child, str):  # a component given by name alone gains options
        child = node[part] = {"use": child}
    elif child is None:
        child = node[part] = {}
    return child, None


def _component(raw: Any, kind: str, path: str, registry: Registry,
               problems: list[tuple[str, str]]) -> ComponentRef | None:
    if isinstance(raw, str):
        name, options = raw, {}
    elif isinstance(raw, Mapping) and isinstance(raw.get("use"), str):
        name = raw["use"]
        options = {k: v for k, v in raw.items() if k != "use"}
    else:
        problems.append((path, f"expected a {kind} name or a mapping with a 'use' key naming "
                               f"the {kind}, got {raw!r}"))
        return None
    try:
        component = registry.get(kind, name)
    except UnknownComponent as exc:
        problems.append((f"{path}.use" if isinstance(raw, Mapping) else path, str(exc)))
        return None
    value, found = option_problems(component.options, options, path)
    if not found:
        for where, referred, target in referenced_names(value, path):
            try:
                registry.get(referred, target)
            except UnknownComponent as exc:
                found.append((where, str(exc)))
    problems.extend(found)
    return ComponentRef(kind, name, value, path) if not found else None


def _default_store(registry: Registry, problems: list[tuple[str, str]]) -> ComponentRef | None:
    """The case base of a configuration that names none: the default store, provided its
    plugin is loaded."""
    try:
        registry.get("store", DEFAULT_STORE)
    except UnknownComponent:
        stores = [f"{c.name} (plugin {c.plugin})" for c in registry if c.kind == "store"]
        problems.append(("casebase", (
            f"no case base is named, so the default store {DEFAULT_STORE!r} is used, but "
            f"plugin {DEFAULT_STORE_PLUGIN!r}, which provides it, is not loaded (see "
            f"CBR_PLUGINS and CBR_DISABLE_PLUGINS); load it or name a store; registered stores: "
            f"{', '.join(stores) or 'none'}")))
        return None
    return _component(DEFAULT_STORE, "store", "casebase", registry, problems)


def parse_config(data: Any, registry: Registry, *, source: Path | None = None,
                 marks: _Marks | None = None) -> Config:
    """Check raw configuration data against the registry; raise one error listing every problem."""
    marks = marks or _Marks(None)
    label = str(source) if source is not None else "configuration"
    if data is None:
        data = {}
    if not isinstance(data, Mapping):
        raise ConfigError(label, [f"expected a mapping at the top level, got {data!r}"])
    problems: list[tuple[str, str]] = []
    plugin_slots = registry.slots
    known = {*CORE_KEYS, *plugin_slots}
    for key in data:
        if key not in known:
            problems.append((str(key), f"unknown key; expected one of: {', '.join(sorted(known))}"))
    seed = data.get("seed", 0)
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        problems.append(("seed", f"expected a non-negative integer, got {seed!r}"))
    values: dict[str, Any] = {}
    base = source.parent if source is not None else Path.cwd()
    with paths_relative_to(base):
        # the plugin slots come first: a component's options may depend on them (a planner
        # option that the configuration's robot model rules out)
        slots: dict[str, ComponentRef] = {}
        for slot, declared in plugin_slots.items():
            # absent or null alike: a slot with a default always holds a component
            raw = data.get(slot)
            raw = declared.default if raw is None else raw
            if raw is None:
                continue
            ref = _component(raw, declared.kind, slot, registry, problems)
            if ref is not None:
                slots[slot] = ref
        with slots_configured({slot: ref.name for slot, ref in slots.items()}):
            for slot, kind in SINGLE_SLOTS.items():
                if slot == "casebase" and slot not in data:
                    values[slot] = _default_store(registry, problems)
                    continue
                raw = data.get(slot)
                if raw is not None:
                    values[slot] = _component(raw, kind, slot, registry, problems)
            for slot, kind in LIST_SLOTS.items():
                raw = data.get(slot) or []
                items = raw if isinstance(raw, list) else [raw]
                refs = [_component(item, kind, f"{slot}.{i}" if isinstance(raw, list) else slot,
                                   registry, problems) for i, item in enumerate(items)]
                values[slot] = tuple(ref for ref in refs if ref is not None)
    if problems:
        raise ConfigError(label, [marks.describe(path, message) for path, message in problems])
    return Config(seed=seed, source=source, slots=slots, **values)


def load_config(path: Path | str, registry: Registry, overrides: Overrides = ()) -> Config:
    """Read, override (see :data:`Overrides`) and check the configuration file at ``path``."""
    path = Path(path).resolve()
    data, marks = read_yaml(path)
    data = overridden(data, overrides, str(path), marks)
    return parse_config(data, registry, source=path, marks=marks)


def config_from_text(text: str, registry: Registry, overrides: Overrides = ()) -> Config:
    """Check a configuration given as YAML text; relative paths resolve against the working
    directory."""
    data, marks = parse_yaml(text, "configuration")
    data = overridden(data, overrides, "configuration", marks)
    return parse_config(data, registry, marks=marks)
