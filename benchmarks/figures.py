"""Figures the docs quote from benchmarks and experiments, rendered from committed results.

A page marks each generated block::

    <!-- figures: NAME -->
    ...rendered text...
    <!-- /figures -->

and this script renders the block NAME from the results a full run wrote: a benchmark's
``benchmarks/results/<benchmark>.md`` / ``.json``, or an experiment's results kept in
``docs/figures/<experiment>.json`` (its ``results.json`` trimmed to what the pages use, with the
run's ``results.md`` table and the command that made it). A rerun that commits new results
changes the pages only through ``--write``, so a page cannot quote a figure its results do not
hold.

    python benchmarks/figures.py --check     # exit 1 naming each page and block that is stale
    python benchmarks/figures.py --write     # rewrite the blocks from the results
    python benchmarks/figures.py --list      # the blocks and where their figures come from
    python benchmarks/figures.py --keep-experiment NAME DIR   # commit DIR's results for NAME
"""

from __future__ import annotations

import argparse
import json
import re
import sys
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import attrs

ROOT = Path(__file__).resolve().parent.parent
DOCS = ROOT / "docs"
RESULTS = ROOT / "benchmarks" / "results"
KEPT = DOCS / "figures"

BLOCK = re.compile(r"(<!-- figures: (?P<name>[\w.-]+) -->\n)(?P<body>.*?)(<!-- /figures -->)",
                   re.S)


class FiguresError(Exception):
    """A block that cannot be rendered: unknown name, missing or malformed results."""


@attrs.frozen
class Block:
    """A generated block: what renders it and the results file its figures come from."""

    name: str
    source: Path
    render: Callable[[], str]


# --- reading results -------------------------------------------------------------------------


def _read(path: Path) -> str:
    try:
        return path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise FiguresError(f"{path.relative_to(ROOT)}: no such results file") from None


def load_json(path: Path) -> Any:
    try:
        return json.loads(_read(path))
    except json.JSONDecodeError as exc:
        raise FiguresError(f"{path.relative_to(ROOT)}: not JSON ({exc})") from None


def tables(text: str) -> list[list[str]]:
    """The markdown tables of ``text``, each as its lines."""
    found: list[list[str]] = []
    current: list[str] = []
    for line in [*text.splitlines(), ""]:
        if line.startswith("|"):
            current.append(line)
        elif current:
            found.append(current)
            current = []
    return found


def _cells(line: str) -> list[str]:
    return [cell.strip() for cell in line.strip().strip("|").split("|")]


def table(text: str, index: int, columns: Sequence[str] | None = None, *, where: str = ""
          ) -> str:
    """Table ``index`` of ``text``, with only ``columns`` (by header, in that order) and only the
    rows whose first cell starts with ``where``."""
    found = tables(text)
    if index >= len(found):
        raise FiguresError(f"results hold {len(found)} tables, not table {index + 1}")
    header, _, *rows = found[index]
    names = _cells(header)
    keep = list(range(len(names))) if columns is None else []
    for column in columns or ():
        if column not in names:
            raise FiguresError(f"results table {index + 1} has no column {column!r}: {names}")
        keep.append(names.index(column))
    chosen = [_cells(row) for row in rows if _cells(row)[0].startswith(where)]
    lines = [[names[k] for k in keep], ["---"] * len(keep),
             *[[row[k] for k in keep] for row in chosen]]
    return "\n".join("| " + " | ".join(line) + " |" for line in lines)


def paragraphs(text: str, start: str) -> str:
    """The paragraph of ``text`` that starts with ``start``."""
    for paragraph in text.split("\n\n"):
        if paragraph.startswith(start):
            return paragraph.strip()
    raise FiguresError(f"results hold no paragraph starting {start!r}")


def result_md(benchmark: str) -> str:
    return _read(RESULTS / f"{benchmark}.md")


def kept(experiment: str) -> dict[str, Any]:
    """An experiment's committed results: ``command``, ``table`` (its results.md), ``results``."""
    data = load_json(KEPT / f"{experiment}.json")
    missing = {"command", "table", "results"} - set(data)
    if missing:
        raise FiguresError(f"docs/figures/{experiment}.json lacks {sorted(missing)}")
    return data


# --- renderers -------------------------------------------------------------------------------


def _bench_table(benchmark: str, index: int, columns: Sequence[str] | None = None,
                 where: str = "") -> Callable[[], str]:
    return lambda: table(result_md(benchmark), index, columns, where=where)


def _solvers_maps() -> str:
    text = result_md("solvers")
    return table(text, 0) + "\n\n" + paragraphs(text, "\\* pyastar2d")


def _solvers_pooled() -> str:
    text = result_md("solvers")
    rows = table(text, 1, ["map", "queries (nx)", "A* ms", "Dijkstra ms", "pyastar2d ms*",
                           "tcod ms", "scipy ms", "networkx ms", "A*/pyastar2d*", "A*/tcod",
                           "A*/networkx", "Dijkstra/scipy"])
    return rows + "\n\n" + paragraphs(text, "One-time costs")


def _radius_row(radius: int, coverage: float) -> dict[str, Any]:
    rows = load_json(RESULTS / "casegraph_similarity_radius.json")["rows"]
    for row in rows:
        if row["radius"] == radius and round(row["coverage"] * 100) == coverage:
            return row
    raise FiguresError(f"casegraph_similarity_radius.json has no row for δr = {radius} at "
                       f"{coverage}% coverage")


def _radius_deviations() -> str:
    """The similarity radius sentence of the reproductions page."""
    ten, fifteen = _radius_row(1, 10), _radius_row(1, 15)
    base_ten, base_fifteen = _radius_row(0, 10), _radius_row(0, 15)
    return (f"**The similarity radius matters most.** With eq. 12 at δr = 1, CBR's cost "
            f"deviation is {ten['cost_deviation']:.1f}% at 10% coverage and "
            f"{fifteen['cost_deviation']:.1f}% at 15% on the same map (δr = 0: "
            f"{base_ten['cost_deviation']:.1f}% and {base_fifteen['cost_deviation']:.1f}%; "
            "`python benchmarks/casegraph_similarity_radius.py --size full`): staircase paths "
            "lose every other step to the similarity test and the graph search has to detour "
            "around the gaps. The default δr = 0 keeps them (see "
            "[the case graph page](casegraph.md)).")


def _radius_casegraph() -> str:
    """The similarity radius sentence of the case graph page."""
    rows = {r: _radius_row(r, 10) for r in (0, 1, 2)}
    shares = ", ".join(f"{rows[r]['cbr_share']:.3f}" for r in rows)
    return (f"On the reproductions' 200x200 map, at {rows[0]['target_vertices']} vertices (10% "
            f"coverage), CBR's mean cost deviation from the optimum is "
            f"{rows[0]['cost_deviation']:.1f}% with δr = 0, {rows[1]['cost_deviation']:.1f}% "
            f"with δr = 1 and {rows[2]['cost_deviation']:.1f}% with δr = 2 (CBR shares "
            f"{shares}; `python benchmarks/casegraph_similarity_radius.py --size full`, the "
            "setting of the [deviation table](reproductions.md#deviations-from-the-best-path-"
            "section-64-table-1-and-fig-5)).")


def _share_rows() -> dict[int, dict[str, Any]]:
    return {row["coverage_percent"]: row for row in kept("cbr-share")["results"]["rows"]}


def _share_growth() -> str:
    """How many paths the graph of the cbr-share experiment took to reach each coverage."""
    rows = _share_rows()
    wanted = [c for c in (2, 6, 10, 15, 20) if c in rows]
    parts = [f"{rows[c]['paths_retained']} for {c}%" for c in wanted]
    listed = ", ".join(parts[:-1]) + f" and {parts[-1]}"
    return (f"On the 200x200 map it takes {listed.replace(' for', ' paths for', 1)}: the more "
            "of the map is covered, the fewer new\nsegments a path brings.")


def _share_against_paper() -> str:
    """The cbr-share experiment's shares at the paper's three points."""
    from cbr_casegraph.experiments.share import PAPER_SHARE

    rows = _share_rows()
    points = [f"{rows[c]['share'] * 100:.0f}% at {c}% coverage (paper about {p * 100:.0f}%)"
              if k == 0 else f"{rows[c]['share'] * 100:.0f}% at {c}% ({p * 100:.0f}%)"
              for k, (c, p) in enumerate(PAPER_SHARE.items())]
    return (f"Our shares lie above the paper's three points: {', '.join(points)}; the shape "
            "is the same, a steep rise at low coverage and a plateau above.")


def _deviation_against_paper() -> str:
    """The deviation-table experiment's CBR row against the paper's, and the project's targets."""
    from cbr_casegraph.experiments.deviation import PAPER_TABLE

    rows = {row["target_vertices"]: row for row in kept("deviation-table")["results"]["rows"]}
    ours = ", ".join(f"{rows[v]['deviation']['CBR']['cost']:.1f}" for v in rows)
    theirs = ", ".join(f"{PAPER_TABLE[v]['CBR'][0]:.1f}" for v in rows if v in PAPER_TABLE)
    ten, fifteen = rows[4000], rows[6000]
    met = all((row["cbr_share"] >= share and row["deviation"]["CBR"]["cost"] <= deviation)
              for row, share, deviation in ((ten, 0.75, 8), (fifteen, 0.90, 5)))
    return (f"CBR's cost deviation in percent at the four coverages: {ours}; the paper's: "
            f"{theirs}. The project's targets (share at least 75% and deviation at most 8% at "
            "10% coverage, share at least 90% and deviation at most 5% at 15%) are "
            f"{'met' if met else 'not met'}: {ten['cbr_share'] * 100:.1f}% / "
            f"{ten['deviation']['CBR']['cost']:.1f}% and {fifteen['cbr_share'] * 100:.1f}% / "
            f"{fifteen['deviation']['CBR']['cost']:.1f}%.")


def _faster_from(rows: list[dict[str, Any]], method: str) -> str:
    """The smallest map from which CBR (its slowest graph) beats ``method`` on every larger one."""
    side = None
    for row in reversed(rows):
        cbr = [ms for ms in row["cbr_ms"].values() if ms is not None]
        if not cbr or max(cbr) >= row[f"{method}_ms"]:
            break
        side = row["size"]
    return "on no map" if side is None else f"from {side}x{side} up"


def _map_size_reading() -> str:
    """The time-vs-map-size experiment's reading: CBR flat, the searches growing."""
    rows = kept("time-vs-map-size")["results"]["rows"]
    cbr = [ms for row in rows for ms in row["cbr_ms"].values() if ms is not None]
    first, last = rows[0], rows[-1]

    def grows(method: str, digits: int) -> str:
        return f"from {first[f'{method}_ms']:.{digits}f} to {last[f'{method}_ms']:.0f} ms"

    ratios = [f"about {row['astar_ms'] / row['cbr_ms']['3000']:.0f}x at "
              f"{row['size']}x{row['size']}" for row in rows
              if row["size"] in (600, 1000) and row["cbr_ms"].get("3000")]
    return (f"The paper's finding holds: CBR's time hardly depends on the map's size "
            f"({min(cbr):.1f}-{max(cbr):.1f} ms from {first['size']}x{first['size']} to "
            f"{last['size']}x{last['size']} for every graph), while the alternative methods' "
            f"times grow steeply with it: Dijkstra {grows('dijkstra', 1)}, A* "
            f"{grows('astar', 2)}, Ai* {grows('aistar', 1)} (Ai* builds its integer distance "
            "map over the whole map before searching). CBR with 3000 vertices is faster than "
            f"our compiled A* {_faster_from(rows, 'astar')}, {' and '.join(ratios)} in this "
            f"run, and faster than Dijkstra {_faster_from(rows, 'dijkstra')}.")


def _vertices_reading() -> str:
    """The time-vs-vertices experiment's reading: growth with the graph, selective adaptation."""
    rows = kept("time-vs-vertices")["results"]["rows"]
    growth = rows[-1]["full_ms"] / rows[0]["full_ms"]
    ratios = [row["selective_ms"] / row["full_ms"] for row in rows]
    saves = "saves nothing here" if min(ratios) >= 1 else "saves little here"
    return (f"As in the paper, CBR time grows with the vertex count ({growth:.1f}x from "
            f"{rows[0]['vertices']} to {rows[-1]['vertices']} vertices), but selective "
            f"adaptation {saves} ({min(ratios):.2f}-{max(ratios):.2f} times full adaptation's "
            "time), where the paper shows it clearly below full adaptation.")


def _experiment_table(experiment: str, index: int) -> Callable[[], str]:
    return lambda: table(kept(experiment)["table"], index)


def _blocks() -> list[Block]:
    bench = RESULTS
    return [
        Block("engine-overhead", bench / "engine_overhead.md", _bench_table("engine_overhead", 0)),
        Block("solvers-maps", bench / "solvers.md", _solvers_maps),
        Block("solvers-pooled", bench / "solvers.md", _solvers_pooled),
        Block("genetic", bench / "genetic.md", _bench_table("genetic", 0)),
        Block("casegraph-speed", bench / "casegraph_speed.md",
              lambda: table(result_md("casegraph_speed"), 0) + "\n\n"
              + table(result_md("casegraph_speed"), 1)),
        Block("casegraph-movingai", bench / "casegraph_movingai.md",
              _bench_table("casegraph_movingai", 0)),
        Block("pathcases-speed", bench / "pathcases_speed.md",
              lambda: "\n\n".join(table(result_md("pathcases_speed"), k) for k in range(3))),
        Block("world2d-speed", bench / "world2d_speed.md",
              lambda: table(result_md("world2d_speed"), 0) + "\n\n"
              + table(result_md("world2d_speed"), 1)),
        Block("landmarks-retrieval", bench / "landmarks_retrieval.md",
              _bench_table("landmarks_retrieval", 0,
                           ["what", "median ms per query", "p90 ms", "note"])),
        Block("landmarks-retrieval-by-size", bench / "landmarks_retrieval.md",
              _bench_table("landmarks_retrieval", 1)),
        Block("rupart-retrieval", bench / "rupart_retrieval.md",
              _bench_table("rupart_retrieval", 0, ["what", "median ms per query", "p90 ms"])),
        Block("kinematics-pooled", bench / "kinematics_speed.md",
              _bench_table("kinematics_speed", 1,
                           ["model", "solved", "edge A* / A*", "edge Dijkstra / A*", "exhaustive",
                            "cost / optimum (median, max)"])),
        Block("similarity-radius", bench / "casegraph_similarity_radius.md",
              _bench_table("casegraph_similarity_radius", 0)),
        Block("similarity-radius-reproductions", bench / "casegraph_similarity_radius.json",
              _radius_deviations),
        Block("similarity-radius-casegraph", bench / "casegraph_similarity_radius.json",
              _radius_casegraph),
        Block("deviation-against-paper", KEPT / "deviation-table.json",
              _deviation_against_paper),
        Block("map-size-reading", KEPT / "time-vs-map-size.json", _map_size_reading),
        Block("vertices-reading", KEPT / "time-vs-vertices.json", _vertices_reading),
        Block("cbr-share-growth", KEPT / "cbr-share.json", _share_growth),
        Block("cbr-share-against-paper", KEPT / "cbr-share.json", _share_against_paper),
        *[Block(f"{name}-table-{k + 1}", KEPT / f"{name}.json", _experiment_table(name, k))
          for name, count in (("cbr-share", 1), ("deviation-table", 2),
                              ("time-vs-map-size", 1), ("time-vs-vertices", 1))
          for k in range(count)],
    ]


BLOCKS = {block.name: block for block in _blocks()}


# --- pages -----------------------------------------------------------------------------------


def render(name: str) -> str:
    if name not in BLOCKS:
        raise FiguresError(f"unknown block {name!r}; known: {', '.join(sorted(BLOCKS))}")
    return BLOCKS[name].render().rstrip("\n") + "\n"


def pages(docs: Path = DOCS) -> list[Path]:
    return sorted(docs.rglob("*.md"))


def refresh(text: str, where: str) -> tuple[str, list[str]]:
    """``text`` with every block rendered anew, and the names of the blocks that changed."""
    changed: list[str] = []

    def fill(match: re.Match[str]) -> str:
        name = match["name"]
        try:
            body = render(name)
        except FiguresError as exc:
            raise FiguresError(f"{where}: block {name}: {exc}") from None
        if body != match["body"]:
            changed.append(name)
        return match[1] + body + match[4]

    return BLOCK.sub(fill, text), changed


def check(docs: Path = DOCS) -> list[str]:
    """One line per stale block: the page and the block's name."""
    stale = []
    for page in pages(docs):
        _, changed = refresh(page.read_text(encoding="utf-8"), page.relative_to(docs.parent)
                             .as_posix())
        stale += [f"{page.relative_to(docs.parent).as_posix()}: block {name} differs from "
                  f"its results ({BLOCKS[name].source.relative_to(ROOT)})" for name in changed]
    return stale


def write(docs: Path = DOCS) -> list[str]:
    """Rewrite every stale block; one line per block rewritten."""
    done = []
    for page in pages(docs):
        where = page.relative_to(docs.parent).as_posix()
        text, changed = refresh(page.read_text(encoding="utf-8"), where)
        if changed:
            page.write_text(text, encoding="utf-8")
            done += [f"{where}: block {name} rewritten" for name in changed]
    return done


def used(docs: Path = DOCS) -> dict[str, list[str]]:
    """Each block name found in the pages, with the pages that hold it."""
    found: dict[str, list[str]] = {}
    for page in pages(docs):
        for match in BLOCK.finditer(page.read_text(encoding="utf-8")):
            found.setdefault(match["name"], []).append(page.relative_to(docs.parent).as_posix())
    return found


def keep_experiment(name: str, run: Path, keys: Sequence[str] | None = None) -> Path:
    """Commit the results of ``cbr experiment NAME`` written into ``run`` for the pages."""
    manifest = load_json(run / "manifest.json")
    results = load_json(run / "results.json")
    size = manifest.get("size")
    if manifest.get("experiment") != name:
        raise FiguresError(f"{run}: manifest.json is of experiment "
                           f"{manifest.get('experiment')!r}, not {name!r}")
    seed = manifest.get("seed")
    data = {"command": f"cbr experiment {name} --size {size} --seed {seed}",
            "table": _read(run / "results.md"),
            "results": {k: results[k] for k in keys} if keys else results}
    KEPT.mkdir(exist_ok=True)
    target = KEPT / f"{name}.json"
    target.write_text(json.dumps(data, indent=1, ensure_ascii=False) + "\n", encoding="utf-8")
    return target


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    mode = parser.add_mutually_exclusive_group(required=True)
    mode.add_argument("--check", action="store_true", help="fail when a block is stale")
    mode.add_argument("--write", action="store_true", help="rewrite the stale blocks")
    mode.add_argument("--list", action="store_true", help="list the blocks and their sources")
    mode.add_argument("--keep-experiment", nargs=2, metavar=("NAME", "DIR"),
                      help="commit the results an experiment wrote into DIR")
    args = parser.parse_args(argv)
    try:
        if args.keep_experiment:
            name, run = args.keep_experiment
            print(keep_experiment(name, Path(run)).relative_to(ROOT))
            return 0
        if args.list:
            found = used()
            for name, block in BLOCKS.items():
                where = ", ".join(found.get(name, ["(no page)"]))
                print(f"{name}: {block.source.relative_to(ROOT)} -> {where}")
            return 0
        lines = write() if args.write else check()
    except FiguresError as exc:
        print(f"figures: {exc}", file=sys.stderr)
        return 1
    for line in lines:
        print(line, file=sys.stderr if args.check else sys.stdout)
    if args.check and lines:
        print("figures: run `python benchmarks/figures.py --write` after committing new results",
              file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
