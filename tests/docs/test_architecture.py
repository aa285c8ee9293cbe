"""The house as drawn in docs/architecture.md: layers import only downward, no package
reaches into another's private names, and what one package hands another is typed, never a
string key in a dict."""

from __future__ import annotations

from repo_paths import ROOT

import ast
import shutil
import subprocess
import sys
import tomllib
from collections.abc import Sequence
from pathlib import Path

import pytest
SOURCES = [ROOT / "cbrcore", *sorted((ROOT / "plugins").glob("cbr_*"))]
PACKAGES = {path.name for path in SOURCES}


def _modules() -> list[Path]:
    return [path for source in SOURCES for path in sorted(source.rglob("*.py"))]


def test_the_import_contracts_hold() -> None:
    linter = shutil.which("lint-imports", path=str(Path(sys.executable).parent)) or shutil.which(
        "lint-imports")
    assert linter, "import-linter is a test dependency"
    result = subprocess.run([linter, "--no-cache"], cwd=ROOT, capture_output=True, text=True,
                            timeout=300)
    assert result.returncode == 0, result.stdout + result.stderr


def test_every_package_of_the_code_is_in_a_layer() -> None:
    config = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))
    linter = config["tool"]["importlinter"]
    layered = {name.strip() for contract in linter["contracts"] if contract["type"] == "layers"
               for layer in contract["layers"] for name in layer.split("|")}
    assert set(linter["root_packages"]) == PACKAGES == layered


def _private_imports(path: Path) -> list[str]:
    owner = path.relative_to(ROOT).parts[0 if path.is_relative_to(ROOT / "cbrcore") else 1]
    found = []
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            package = node.module.split(".")[0]
            if package in PACKAGES and package != owner:
                found += [f"{path.relative_to(ROOT)}:{node.lineno}: {node.module}.{alias.name}"
                          for alias in node.names if alias.name.startswith("_")
                          and not alias.name.startswith("__")]
                if any(part.startswith("_") and not part.startswith("__")
                       for part in node.module.split(".")):
                    found.append(f"{path.relative_to(ROOT)}:{node.lineno}: {node.module}")
    return found


def test_no_package_imports_another_packages_private_names() -> None:
    found = [line for path in _modules() for line in _private_imports(path)]
    assert found == []


def test_the_architecture_page_places_every_package_with_its_plugin() -> None:
    """The page's table of where things live has a row per package, naming the plugin its entry
    point registers, and the page counts the packages and layers the contract has."""
    config = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))
    plugin_of = {value.split(".")[0]: name
                 for name, value in config["project"]["entry-points"]["cbr"].items()}
    page = (ROOT / "docs" / "architecture.md").read_text(encoding="utf-8")
    rows = {cells[1].strip(" `/").split("/")[-1]: cells[2].strip(" `")
            for line in page.splitlines() if line.startswith("| `")
            for cells in [line.split("|")]}
    # a package without an entry point (a library the families import) has an empty cell
    assert {package: rows.get(package) for package in PACKAGES} == {
        package: plugin_of.get(package, "") for package in PACKAGES}
    layers = [layer for contract in config["tool"]["importlinter"]["contracts"]
              if contract["type"] == "layers" for layer in contract["layers"]]
    numbers = "zero one two three four five six seven eight nine ten eleven twelve thirteen "
    words = (numbers + "fourteen fifteen sixteen seventeen eighteen nineteen twenty").split()
    assert (f"{words[len(PACKAGES)]} packages stand in {words[len(layers)]} layers"
            in page.lower())


# --- hand-offs: typed fields and stash keys, never string keys ----------------------------------

HANDOFF_CONTAINERS = frozenset({"detail", "meta", "features", "payload", "report"})
"""The free-form mappings of the cycle's objects (``Solution.detail``, ``Case.meta``,
``Match.features``), of the families' own results built into them (a planner's ``detail``),
and the typed channels (``payload``, ``report``) should a dict be put there. A string key one
package writes into one of them and another package reads is a hand-off by name. Other dicts
are left out: results rows, summaries, GeoJSON and case exchange files are file formats, read
back by their columns and fields, not hand-offs between components; and ``Proposal.timings``
(and a learn step's) is keyed by the engine's phase names, which are also the ``ms_<phase>``
columns of results.csv."""

_READING_METHODS = frozenset({"get", "pop", "setdefault"})


def _container(node: ast.expr) -> str | None:
    """The hand-off container ``node`` names (``x.detail`` or a variable ``detail``), if any."""
    name = (node.id if isinstance(node, ast.Name)
            else node.attr if isinstance(node, ast.Attribute) else None)
    return name if name in HANDOFF_CONTAINERS else None


def _is_stash(node: ast.expr) -> bool:
    return isinstance(node, ast.Attribute) and node.attr == "stash"


def _text(node: ast.expr | None) -> str | None:
    return node.value if isinstance(node, ast.Constant) and isinstance(node.value, str) else None


_FUNCTIONS = (ast.FunctionDef, ast.AsyncFunctionDef)


def _own(scope: ast.AST) -> list[ast.AST]:
    """The nodes of ``scope`` outside the functions defined in it (which are scopes of their
    own), those functions included."""
    nodes: list[ast.AST] = []
    todo = list(ast.iter_child_nodes(scope))
    while todo:
        node = todo.pop()
        nodes.append(node)
        if not isinstance(node, _FUNCTIONS):
            todo.extend(ast.iter_child_nodes(node))
    return nodes


class _Scope:
    """The dicts one function (or module) builds: the variables bound to dict displays or
    ``dict(...)`` calls, so that ``detail=facts`` counts the keys written into ``facts``; a
    name not bound here is looked up in the enclosing scope."""

    def __init__(self, nodes: list[ast.AST], outer: _Scope | None) -> None:
        self.bound: dict[str, list[ast.expr]] = dict(outer.bound) if outer is not None else {}
        for child in nodes:
            targets = (child.targets if isinstance(child, ast.Assign)
                       else [child.target] if isinstance(child, ast.AnnAssign) else [])
            value = getattr(child, "value", None)
            for target in targets:
                if isinstance(target, ast.Name) and value is not None:
                    self.bound[target.id] = [*self.bound.get(target.id, ()), value]

    def keys(self, node: ast.expr, seen: frozenset[str] = frozenset()) -> set[str]:
        """The string keys the dict ``node`` evaluates to is known to hold."""
        if isinstance(node, ast.Dict):
            found = {key for key in map(_text, node.keys) if key is not None}
            for key, value in zip(node.keys, node.values, strict=True):
                if key is None:  # ``**other``
                    found |= self.keys(value, seen)
            return found
        if (isinstance(node, ast.Call) and isinstance(node.func, ast.Name)
                and node.func.id == "dict"):
            return ({kw.arg for kw in node.keywords if kw.arg is not None}
                    | {key for arg in node.args for key in self.keys(arg, seen)})
        if isinstance(node, ast.BinOp) and isinstance(node.op, ast.BitOr):
            return self.keys(node.left, seen) | self.keys(node.right, seen)
        if isinstance(node, ast.Name) and node.id not in seen:
            return {key for value in self.bound.get(node.id, ())
                    for key in self.keys(value, seen | {node.id})}
        return set()


Use = tuple[str, str, str]
"""A container, a key and where (``path:line``)."""


def _uses(tree: ast.Module, where: str) -> tuple[set[Use], set[Use], list[str]]:
    """The string keys ``tree`` writes into and reads from hand-off containers, and its uses
    of the stash under a string key."""
    written: set[Use] = set()
    read: set[Use] = set()
    stashed: list[str] = []
    scopes: list[tuple[ast.AST, _Scope | None]] = [(tree, None)]
    while scopes:
        scope_node, outer = scopes.pop()
        nodes = _own(scope_node)
        scope = _Scope(nodes, outer)
        scopes += [(node, scope) for node in nodes if isinstance(node, _FUNCTIONS)]
        for node in nodes:
            at = f"{where}:{getattr(node, 'lineno', 0)}"
            if isinstance(node, ast.Call):
                for kw in node.keywords:  # Solution(..., detail={...})
                    if kw.arg in HANDOFF_CONTAINERS:
                        written |= {(kw.arg, key, at) for key in scope.keys(kw.value)}
                func = node.func
                if isinstance(func, ast.Attribute):
                    owner = _container(func.value)
                    first = _text(node.args[0]) if node.args else None
                    if owner and func.attr == "update":
                        written |= {(owner, kw.arg, at) for kw in node.keywords if kw.arg}
                        written |= {(owner, key, at) for arg in node.args
                                    for key in scope.keys(arg)}
                    elif owner and func.attr in _READING_METHODS and first is not None:
                        read.add((owner, first, at))
                    if _is_stash(func.value) and first is not None:
                        stashed.append(f"{at}: stash key {first!r}")
            elif isinstance(node, ast.Assign | ast.AnnAssign) and node.value is not None:
                for target in node.targets if isinstance(node, ast.Assign) else [node.target]:
                    if (owner := _container(target)) is not None:  # detail = {...}
                        written |= {(owner, key, at) for key in scope.keys(node.value)}
            if isinstance(node, ast.Subscript) and (key := _text(node.slice)) is not None:
                if (owner := _container(node.value)) is not None:
                    (written if isinstance(node.ctx, ast.Store) else read).add((owner, key, at))
                if _is_stash(node.value):
                    stashed.append(f"{at}: stash key {key!r}")
            if isinstance(node, ast.Compare) and (key := _text(node.left)) is not None:
                for op, right in zip(node.ops, node.comparators, strict=True):
                    if isinstance(op, ast.In | ast.NotIn):
                        if (owner := _container(right)) is not None:
                            read.add((owner, key, at))
                        if _is_stash(right):
                            stashed.append(f"{at}: stash key {key!r}")
    return written, read, sorted(set(stashed))


def string_handoffs(packages: Sequence[Path], root: Path) -> list[str]:
    """Every string key read from a hand-off container in one package that another package
    writes there (and the reading package does not write itself: a key of its own may share a
    word with another's), and every use of the stash under a string key, as
    ``path:line: ...`` lines.

    The AST cannot follow a dict through calls, so a dict built by another function and
    returned is not seen; what is seen is enough for the pattern: a producer's dict display,
    ``dict(...)``, ``update`` or item assignment into a ``detail``, ``meta`` or ``features``,
    and a consumer's item, ``get``/``pop``/``setdefault`` or ``in`` on one.
    """
    writers: dict[tuple[str, str], set[str]] = {}
    reads: list[tuple[str, str, str, str]] = []
    found: list[str] = []
    for package in packages:
        for path in sorted(package.rglob("*.py")):
            where = str(path.relative_to(root))
            written, read, stashed = _uses(ast.parse(path.read_text(encoding="utf-8")), where)
            found += stashed
            for owner, key, _ in written:
                writers.setdefault((owner, key), set()).add(package.name)
            reads += [(package.name, owner, key, at) for owner, key, at in read]
    for reader, owner, key, at in sorted(reads, key=lambda read: read[3]):
        others = writers.get((owner, key), set()) - {reader}
        if others and reader not in writers[(owner, key)]:
            found.append(f"{at}: reads {owner}[{key!r}], which {', '.join(sorted(others))} "
                         "writes: hand it on as a typed field or a declared StashKey")
    return found


def test_no_package_reads_a_string_key_another_package_writes() -> None:
    assert string_handoffs(SOURCES, ROOT) == []


def _two_packages(tmp_path: Path, producer: str, consumer: str) -> list[str]:
    packages = []
    for name, code in (("producer", producer), ("consumer", consumer)):
        (tmp_path / name).mkdir()
        (tmp_path / name / "component.py").write_text(code, encoding="utf-8")
        packages.append(tmp_path / name)
    return string_handoffs(packages, tmp_path)


READ_BOUND = "def revise(solution):\n    return solution.detail.get('bound')\n"


@pytest.mark.parametrize(("producer", "consumer"), [
    pytest.param("def reuse(path, cost, e):\n"
                 "    detail = {'bound': e, 'expanded': 3}\n"
                 "    return Found(path, cost, detail)\n",
                 "def revise(solution):\n    return solution.detail['bound'] <= 1.5\n",
                 id="a planner's detail read by a sibling's reviser"),
    pytest.param("def reuse(path):\n    return Solution(path, detail={'bound': 1.5})\n",
                 READ_BOUND, id="a dict display in the solution"),
    pytest.param("def reuse(path):\n    return Solution(path, detail=dict(bound=1.5))\n",
                 READ_BOUND, id="dict keywords"),
    pytest.param("def reuse(path, best):\n"
                 "    facts = {'kind': best.kind}\n"
                 "    return Solution(path, detail={**facts, 'adapted': []})\n",
                 "def retain(solution):\n    return 'kind' in solution.detail\n",
                 id="a variable spread into the detail"),
    pytest.param("def reuse(solution):\n    solution.detail['bound'] = 1.5\n",
                 READ_BOUND, id="item assignment"),
    pytest.param("def reuse(detail):\n    detail.update(bound=1.5)\n",
                 READ_BOUND, id="update"),
    pytest.param("def retain(problem, path):\n    return Case(problem, path, meta={'cost': 2})\n",
                 "def forget(case):\n    return case.meta.pop('cost')\n", id="case meta"),
    pytest.param("def reuse(v):\n    return Solution(v, payload={'kind': 'plan'})\n",
                 "def log(solution):\n    return solution.payload['kind']\n",
                 id="a dict as the payload"),
])
def test_a_string_key_one_package_writes_and_another_reads_is_found(
        tmp_path: Path, producer: str, consumer: str) -> None:
    found = _two_packages(tmp_path, producer, consumer)
    assert len(found) == 1
    assert found[0].startswith("consumer/component.py:2: reads ")
    assert "which producer writes" in found[0]


def test_a_string_key_in_the_stash_is_found_wherever_it_is(tmp_path: Path) -> None:
    found = _two_packages(tmp_path, "def warm(ctx, grid):\n    ctx.stash['world'] = grid\n",
                          "def plan(ctx):\n    return 'world' in ctx.stash\n")
    assert sorted(found) == ["consumer/component.py:2: stash key 'world'",
                             "producer/component.py:2: stash key 'world'"]


@pytest.mark.parametrize(("producer", "consumer"), [
    pytest.param("def reuse(path):\n    return Solution(path, bound=1.5)\n",
                 "def revise(solution):\n    return solution.bound\n", id="a typed field"),
    pytest.param("def measure(p):\n    return {'bound': p.bound}\n",
                 "def figure(row):\n    return row['bound']\n", id="a results row"),
    pytest.param("def reuse(path):\n    return Solution(path, detail={'way': 'round'})\n",
                 "def report(solution):\n    solution.detail['way'] = 'line'\n"
                 "    return solution.detail['way']\n", id="a key the reader writes itself"),
])
def test_what_is_not_a_string_handoff_passes(tmp_path: Path, producer: str,
                                             consumer: str) -> None:
    assert _two_packages(tmp_path, producer, consumer) == []


def test_a_key_read_in_the_package_that_writes_it_is_its_own(tmp_path: Path) -> None:
    package = tmp_path / "family"
    package.mkdir()
    (package / "reuser.py").write_text(
        "def reuse(path):\n    return Solution(path, detail={'kind': 'plan'})\n", encoding="utf-8")
    (package / "retainer.py").write_text(
        "def retain(solution):\n    return solution.detail['kind']\n", encoding="utf-8")
    assert string_handoffs([package], tmp_path) == []
