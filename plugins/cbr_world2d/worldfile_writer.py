"""Writing a world back as a world file: :func:`dump_world` gives the plain data of the format
(:mod:`cbr_world2d.worldfile`), :func:`world_yaml` its text, one line per item, and
:func:`save_world` writes it."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import yaml

from cbr_world2d.shapes import rim_wall
from cbr_world2d.world import Wall, World
from cbr_world2d.worldfile import is_number


def _plain(point: Sequence[float]) -> list[float]:
    return [float(v) for v in point]


def _between_matches(world: World, wall: Wall) -> bool:
    """Whether the wall is exactly the rim segment its ``between`` names (then it is written as
    ``between``, and reading rebuilds the same floats)."""
    if wall.between is None:
        return False
    try:
        first, second = (world.landmark(id) for id in wall.between)
    except KeyError:
        return False
    ends = rim_wall(first, second)
    return ends is not None and ends == (tuple(wall.a), tuple(wall.b))


def dump_world(world: World) -> dict[str, Any]:
    """The world as plain data in the world file's format:
    :func:`~cbr_world2d.worldfile.world_from_data` of it gives
    the same world (every number written exactly, door phases included). A wall whose
    ``between`` no longer matches its landmarks' rims is written by its ends."""
    data: dict[str, Any] = {"name": world.name} if world.name else {}
    data["bounds"] = _plain(world.bounds)
    if world.landmarks:
        data["landmarks"] = [{"id": m.id, "at": [float(m.x), float(m.y)],
                              "radius": float(m.radius)} for m in world.landmarks]
    if world.walls:
        data["walls"] = [{"between": list(w.between)} if _between_matches(world, w)
                         else {"a": _plain(w.a), "b": _plain(w.b)} for w in world.walls]
    if world.polygons:
        data["polygons"] = [[_plain(v) for v in polygon] for polygon in world.polygons]
    if world.points:
        data["points"] = [{"at": _plain(p[:2]), "radius": float(p[2])} for p in world.points]
    if world.doors:
        data["doors"] = [{"a": _plain(d.a), "b": _plain(d.b), "period": float(d.period),
                          "open_for": float(d.open_for), "phase": float(d.phase),
                          **({"name": d.name} if d.name else {})} for d in world.doors]
    if world.movers:
        data["movers"] = [{"waypoints": [_plain(p) for p in m.waypoints],
                           "speed": float(m.speed), "radius": float(m.radius), "kind": m.kind,
                           "appears": float(m.appears),
                           **({"leaves": float(m.leaves)} if m.leaves is not None else {}),
                           **({"yields": True} if m.yields else {})}
                          for m in world.movers]
    if world.places:
        data["places"] = {name: _plain(point) for name, point in world.places.items()}
    return data


class _Flow(dict):  # type: ignore[type-arg]
    """A mapping written on one line."""


class _Dumper(yaml.SafeDumper):
    pass


def _represent_list(dumper: yaml.SafeDumper, data: list[Any]) -> yaml.Node:
    flat = all(is_number(v) or (isinstance(v, list) and all(is_number(w) for w in v)) for v in data)
    return dumper.represent_sequence("tag:yaml.org,2002:seq", data, flow_style=flat and bool(data))


def _represent_flow(dumper: yaml.SafeDumper, data: _Flow) -> yaml.Node:
    return dumper.represent_mapping("tag:yaml.org,2002:map", data.items(), flow_style=True)


_Dumper.add_representer(list, _represent_list)
_Dumper.add_representer(_Flow, _represent_flow)


def world_yaml(world: World) -> str:
    """The world file text of ``world``: one line per item, points written ``[x, y]``."""
    data = dump_world(world)
    for key, value in data.items():
        if isinstance(value, list) and value and isinstance(value[0], dict):
            data[key] = [_Flow(item) for item in value]
    return yaml.dump(data, Dumper=_Dumper, sort_keys=False, width=100, allow_unicode=True)


def save_world(world: World, path: str | Path) -> None:
    """Write ``world`` as a world file at ``path``."""
    Path(path).write_text(world_yaml(world), encoding="utf-8")
