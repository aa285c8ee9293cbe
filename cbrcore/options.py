"""Component options: attrs classes checked strictly when a configuration is read.

A plugin declares its options as an attrs class and documents each field with :func:`option`::

    @attrs.frozen
    class NearestOptions:
        k: int = option(3, "How many cases to retrieve.", validator=attrs.validators.ge(1))

Values are checked strictly (YAML ``"3"`` is not an integer, ``3.5`` is not silently truncated),
unknown keys are refused, and ``pathlib.Path`` fields resolve relative to the configuration
file's folder. A file the component writes is an :data:`OutputPath` instead: a relative one names
a file inside the run's output folder (see :func:`in_run_folder`), and one whose ``..`` would
leave that folder is refused; to write elsewhere, the configuration gives an absolute path.

An option that names another component is declared with :func:`reference`, giving the kind it
names; a configuration naming a component of that kind nobody registered is refused::

    @attrs.frozen
    class SpliceOptions:
        connector: str = reference("solver", "astar", "The solver that joins the pieces.")
"""

from __future__ import annotations

import contextlib
import contextvars
import os
import re
import sys
import typing
from collections.abc import Callable, Iterator, Mapping, Sequence
from pathlib import Path
from typing import Any, Literal, NewType

import attrs
import cattrs
from cattrs.cols import list_structure_factory
from cattrs.errors import ClassValidationError, ForbiddenExtraKeysError, IterableValidationError

from cbrcore.documents import found
from cbrcore.errors import ConfigError

_base_dir: contextvars.ContextVar[Path] = contextvars.ContextVar("cbr_base_dir")
_slots: contextvars.ContextVar[Mapping[str, str]] = contextvars.ContextVar("cbr_slots")


_REFERS_TO = "cbr_refers_to"
_SHOWN = "cbr_shown"
_FITS = "cbr_fits"


def option(default: Any = attrs.NOTHING, doc: str = "", *,
           validator: Callable[..., Any] | None = None, factory: Callable[[], Any] | None = None,
           shown: Callable[[str], str] | None = None) -> Any:
    """An attrs field with a documentation string shown in the configuration reference.

    ``shown`` marks a string option that may hold a secret (a password in a database's
    address): what a run's manifest, ``cbr validate --json`` and the recorded command line show
    instead of its value (see :func:`displayed`).
    """
    metadata: dict[str, Any] = {"doc": doc}
    if shown is not None:
        metadata[_SHOWN] = shown
    return _field(default, validator, factory, metadata)


def reference(kind: str, default: Any = attrs.NOTHING, doc: str = "", *,
              validator: Callable[..., Any] | None = None,
              factory: Callable[[], Any] | None = None,
              fits: Callable[[Any, str], str | None] | None = None) -> Any:
    """An option naming a component of ``kind``, as :func:`option` otherwise.

    The value is a component name (``str``), None, or a list or tuple of names. Reading a
    configuration checks every name, the default included, against the registry, and the
    configuration reference shows the kind the option names. ``fits(registry, name)`` narrows
    the components the option takes (those of a protocol, say): it returns what is wrong with
    the registered component ``name`` here, listing the names that fit, or None.
    """
    metadata: dict[str, Any] = {"doc": doc, _REFERS_TO: kind}
    if fits is not None:
        metadata[_FITS] = fits
    return _field(default, validator, factory, metadata)


def _field(default: Any, validator: Callable[..., Any] | None,
           factory: Callable[[], Any] | None, metadata: dict[str, Any]) -> Any:
    if factory is not None:
        return attrs.field(factory=factory, validator=validator, metadata=metadata)
    return attrs.field(default=default, validator=validator, metadata=metadata)


def referred_kind(field: attrs.Attribute) -> str | None:
    """The component kind a field declared with :func:`reference` names, else None."""
    return field.metadata.get(_REFERS_TO)


def _attrs_classes(kind: Any) -> Iterator[type]:
    if isinstance(kind, type) and attrs.has(kind):
        yield kind
    for argument in typing.get_args(kind):
        yield from _attrs_classes(argument)


def references(options_cls: type) -> Iterator[tuple[str, str]]:
    """``(option path, kind)`` for every reference in an options class, nested ones included.

    Options classes nested in fields (directly, or in lists, tuples, mappings and unions) are
    searched too; their options are written ``outer.inner``. Raises ``NameError`` when the
    class's annotations do not resolve.
    """

    def walk(cls: type, prefix: str, seen: frozenset[type]) -> Iterator[tuple[str, str]]:
        for field in attrs.fields(attrs.resolve_types(cls)):
            kind = referred_kind(field)
            if kind is not None:
                yield f"{prefix}{field.name}", kind
            for inner in _attrs_classes(field.type):
                if inner not in seen:
                    yield from walk(inner, f"{prefix}{field.name}.", seen | {inner})

    return walk(options_cls, "", frozenset({options_cls}))


def referenced_names(options: Any, where: str) -> Iterator[tuple[str, str, str]]:
    """``(yaml path, kind, name)`` for every component name an options instance refers to.

    Walks nested options instances in fields, lists, tuples and mappings; paths are below
    ``where`` (``reuse.connector``, ``reuse.stages.1.solver``).
    """
    for name_path, field, name in _named(options, where):
        yield name_path, referred_kind(field), name


def misfits(options: Any, where: str, registry: Any) -> Iterator[tuple[str, str]]:
    """``(yaml path, problem)`` for every registered component an options instance names where
    its option's ``fits`` (see :func:`reference`) refuses it."""
    for name_path, field, name in _named(options, where):
        fits = field.metadata.get(_FITS)
        problem = None if fits is None else fits(registry, name)
        if problem is not None:
            yield name_path, problem


def _named(options: Any, where: str) -> Iterator[tuple[str, attrs.Attribute, str]]:
    """``(yaml path, field, name)`` for every component name in an options instance."""
    for field in attrs.fields(type(options)):
        value = getattr(options, field.name)
        path = f"{where}.{field.name}"
        if referred_kind(field) is not None:
            for name_path, name in _items(value, path):
                yield name_path, field, name
        else:
            for item_path, item in _items(value, path):
                if attrs.has(type(item)):
                    yield from _named(item, item_path)


def _items(value: Any, path: str) -> Iterator[tuple[str, Any]]:
    """The value itself, or each item of a list, tuple or mapping, with its YAML path."""
    if isinstance(value, Mapping):
        for key, item in value.items():
            yield f"{path}.{key}", item
    elif isinstance(value, Sequence) and not isinstance(value, str):
        for index, item in enumerate(value):
            yield f"{path}.{index}", item
    elif value is not None:
        yield path, value


INT64 = (-2**63, 2**63 - 1)
"""The integers an option may hold: what numpy, SQLite and ``len()`` can take, not Python's
unbounded ``int``."""


def _integer(value: Any, _: type) -> int:
    number = _strict(int, "an integer", (int,))(value, int)
    low, high = INT64
    if not low <= number <= high:
        raise ValueError(f"expected an integer from {low} to {high}, got "
                         f"{found(value, setting=True)}")
    return number


def _strict(kind: type, label: str, accept: tuple[type, ...]) -> Callable[[Any, type], Any]:
    def structure(value: Any, _: type) -> Any:
        if isinstance(value, bool) and kind is not bool:
            raise TypeError(f"expected {label}, got {found(value, setting=True)}")
        if not isinstance(value, accept):
            raise TypeError(f"expected {label}, got {found(value, setting=True)}")
        try:
            return kind(value)
        except OverflowError:  # an integer past the largest float
            raise ValueError(f"expected {label} within ±{sys.float_info.max:.4g}, got "
                             f"{found(value, setting=True)}") from None

    return structure


def _literal(value: Any, kind: Any) -> Any:
    allowed = typing.get_args(kind)
    if not any(type(value) is type(a) and value == a for a in allowed):
        raise ValueError(f"expected one of {', '.join(map(repr, allowed))}, got "
                         f"{found(value, setting=True)}")
    return value


def _path(value: Any, _: type) -> Path:
    if not isinstance(value, str | Path):
        raise TypeError(f"expected a file path, got {found(value, setting=True)}")
    path = Path(value).expanduser()
    base = _base_dir.get(None)
    return path if path.is_absolute() or base is None else base / path


OutputPath = NewType("OutputPath", Path)
"""The type of an option naming a file the component writes: absolute (``~`` expanded) as
written, or relative to the run's output folder and inside it; resolve it with
:func:`in_run_folder`."""


def _output_path(value: Any, _: type) -> Path:
    if not isinstance(value, str | Path):
        raise TypeError(f"expected a file path, got {found(value, setting=True)}")
    path = Path(value).expanduser()
    if path.is_absolute():
        return path
    # checked by its text: the run folder may not exist yet, or not be known (cbr validate)
    inside = Path(os.path.normpath(path))
    if inside.parts[:1] in ((), (os.pardir,)):
        raise ValueError(f"expected a file inside the run's output folder, got "
                         f"{found(str(value), setting=True)}; "
                         "give an absolute path to write outside it")
    return inside


def in_run_folder(path: Path, out_dir: Path | None, config_dir: Path) -> Path:
    """Where the :data:`OutputPath` ``path`` writes: an absolute path as it is, a relative one
    inside ``out_dir``, or, without an output folder (an engine embedded without one), inside
    ``config_dir``, the configuration's folder, as a read path would be."""
    if path.is_absolute():
        return path
    return (config_dir if out_dir is None else out_dir) / path


def _mapping_first(converter: cattrs.Converter) -> Callable[[type], Callable[[Any, type], Any]]:
    """A structure hook factory for nested options classes that refuses anything but a mapping
    with the keys the class takes: cattrs's own hook would fail on ``value.keys()`` or ``key in
    value`` with words about Python types."""

    def factory(cls: type) -> Callable[[Any, type], Any]:
        structure = converter.gen_structure_attrs_fromdict(cls)
        keys = ", ".join(field.name for field in attrs.fields(cls) if field.init)

        def checked(value: Any, kind: type) -> Any:
            if not isinstance(value, Mapping):
                raise TypeError(f"expected a mapping with keys {keys}, got "
                                f"{found(value, setting=True)}")
            return structure(value, kind)

        return checked

    return factory


def _list_first(converter: cattrs.Converter) -> Callable[[type], Callable[[Any, type], Any]]:
    """A structure hook factory for list options that refuses anything but a list (or tuple):
    cattrs's own hook takes any iterable, so a string would be read character by character and
    a mapping by its keys."""

    def factory(kind: type) -> Callable[[Any, type], Any]:
        structure = list_structure_factory(kind, converter)

        def checked(value: Any, kind: type) -> Any:
            if not isinstance(value, list | tuple):
                raise TypeError(f"expected a list, got {found(value, setting=True)}")
            return structure(value, kind)

        return checked

    return factory


def _make_converter() -> cattrs.Converter:
    converter = cattrs.Converter(forbid_extra_keys=True, detailed_validation=True)
    converter.register_structure_hook_factory(attrs.has, _mapping_first(converter))
    converter.register_structure_hook_factory(lambda t: typing.get_origin(t) is list,
                                              _list_first(converter))
    converter.register_structure_hook(int, _integer)
    converter.register_structure_hook(float, _strict(float, "a number", (int, float)))
    converter.register_structure_hook(bool, _strict(bool, "true or false", (bool,)))
    converter.register_structure_hook(str, _strict(str, "a string", (str,)))
    converter.register_structure_hook(Path, _path)
    converter.register_structure_hook(OutputPath, _output_path)
    converter.register_structure_hook_func(lambda t: typing.get_origin(t) is Literal, _literal)
    converter.register_unstructure_hook(Path, str)
    return converter


converter = _make_converter()
"""The converter that reads every component's options."""


@contextlib.contextmanager
def paths_relative_to(base: Path) -> Iterator[None]:
    """Resolve relative ``Path`` options against ``base`` while structuring."""
    token = _base_dir.set(base)
    try:
        yield
    finally:
        _base_dir.reset(token)


@contextlib.contextmanager
def slots_configured(names: Mapping[str, str]) -> Iterator[None]:
    """Let option validators see which component each plugin slot names (see
    :func:`configured`) while the other slots' options are structured."""
    token = _slots.set(names)
    try:
        yield
    finally:
        _slots.reset(token)


def configured(slot: str) -> str | None:
    """The name of the component the configuration being read puts in the plugin slot ``slot``
    (its default when the file names none), for an option validator that depends on it (a
    planner option that a constrained robot rules out); None outside the reading of a
    configuration, or when no such slot is filled."""
    return _slots.get({}).get(slot)


def _describe(exc: BaseException) -> str:
    if isinstance(exc, KeyError):
        return "required option is missing"
    if isinstance(exc, TypeError | ValueError):
        return str(exc)
    return f"{type(exc).__name__}: {exc}"


_VALIDATOR_MESSAGE = re.compile(r"^'(?P<field>\w+)' (?P<rest>must .*)$", re.S)


def _walk(exc: BaseException, path: str) -> Iterator[tuple[str, str]]:
    if isinstance(exc, ForbiddenExtraKeysError):
        fields = [a.name for a in attrs.fields(exc.cl)] if attrs.has(exc.cl) else []
        expected = f"one of: {', '.join(fields)}" if fields else "no options"
        # YAML allows keys that are not text (3: 1): sorted as text, so they mix with names
        for key in sorted(exc.extra_fields, key=str):
            yield f"{path}.{key}", f"unknown key; expected {expected}"
    elif isinstance(exc, ClassValidationError | IterableValidationError):
        noted, plain = exc.group_exceptions()
        for inner, note in noted:
            step = getattr(note, "name", None)
            yield from _walk(inner, f"{path}.{step if step is not None else note.index}")
        for inner in plain:
            yield from _walk(inner, path)
    elif isinstance(exc, BaseExceptionGroup):
        for inner in exc.exceptions:
            yield from _walk(inner, path)
    elif isinstance(exc, ValueError) and (named := _VALIDATOR_MESSAGE.match(str(exc))):
        # attrs validators raise after structuring, naming the field only in their message
        yield f"{path}.{named['field']}", named["rest"]
    else:
        yield path, _describe(exc)


def _unquoted(message: str) -> str:
    """A problem with an option that may hold a secret, without the value it quotes: what was
    expected, when the message says so, else only that the value is refused."""
    expected, got, _ = message.partition(", got ")
    return f"{expected if got else 'the value is refused'} (the value given is not shown)"


def option_problems(options_cls: type, data: Any, where: str) -> tuple[Any, list[tuple[str, str]]]:
    """Structure ``data`` into ``options_cls``; return the instance or the problems found.

    Each problem is ``(yaml_path, message)`` with paths below ``where``.
    """
    if data is None:
        data = {}
    if not isinstance(data, Mapping):
        return None, [(where, f"expected a mapping of options, got "
                              f"{found(data, setting=True)}")]
    try:
        return converter.structure(dict(data), options_cls), []
    except Exception as exc:  # cattrs gathers every field's error into one group
        secret = {f"{where}.{field.name}" for field in attrs.fields(options_cls)
                  if _SHOWN in field.metadata}
        return None, [(path, _unquoted(message) if path in secret else message)
                      for path, message in _walk(exc, where)]


def structure_options(options_cls: type, data: Any, where: str) -> Any:
    """Structure ``data`` into ``options_cls`` or raise a :class:`ConfigError` listing problems."""
    value, problems = option_problems(options_cls, data, where)
    if problems:
        raise ConfigError(where, [f"{path}: {message}" for path, message in problems])
    return value


def unstructure(options: Any) -> Any:
    """Plain data for an options instance (as written to a run's manifest)."""
    return converter.unstructure(options)


def _secrets(options: Any) -> Iterator[tuple[str, str, Callable[[str], str]]]:
    """``(field name, value, how it is shown)`` for each string option of ``options`` itself
    declared with ``shown``."""
    for field in attrs.fields(type(options)):
        show = field.metadata.get(_SHOWN)
        value = getattr(options, field.name)
        if show is not None and isinstance(value, str):
            yield field.name, value, show


def displayed(options: Any) -> Any:
    """Plain data for an options instance as :func:`unstructure` gives it, with the value of
    every option declared with ``shown`` (in nested options instances too) as it is shown."""
    data = unstructure(options)
    _mask(options, data)
    return data


def _mask(options: Any, data: Any) -> None:
    if not attrs.has(type(options)) or not isinstance(data, dict):
        return
    for name, value, show in _secrets(options):
        data[name] = show(value)
    for field in attrs.fields(type(options)):
        value, plain = getattr(options, field.name), data.get(field.name)
        if isinstance(value, list | tuple) and isinstance(plain, list):
            for item, item_plain in zip(value, plain, strict=False):
                _mask(item, item_plain)
        else:
            _mask(value, plain)


def secret_values(options: Any) -> dict[str, str]:
    """Each value of an option declared with ``shown`` (in nested options instances too), with
    what is shown instead: to mask it wherever it was written, such as a command line."""
    if not attrs.has(type(options)):
        return {}
    found = {value: show(value) for _, value, show in _secrets(options) if value}
    for field in attrs.fields(type(options)):
        value = getattr(options, field.name)
        for item in value if isinstance(value, list | tuple) else (value,):
            found.update(secret_values(item))
    return found
