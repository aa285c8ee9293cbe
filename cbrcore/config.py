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
and what was expected; a key the schema does not know is located by its line and column alone,
and a document that is not a mapping is named by its kind (the rule of
:func:`cbrcore.documents.found`).
"""

from __future__ import annotations

import copy
import re
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import attrs
import yaml

from cbrcore.documents import (
    DocumentError,
    compose_yaml,
    construct_yaml,
    found,
    load_yaml,
    read_text,
)
from cbrcore.errors import ConfigError
from cbrcore.options import (
    displayed,
    misfits,
    option_problems,
    paths_relative_to,
    referenced_names,
    secret_values,
    slots_configured,
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

    def refs(self) -> list[ComponentRef]:
        """Every configured component."""
        singles = [getattr(self, slot) for slot in SINGLE_SLOTS]
        lists = [ref for slot in LIST_SLOTS for ref in getattr(self, slot)]
        return [ref for ref in (*singles, *self.slots.values(), *lists) if ref is not None]

    def masked(self, text: str) -> str:
        """``text`` (a command-line argument, an override) with the value of every option that
        may hold a secret replaced by what is shown of it."""
        secrets = {raw: shown for ref in self.refs() for raw, shown in
                   secret_values(ref.options).items() if raw != shown}
        # the longest first: a value may hold a shorter one; whole values only, as written
        # after '=' or ':', quoted or in a YAML mapping, not a word inside another
        for raw in sorted(secrets, key=len, reverse=True):
            text = re.sub(rf"(?<![^\s=:'\"{{,\[]){re.escape(raw)}(?![^\s'\"}},\]])",
                          lambda _, shown=secrets[raw]: shown, text)
        return text

    def resolved(self) -> dict[str, Any]:
        """The configuration as plain data with every default filled in (for a run's manifest),
        each option that may hold a secret as it is shown (:func:`~cbrcore.options.option`)."""

        def plain(ref: ComponentRef) -> dict[str, Any]:
            return {"use": ref.name, **displayed(ref.options)}

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
    column it was written at in the document, or the override that set it."""

    def __init__(self, node: yaml.Node | None) -> None:
        # a path the configuration holds at no known position (one given as data) maps to None
        self.marks: dict[str, yaml.Mark | None] = {}
        # where each key of a mapping is written, by the path it leads to
        self.keys: dict[str, yaml.Mark] = {}
        self.duplicates: list[str] = []
        # (path, origin) for each override in the order applied: a later one replaces what an
        # earlier one set beneath its path
        self.overrides: list[tuple[str, str]] = []
        if node is not None:
            self._walk(node, "")

    @classmethod
    def of_data(cls, data: Any) -> _Marks:
        """The marks of a configuration given as data: the paths it holds, at no position."""
        marks = cls(None)

        def walk(value: Any, path: str) -> None:
            marks.marks[path] = None
            items = (value.items() if isinstance(value, Mapping)
                     else enumerate(value) if isinstance(value, list) else ())
            for key, item in items:
                walk(item, f"{path}.{key}" if path else str(key))

        walk(data, "")
        return marks

    def _walk(self, node: yaml.Node, path: str) -> None:
        self.marks[path] = node.start_mark
        if isinstance(node, yaml.MappingNode):
            for key, value in node.value:
                child = f"{path}.{key.value}" if path else str(key.value)
                if child in self.marks:  # PyYAML keeps the last of two equal keys silently
                    self.duplicates.append(f"{child}{self.at(key.start_mark)}: key written twice")
                self._walk(value, child)
                self.marks.setdefault(child, key.start_mark)
                self.keys.setdefault(child, key.start_mark)
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

    def overridden(self, path: str, origin: str) -> None:
        """Record that the override named ``origin`` (``--set KEY=VALUE``,
        ``overrides['KEY']``) set the value at ``path``."""
        self.overrides.append((path, origin))

    def option(self, path: str) -> tuple[str, str] | None:
        """The override (its path and origin) that the value at ``path`` came from: one that
        set ``path`` or a path enclosing it, or one below ``path`` when the document does not
        hold ``path`` (the override made it)."""
        for set_path, origin in reversed(self.overrides):
            if path == set_path or path.startswith(f"{set_path}."):
                return set_path, origin
            if set_path.startswith(f"{path}.") and path not in self.marks:
                return set_path, origin
        return None

    def unknown_key(self, path: str, message: str) -> str:
        """One problem line about a key the schema does not know: where the document writes it,
        ``line L, column C: ...``, without the key, which may be a secret's (see
        :func:`cbrcore.documents.found`); one an override set or given as data is named."""
        mark = self.keys.get(path)
        if mark is None or self.option(path) is not None:
            return self.describe(path, message)
        return f"line {mark.line + 1}, column {mark.column + 1}: {message}"

    def top(self) -> str:
        """`` (line L, column C)`` where the document's top level starts; empty for data."""
        return self.at(self.marks.get(""))

    def describe(self, path: str, message: str) -> str:
        """One problem line: ``--set KEY=VALUE: ...`` or ``overrides['KEY']: ...`` for a value
        an override set, else the YAML path and where the document holds it."""
        override = self.option(path)
        if override is None:
            return f"{path}{self.where(path)}: {message}"
        set_path, origin = override
        if path == set_path:
            return f"{origin}: {message}"
        return f"{origin}: {path}: {message}"


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


def apply_overrides(data: Any, overrides: Overrides, source: str,
                    marks: _Marks | None = None) -> Any:
    """Apply ``overrides`` (see :data:`Overrides`) to the raw configuration ``data``, in order.

    Each ``KEY.PATH`` walks mappings by key and lists by index, and its value replaces what the
    path held: a whole slot, one option or a list item. A component written by its name alone
    gains options on the way (``retrieve: casegraph`` and ``retrieve.delta`` make
    ``{use: casegraph, delta: ...}``), as does a slot not written at all. ``--set`` values are
    parsed as YAML within the document limits; mapping values are copied.

    With the ``marks`` of the document, each override is recorded there, so that a problem in a
    value it set names the override (``--set KEY.PATH=VALUE`` or ``overrides['KEY.PATH']``)
    rather than a line of the file. Every override that cannot be applied is reported at once,
    in a :class:`~cbrcore.errors.ConfigError` naming ``source``.
    """
    data = {} if data is None else data
    problems: list[str] = []
    for setting in _settings(overrides, problems):
        problem = _assign(data, setting.parts, setting.value)
        if problem:
            problems.append(f"{setting.label}: {problem}")
        elif marks is not None:
            marks.overridden(".".join(setting.parts), setting.origin)
    if problems:
        raise ConfigError(source, problems)
    return data


@attrs.frozen
class _Setting:
    """One override, read: the path it sets, its value and how problems name it."""

    parts: list[str]
    value: Any
    label: str
    """Names the override in a problem with its key: ``--set 'KEY=VALUE'``, ``overrides['KEY']``."""
    origin: str
    """Names the override in a problem with the value it set: ``--set KEY=VALUE``,
    ``overrides['KEY']``."""


def _settings(overrides: Overrides, problems: list[str]) -> list[_Setting]:
    """The overrides read, each ``KEY.PATH`` split at its dots; a problem for each that cannot
    be read."""
    if isinstance(overrides, Mapping):
        return [setting for key, value in overrides.items()
                if (setting := _mapping_setting(key, value, problems)) is not None]
    if isinstance(overrides, str):  # a lone string would be taken letter by letter
        overrides = [overrides]
    return [setting for text in overrides
            if (setting := _option_setting(text, problems)) is not None]


def _option_setting(text: str, problems: list[str]) -> _Setting | None:
    """A ``KEY.PATH=VALUE`` string as ``--set`` takes it, the value read as YAML."""
    label = f"--set {text!r}"
    key, sep, raw = text.partition("=")
    if not sep or not all(part.strip() for part in key.split(".")):
        problems.append(f"{label}: expected KEY.PATH=VALUE")
        return None
    try:
        value = load_yaml(raw, f"--set {key.strip()}")
    except yaml.YAMLError as exc:
        problems.append(f"{label}: the value is not valid YAML ({exc})")
        return None
    except DocumentError as exc:  # the value may be huge: name its key alone
        problems.append(f"--set {key.strip()}=...: the value is refused: {exc.problem}")
        return None
    return _Setting(key.strip().split("."), value, label, f"--set {text}")


def _mapping_setting(key: Any, value: Any, problems: list[str]) -> _Setting | None:
    """A ``KEY.PATH`` of a mapping of overrides with its Python value, copied so that the
    configuration never shares it with the caller."""
    label = f"overrides[{key!r}]"
    parts = key.split(".") if isinstance(key, str) else []
    if not parts or not all(part.strip() for part in parts):
        problems.append(f"{label}: expected a key of the form KEY.PATH (dots between names), "
                        "such as 'retrieve.k'")
        return None
    return _Setting(parts, copy.deepcopy(value), label, label)


def _assign(data: Any, parts: Sequence[str], value: Any) -> str | None:
    """Set the value at the path ``parts`` of ``data``; the problem when it cannot be set."""
    node = data
    for depth, part in enumerate(parts):
        key: int | str
        if isinstance(node, list):
            if not (part.isdigit() and int(part) < len(node)):
                return (f"{'.'.join(parts[: depth + 1])}: the list has no item {part} "
                        f"(it has {len(node)})")
            key = int(part)
        elif isinstance(node, dict):
            key = part
        else:
            parent = ".".join(parts[:depth]) or "the top level"
            return (f"{'.'.join(parts)} cannot be set: {parent} holds {type(node).__name__}, "
                    "not a mapping or a list")
        if depth == len(parts) - 1:
            node[key] = value
        else:
            node = _opened(node, key)
    return None


def _opened(node: list[Any] | dict[str, Any], key: Any) -> Any:
    """The value under ``key`` of ``node`` that an override descends into: a component given
    by its name alone gains options (``{use: name}``), and one not written starts empty."""
    child = node[key] if isinstance(node, list) else node.get(key)
    if isinstance(child, str):
        child = node[key] = {"use": child}
    elif child is None:
        child = node[key] = {}
    return child


def _component(raw: Any, kind: str, path: str, registry: Registry,
               problems: list[tuple[str, str]]) -> ComponentRef | None:
    if isinstance(raw, str):
        name, options = raw, {}
    elif isinstance(raw, Mapping) and isinstance(raw.get("use"), str):
        name = raw["use"]
        options = {k: v for k, v in raw.items() if k != "use"}
    else:
        problems.append((path, f"expected a {kind} name or a mapping with a 'use' key naming "
                               f"the {kind}, got {found(raw, setting=True)}"))
        return None
    try:
        component = registry.get(kind, name)
    except UnknownComponent as exc:
        problems.append((f"{path}.use" if isinstance(raw, Mapping) else path, str(exc)))
        return None
    value, faults = option_problems(component.options, options, path)
    if not faults:
        # an option that takes only some components of its kind says which ones fit
        unfit = dict(misfits(value, path, registry))
        for where, referred, target in referenced_names(value, path):
            try:
                registry.get(referred, target)
            except UnknownComponent as exc:
                faults.append((where, unfit.pop(where, str(exc))))
        faults.extend(unfit.items())
    problems.extend(faults)
    return ComponentRef(kind, name, value, path) if not faults else None


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
        raise ConfigError(label, [f"the top level{marks.top()}: expected a mapping of "
                                  f"settings, got {found(data)}"])
    problems: list[tuple[str, str]] = []
    plugin_slots = registry.slots
    known = {*CORE_KEYS, *plugin_slots}
    unknown = [marks.unknown_key(str(key), f"unknown key; expected one of: "
                                           f"{', '.join(sorted(known))}")
               for key in data if key not in known]
    seed = data.get("seed", 0)
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        problems.append(("seed", f"expected a non-negative integer, got "
                                 f"{found(seed, setting=True)}"))
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
    if unknown or problems:
        raise ConfigError(label, unknown + [marks.describe(path, message)
                                            for path, message in problems])
    return Config(seed=seed, source=source, slots=slots, **values)


def load_config(path: Path | str, registry: Registry, overrides: Overrides = (),
                observers: Sequence[Mapping[str, Any]] = ()) -> Config:
    """Read, override (see :data:`Overrides`) and check the configuration file at ``path``;
    ``observers`` (each ``{use: name, ...options}``) follow the file's own, as a command's
    option adds one (``cbr run --record``)."""
    path = Path(path).resolve()
    data, marks = read_yaml(path)
    data = apply_overrides(data, overrides, str(path), marks)
    if observers:
        listed = data.get("observers") if isinstance(data, dict) else None
        if isinstance(data, dict) and (listed is None or isinstance(listed, list)):
            data["observers"] = [*(listed or []), *(dict(o) for o in observers)]
    return parse_config(data, registry, source=path, marks=marks)


def config_from_text(text: str, registry: Registry, overrides: Overrides = ()) -> Config:
    """Check a configuration given as YAML text; relative paths resolve against the working
    directory."""
    data, marks = parse_yaml(text, "configuration")
    data = apply_overrides(data, overrides, "configuration", marks)
    return parse_config(data, registry, marks=marks)


def config_from_data(data: Mapping[str, Any], registry: Registry,
                     overrides: Overrides = ()) -> Config:
    """Check a configuration given as a mapping of the shape of a YAML one, which is copied,
    never changed; relative paths resolve against the working directory."""
    if not isinstance(data, Mapping):
        raise ConfigError("configuration", [f"expected a mapping of settings, got "
                                            f"{type(data).__name__}"])
    data = copy.deepcopy(dict(data))
    marks = _Marks.of_data(data)
    data = apply_overrides(data, overrides, "configuration", marks)
    return parse_config(data, registry, marks=marks)
