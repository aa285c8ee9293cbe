"""The nonholonomic planning page (docs/kinematics.md): its commands print what it shows, its
Python examples run, and the U-turn example's claims hold, checked here on the map itself."""

from __future__ import annotations

import contextlib
import io
import itertools
import json
import math
import re
import shlex
import types
from collections.abc import Callable
from pathlib import Path

import pytest

from cbrcore.plugins import Plugins
from cbrcore.testing import CliResult
from repo_paths import ROOT

Cli = Callable[..., CliResult]

PAGE = ROOT / "docs" / "kinematics.md"
FENCE = re.compile(r"^```(\w*)\n(.*?)^```$", re.S | re.M)
PLUGIN_HEADER = "# cbr-steering/src/cbr_steering/__init__.py\n"
PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"

# The compass of the page, written out here: 0 = E, counter-clockwise, rows counted downwards.
COMPASS = {(1, 0): 0, (1, -1): 1, (0, -1): 2, (-1, -1): 3, (-1, 0): 4, (-1, 1): 5, (0, 1): 6,
           (1, 1): 7}
NAMES = {"E": 0, "NE": 1, "N": 2, "NW": 3, "W": 4, "SW": 5, "S": 6, "SE": 7}


def blocks() -> list[tuple[str, str]]:
    """The page's fenced blocks in order, as (language, text)."""
    return [(m.group(1), m.group(2)) for m in FENCE.finditer(PAGE.read_text(encoding="utf-8"))]


def examples() -> list[tuple[str, str | None]]:
    """Every ``cbr plan`` command on the page, with the output block shown after it (if any)."""
    found = []
    shown = blocks()
    for i, (_, text) in enumerate(shown):
        for line in text.splitlines():
            if line.startswith("cbr plan "):
                after = shown[i + 1] if i + 1 < len(shown) else ("", "")
                found.append((line, after[1] if after[0] == "text" else None))
    return found


def options(command: str) -> dict[str, str]:
    """The ``--option value`` pairs of a command line."""
    words = shlex.split(command)
    return {word: words[k + 1] for k, word in enumerate(words) if word.startswith("--")}


def command(*, plot: str | None = None, start: str | None = None,
            kinematics: str | None = None) -> str:
    """The one page command with the given picture, or start and model (None: holonomic)."""
    matches = [line for line, _ in examples()
               if (plot is None or options(line).get("--plot", "").endswith(plot))
               and (start is None or options(line)["--start"] == start)
               and options(line).get("--kinematics") == kinematics]
    assert len(matches) == 1, matches
    return matches[0]


def steering_plugin() -> types.ModuleType:
    """The kinematic model plugin of the page's last section, as a module."""
    code = [text for language, text in blocks()
            if language == "python" and text.startswith(PLUGIN_HEADER)]
    assert len(code) == 1
    module = types.ModuleType("cbr_steering")
    exec(compile(code[0], f"{PAGE}:cbr_steering", "exec"), module.__dict__)
    return module


@pytest.fixture(autouse=True)
def installed(cbr_plugins: Callable[..., Plugins], monkeypatch: pytest.MonkeyPatch) -> Plugins:
    """The installed plugins and the page's own plugin, run from the repository root as the page
    says."""
    monkeypatch.chdir(ROOT)
    return cbr_plugins(("steering", steering_plugin()), entry_points=True)


def run(cli: Cli, line: str, *extra: str, tmp_path: Path | None = None) -> CliResult:
    """Run a page command; its picture, if any, goes into ``tmp_path``."""
    words = shlex.split(line)
    assert words[:2] == ["cbr", "plan"]
    args = words[1:]
    if "--plot" in args:
        k = args.index("--plot") + 1
        assert tmp_path is not None
        args[k] = str(tmp_path / Path(args[k]).name)
    return cli(*args, *extra)


def record(cli: Cli, line: str) -> dict:
    """The JSON record of a page command (without its picture)."""
    words = shlex.split(line)
    if "--plot" in words:
        k = words.index("--plot")
        del words[k:k + 2]
    result = run(cli, shlex.join(words), "--json")
    assert result.exit_code == 0, result.stderr
    return json.loads(result.stdout)


def read_map(path: Path) -> list[str]:
    """The rows of a Moving AI map, read here from the file's text."""
    lines = path.read_text(encoding="ascii").splitlines()
    assert lines[0] == "type octile" and lines[3] == "map"
    height, width = int(lines[1].split()[1]), int(lines[2].split()[1])
    rows = lines[4:]
    assert len(rows) == height and all(len(row) == width for row in rows)
    return rows


def directions(rows: list[str], path: list[list[int]]) -> list[int]:
    """The direction of each step of ``path``, checking that it is a legal move on the map:
    passable cells, one step to a neighbour, a diagonal step between two passable cells."""
    def free(x: int, y: int) -> bool:
        return 0 <= y < len(rows) and 0 <= x < len(rows[0]) and rows[y][x] == "."

    assert all(free(x, y) for x, y in path)
    found = []
    for (x0, y0), (x1, y1) in itertools.pairwise(path):
        step = (x1 - x0, y1 - y0)
        assert step in COMPASS, (x0, y0, x1, y1)
        if step[0] and step[1]:
            assert free(x1, y0) and free(x0, y1), (x0, y0, x1, y1)
        found.append(COMPASS[step])
    return found


def turn(a: int, b: int) -> int:
    """The turn from direction a to direction b in 45-degree steps, 0-4."""
    alpha = abs(a - b)
    return min(alpha, 8 - alpha)


def octile_cost(path: list[list[int]]) -> float:
    """The cost of a path on a map without risk: 1 per straight step, sqrt 2 per diagonal one."""
    return sum(math.sqrt(2.0) if x0 != x1 and y0 != y1 else 1.0
               for (x0, y0), (x1, y1) in itertools.pairwise(path))


@pytest.mark.parametrize(("line", "shown"), examples(), ids=[
    f"{options(line).get('--kinematics', 'holonomic')}-{options(line)['--start']}"
    for line, _ in examples()])
def test_page_commands_print_what_the_page_shows(invoke_cbr: Cli, tmp_path: Path, line: str,
                                                 shown: str | None) -> None:
    result = run(invoke_cbr, line, tmp_path=tmp_path)
    assert shown is not None, f"no output shown for {line}"
    if shown.startswith("no path"):
        assert result.exit_code == 1
        assert result.stderr.strip() == shown.strip()
        return
    assert result.exit_code == 0, result.stderr
    printed, expected = result.stdout.splitlines(), shown.splitlines()
    assert len(printed) == len(expected)
    for got, want in zip(printed, expected, strict=True):
        key = want.split()[0]
        if key == "time_ms":  # varies from run to run
            assert got.split()[0] == key and float(got.split()[1]) >= 0.0
        elif key == "wrote":
            picture = tmp_path / Path(want.split()[1]).name
            assert got == f"wrote {picture}"
            assert picture.read_bytes().startswith(PNG_SIGNATURE)
        else:
            assert got == want


def test_page_pictures_exist_where_the_commands_write_them() -> None:
    pictures = [options(line)["--plot"] for line, _ in examples() if "--plot" in line]
    assert sorted(Path(p).name for p in pictures) == [
        "kinematics_forward.png", "kinematics_forward_backward.png", "kinematics_holonomic.png"]
    text = PAGE.read_text(encoding="utf-8")
    for picture in pictures:
        assert (ROOT / picture).read_bytes().startswith(PNG_SIGNATURE)
        assert f"]({Path(picture).relative_to('docs')})" in text  # shown on the page


def test_the_holonomic_path_is_not_one_a_forward_robot_can_drive(invoke_cbr: Cli) -> None:
    forward = options(command(plot="kinematics_forward.png", kinematics="forward"))
    holonomic_line = command(plot="kinematics_holonomic.png")
    assert options(holonomic_line)["--start"] == forward["--start"]
    assert options(holonomic_line)["--goal"] == forward["--goal"]
    rows = read_map(ROOT / shlex.split(holonomic_line)[2])
    path = record(invoke_cbr, holonomic_line)["path"]
    steps = [NAMES[forward["--heading"]], *directions(rows, path)]
    assert max(turn(a, b) for a, b in itertools.pairwise(steps)) > 1


def test_the_forward_path_turns_45_degrees_at_most_and_costs_more(invoke_cbr: Cli) -> None:
    line = command(plot="kinematics_forward.png", kinematics="forward")
    given = options(line)
    rows = read_map(ROOT / shlex.split(line)[2])
    found = record(invoke_cbr, line)
    path = found["path"]
    assert path[0] == [int(v) for v in given["--start"].split(",")]
    assert path[-1] == [int(v) for v in given["--goal"].split(",")]
    steps = [NAMES[given["--heading"]], *directions(rows, path), NAMES[given["--final-heading"]]]
    assert all(turn(a, b) <= 1 for a, b in itertools.pairwise(steps))
    assert not any(found["reversing"])
    assert found["cost"] == pytest.approx(octile_cost(path))
    holonomic = record(invoke_cbr, command(plot="kinematics_holonomic.png"))
    assert holonomic["cost"] == pytest.approx(octile_cost(holonomic["path"]))
    assert found["cost"] > holonomic["cost"] + 10.0


def test_only_forward_backward_leaves_the_dead_end(invoke_cbr: Cli) -> None:
    line = command(plot="kinematics_forward_backward.png", kinematics="forward_backward")
    given = options(line)
    stuck = command(start=given["--start"], kinematics="forward")
    assert {k: v for k, v in options(stuck).items() if k != "--kinematics"} == {
        k: v for k, v in given.items() if k not in ("--kinematics", "--plot")}
    assert run(invoke_cbr, stuck, "--json").exit_code == 1

    rows = read_map(ROOT / shlex.split(line)[2])
    found = record(invoke_cbr, line)
    path = found["path"]
    assert path[0] == [int(v) for v in given["--start"].split(",")]
    assert path[-1] == [int(v) for v in given["--goal"].split(",")]
    steps = [NAMES[given["--heading"]], *directions(rows, path), NAMES[given["--final-heading"]]]
    turns = [turn(a, b) for a, b in itertools.pairwise(steps)]
    # gentle turns, and cusps: a step straight back along the one before it
    assert set(turns) <= {0, 1, 4} and 4 in turns
    assert any(found["reversing"])
    cusp = turns.index(4)  # steps[cusp + 1] is the first step driven in reverse
    assert found["reversing"][cusp] and not any(found["reversing"][:cusp])
    # the manoeuvre costs its step out and back, on top of the cells driven
    assert found["cost"] == pytest.approx(octile_cost(path))


def test_the_figures_quoted_in_the_text_are_the_commands(invoke_cbr: Cli) -> None:
    text = " ".join(PAGE.read_text(encoding="utf-8").split())
    forward = record(invoke_cbr, command(plot="kinematics_forward.png", kinematics="forward"))
    holonomic = record(invoke_cbr, command(plot="kinematics_holonomic.png"))
    quoted = re.search(r"The path costs ([\d.]+) against the holonomic ([\d.]+)", text)
    assert quoted is not None
    assert quoted.groups() == (f"{forward['cost']:.2f}", f"{holonomic['cost']:.2f}")

    back = record(invoke_cbr, command(plot="kinematics_forward_backward.png",
                                   kinematics="forward_backward"))
    quoted = re.search(r"on to the goal, ([\d.]+) in all", text)
    assert quoted is not None and quoted.group(1) == f"{back['cost']:.2f}"

    # the price of step 4: without a final heading the search settles every edge it can reach
    from cbr_grid.movingai import load_map
    from cbr_kinematics.models import Forward
    from cbr_solvers.kinematic_search import astar, dijkstra

    given = options(command(plot="kinematics_forward.png", kinematics="forward"))
    grid = load_map(ROOT / "docs" / "examples" / "uturn.map")
    start = tuple(int(v) for v in given["--start"].split(","))
    goal = tuple(int(v) for v in given["--goal"].split(","))
    ends = (grid.factor, grid.passable, grid.corner_cutting, start, goal)
    free = astar(*ends, kinematics=Forward(), heading=NAMES[given["--heading"]])
    exhaustive = dijkstra(*ends, kinematics=Forward(), heading=NAMES[given["--heading"]])
    assert free is not None and exhaustive is not None
    assert free.expanded == exhaustive.expanded
    assert free.cost == pytest.approx(forward["cost"])
    quoted = re.search(r"settles all (\d+) edges it can reach, and (\d+) with the final heading "
                       r"(\w+)\.", text)
    assert quoted is not None
    assert quoted.groups() == (str(free.expanded), str(forward["expanded"]),
                               given["--final-heading"])


def test_python_examples_print_what_the_page_shows() -> None:
    shown = blocks()
    ran = 0
    for i, (language, code) in enumerate(shown):
        if language != "python" or code.startswith(PLUGIN_HEADER):
            continue
        printed = io.StringIO()
        with contextlib.redirect_stdout(printed):
            exec(compile(code, f"{PAGE}:block{i}", "exec"), {})
        assert shown[i + 1][0] == "text"
        assert printed.getvalue() == shown[i + 1][1]
        ran += 1
    assert ran == 2


def test_the_configuration_example_plans_for_a_forward_robot(
        monkeypatch: pytest.MonkeyPatch) -> None:
    from cbr_grid.query import GridQuery
    from cbrcore import Engine
    from cbrcore.config import config_from_text
    from cbrcore.plugins import current

    yaml = [text for language, text in blocks() if language == "yaml"]
    assert len(yaml) == 1
    monkeypatch.chdir(ROOT / "docs" / "examples")  # the map beside the configuration
    with Engine(config_from_text(yaml[0], current().registry)) as engine:
        proposal = engine.solve(GridQuery((10, 6), (2, 4), heading=NAMES["E"],
                                          final_heading=NAMES["W"]))
    assert proposal.solution is not None
    assert proposal.solution.cost == pytest.approx(octile_cost(proposal.solution.value))
    assert proposal.solution.cost > 20.0
    assert not any(proposal.solution.detail["reversing"])
