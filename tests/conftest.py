"""Fixtures shared by the test suite (cbrcore's own fixtures come from cbrcore.testing)."""

from __future__ import annotations

import contextlib
import glob
import itertools
import os
import pwd
import shutil
import subprocess
import tempfile
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest

import cbr_observers
import toy_domain
from cbr_stores.sqlite import SQLiteStore
from cbrcore.casebase.memory import MemoryStore
from cbrcore.casebase.store import CaseStore
from cbrcore.plugins import Plugins

PLUGIN_VARIABLES = ("CBR_PLUGINS", "CBR_DISABLE_PLUGINS", "CBR_STRICT_PLUGINS")


@pytest.fixture(autouse=True)
def _no_plugin_environment(monkeypatch: pytest.MonkeyPatch) -> None:
    """Keep the caller's plugin environment variables out of every test."""
    for name in PLUGIN_VARIABLES:
        monkeypatch.delenv(name, raising=False)


@pytest.fixture
def load_toy(cbr_plugins: Callable[..., Plugins]) -> Callable[..., Plugins]:
    """A callable ``load_toy(*extra) -> Plugins`` making the toy domain current.

    It loads the toy domain with the built-in plugins (``core``, ``stores``, ``experiments`` and
    ``observers``, registered in code rather than through their entry points) and any test-only
    ``extra`` plugins, given as ``cbr_plugins`` takes them; each call makes a fresh set current
    until the test ends.
    """
    import cbr_experiments
    import cbr_stores
    import cbrcore.builtins

    def load(*extra: object) -> Plugins:
        return cbr_plugins(("toy", toy_domain), ("core", cbrcore.builtins),
                           ("stores", cbr_stores), ("experiments", cbr_experiments),
                           ("observers", cbr_observers), *extra)

    return load


@pytest.fixture
def toy_plugins(load_toy: Callable[..., Plugins]) -> Plugins:
    """The toy domain and the built-in plugins, made current for the test."""
    return load_toy()


@pytest.fixture(params=["memory", "sqlite"])
def store(request: pytest.FixtureRequest, tmp_path: Path) -> Iterator[CaseStore]:
    """An empty case base: each test using it runs on the memory and on the SQLite store."""
    if request.param == "memory":
        yield MemoryStore()
    else:
        with SQLiteStore(tmp_path / "casebase.sqlite") as sqlite:
            yield sqlite


@pytest.fixture
def toy_config(tmp_path: Path) -> Path:
    """The toy domain's full composition written to a YAML file."""
    path = tmp_path / "toy.yaml"
    path.write_text(toy_domain.TOY_CONFIG, encoding="utf-8")
    return path


def installed_plugins() -> list[str]:
    """The names of the plugins the installed distributions declare, as they load: sorted."""
    from importlib import metadata

    return sorted({ep.name for ep in metadata.entry_points(group="cbr")})


# -- a throwaway PostgreSQL server ------------------------------------------------------------


def postgres_bindir() -> Path | None:
    """The folder of PostgreSQL's server programs (initdb, pg_ctl, postgres); None without."""
    candidates: list[Path] = []
    found = shutil.which("pg_ctl")
    if found:
        # a link in /usr/local/bin: pg_ctl starts the postgres beside the program it links to
        candidates.append(Path(found).resolve().parent)
    config = shutil.which("pg_config")
    if config:
        with contextlib.suppress(OSError, subprocess.CalledProcessError):
            candidates.append(Path(subprocess.run([config, "--bindir"], check=True,
                                                  capture_output=True, text=True).stdout.strip()))
    # the newest installed version first
    candidates += sorted((Path(p) for p in glob.glob("/usr/lib/postgresql/*/bin")),
                         key=lambda p: int(p.parent.name) if p.parent.name.isdigit() else 0,
                         reverse=True)
    for folder in candidates:
        if all((folder / name).is_file() for name in ("initdb", "pg_ctl", "postgres")):
            return folder
    return None


class PostgresServer:
    """A PostgreSQL server of its own in a temporary folder, reached through a unix socket.

    It listens on no TCP port, so servers started at once (pytest-xdist runs test files in
    parallel) cannot collide: each has its own socket folder. Authentication is ``trust`` for
    the superuser ``cbr``. PostgreSQL refuses to run as root, so when the tests run as root the
    server's programs run as the unprivileged user ``nobody``, which owns the folder. (The
    pytest-postgresql plugin starts its servers as the current user, so it cannot serve here.)
    """

    user = "cbr"

    def __init__(self, bindir: Path) -> None:
        self.bindir = bindir
        # not under pytest's basetemp, which only root may enter
        self.folder = Path(tempfile.mkdtemp(prefix="cbr-pg-"))
        self._as: dict[str, object] = {}
        if os.geteuid() == 0:
            nobody = pwd.getpwnam("nobody")
            os.chown(self.folder, nobody.pw_uid, nobody.pw_gid)
            self._as = {"user": nobody.pw_uid, "group": nobody.pw_gid, "extra_groups": []}
        self.data = self.folder / "data"
        self.log = self.folder / "server.log"

    def _program(self, *args: str) -> None:
        env = {key: value for key, value in os.environ.items() if not key.startswith("PG")}
        env["LC_ALL"] = "C"
        done = subprocess.run([str(self.bindir / args[0]), *args[1:]], env=env,
                              capture_output=True, text=True, cwd=self.folder,
                              **self._as)  # type: ignore[call-overload]
        if done.returncode:
            log = self.log.read_text(errors="replace") if self.log.exists() else ""
            raise RuntimeError(f"{args[0]} failed ({done.returncode}): {done.stderr}{log}")

    def start(self) -> None:
        self._program("initdb", "-D", str(self.data), "-U", self.user, "--auth=trust",
                      "-E", "UTF8", "--no-sync", "--no-instructions")
        # no TCP, no waiting for disks: a server for tests
        self._program("pg_ctl", "-D", str(self.data), "-l", str(self.log), "-w", "-o",
                      f"-k {self.folder} -c listen_addresses= -F", "start")

    def stop(self) -> None:
        with contextlib.suppress(RuntimeError):
            self._program("pg_ctl", "-D", str(self.data), "-m", "immediate", "stop")
        shutil.rmtree(self.folder, ignore_errors=True)

    def dsn(self, dbname: str = "postgres") -> str:
        """The libpq connection string of database ``dbname`` on this server."""
        return f"host={self.folder} port=5432 user={self.user} dbname={dbname}"


_database_numbers = itertools.count()


@pytest.fixture(scope="session")
def postgres_server() -> Iterator[PostgresServer]:
    """A PostgreSQL server for the test session, stopped and removed at its end.

    Skips the tests using it when no PostgreSQL server programs are installed.
    """
    bindir = postgres_bindir()
    if bindir is None:
        pytest.skip("no PostgreSQL server programs (initdb, pg_ctl, postgres) found on PATH, "
                    "through pg_config or in /usr/lib/postgresql/*/bin")
    server = PostgresServer(bindir)
    try:
        server.start()
        yield server
    finally:
        server.stop()


@pytest.fixture
def postgres_database(postgres_server: PostgresServer) -> Iterator[str]:
    """The connection string of a new, empty database on the session's PostgreSQL server,
    dropped when the test ends."""
    import psycopg  # here, not at the top: the rest of the suite runs without it

    name = f"cbr_test_{next(_database_numbers)}"
    with psycopg.connect(postgres_server.dsn(), autocommit=True) as admin:
        admin.execute(f"CREATE DATABASE {name}")
    try:
        yield postgres_server.dsn(name)
    finally:
        with psycopg.connect(postgres_server.dsn(), autocommit=True) as admin:
            # a store a test left open must not keep its database alive
            admin.execute(f"DROP DATABASE {name} WITH (FORCE)")
