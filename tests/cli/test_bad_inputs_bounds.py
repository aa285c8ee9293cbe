"""Inputs past the bounds of what can be used: one clear error, exit code 2, no traceback.

A careless or hostile user can name a named pipe (which nobody writes to) where a file is
expected, give a file whose header declares an array of exabytes, type numbers that no
simulation survives or a name with a NUL byte in it. Each row is one such input to the command
line; each must be refused with the limit it passes, naming the file, option or YAML path
(for a named pipe: the file and what it is, whatever the reader's own wording around them).

The command line runs in a thread guarded against hanging: should it still wait on a named
pipe after the guard's time, every named pipe of the test gets a writer that closes at once
(ending the read) and the test fails.
"""

from __future__ import annotations

import contextlib
import io
import os
import socket
import stat
import struct
import threading
import zlib
from collections.abc import Callable, Iterator
from pathlib import Path

import numpy as np
import pytest
import yaml

from cbrcore.errors import CbrError
from cbrcore.plugins import Plugins
from cbrcore.testing import CliResult
from repo_paths import ROOT

Cli = Callable[..., CliResult]
Case = Callable[[Path, Cli], CliResult]

LANDMARKS = ROOT / "configs" / "landmarks.yaml"
ROS2005 = ROOT / "plugins" / "cbr_landmarks" / "cases" / "ros2005.yaml"
RUPART = ROOT / "plugins" / "cbr_behaviors" / "cases" / "rupart.sexp"
GUARD_SECONDS = 60
"""How long the command may run before it is taken to hang on a named pipe."""

SMALL_MAP = "type octile\nheight 2\nwidth 3\nmap\n...\n...\n"
WORLD = "bounds: [0, 0, 8, 6]\nplaces: {start: [1, 3], target: [6, 3]}\n"
ROS_YAML = ("image: {image}\nresolution: 0.05\norigin: [0, 0, 0]\nnegate: 0\n"
            "occupied_thresh: 0.65\nfree_thresh: 0.2\n")
PIPE = "a named pipe, not a regular file"
PAST_FLOATS = "1" + "0" * 400
"""An integer past the largest float, whose digits are within Python's limit."""
SHOWN_PAST_FLOATS = PAST_FLOATS[:57] + "..."


@pytest.fixture(autouse=True)
def installed(cbr_plugins: Callable[..., Plugins]) -> Plugins:
    """The installed plugins made current for every test."""
    return cbr_plugins(entry_points=True)


# --- building the inputs ------------------------------------------------------------------------

def _fifo(tmp: Path, name: str) -> str:
    os.mkfifo(tmp / name)
    return str(tmp / name)


def _write(tmp: Path, name: str, text: str | bytes) -> str:
    path = tmp / name
    if isinstance(text, bytes):
        path.write_bytes(text)
    else:
        path.write_text(text, encoding="utf-8")
    return str(path)


def _npy_header(shape: tuple[int, ...]) -> bytes:
    """A .npy file of float64 ``shape`` whose data is 16 bytes: the header alone declares it."""
    from numpy.lib import format as npy

    stream = io.BytesIO()
    npy.write_array_header_1_0(stream, {"descr": "<f8", "fortran_order": False, "shape": shape})
    return stream.getvalue() + bytes(16)


def _png_header(width: int, height: int) -> bytes:
    """A greyscale PNG that declares ``width`` x ``height`` pixels and holds one row of them."""
    def chunk(kind: bytes, data: bytes) -> bytes:
        return (struct.pack(">I", len(data)) + kind + data
                + struct.pack(">I", zlib.crc32(kind + data)))

    header = struct.pack(">IIBBBBB", width, height, 8, 0, 0, 0, 0)
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header)
            + chunk(b"IDAT", zlib.compress(bytes(width + 1))) + chunk(b"IEND", b""))


def _landmark_cases(tmp: Path, change: Callable[[dict], None]) -> str:
    document = yaml.safe_load(ROS2005.read_text(encoding="utf-8"))
    change(document["cases"][0])
    return _write(tmp, "cases.yaml", yaml.safe_dump(document))


def _behavior_case(replace: str, by: str) -> str:
    """RUPART's first case file entry with ``replace`` replaced by ``by`` once."""
    text = RUPART.read_text(encoding="utf-8")
    start = text.index("(behavior-case open-area")
    depth = 0
    for end in range(start, len(text)):
        depth += {"(": 1, ")": -1}.get(text[end], 0)
        if depth == 0:
            break
    return text[start:end + 1].replace(replace, by, 1)


@pytest.fixture
def not_dask() -> Iterator[str]:
    """The address of a service that greets every connection with an SSH banner."""
    server = socket.create_server(("127.0.0.1", 0))
    stop = threading.Event()

    def serve() -> None:
        server.settimeout(0.1)
        while not stop.is_set():
            try:
                connection, _ = server.accept()
            except TimeoutError:
                continue
            with connection:
                connection.sendall(b"SSH-2.0-OpenSSH_9.6\r\n" * 4)

    thread = threading.Thread(target=serve, daemon=True)
    thread.start()
    yield f"tcp://127.0.0.1:{server.getsockname()[1]}"
    stop.set()
    thread.join()
    server.close()


# --- the cases ----------------------------------------------------------------------------------

def _plan(name: str, *args: str) -> Case:
    return lambda tmp, cli: cli("plan", str(tmp / name), *(args or ("--start", "0,0", "--goal",
                                                                     "1,1")))


def _plan_pipe(name: str, map_name: str | None = None) -> Case:
    """``cbr plan`` of the map ``map_name`` (default: ``name``) with a named pipe ``name``."""
    def case(tmp: Path, cli: Cli) -> CliResult:
        _fifo(tmp, name)
        return _plan(map_name or name)(tmp, cli)
    return case


def _sim(*args: str, world: str = "world.yaml") -> Case:
    return lambda tmp, cli: cli("sim", *args[:1], str(tmp / world), *args[1:])


def _landmarks_run(change: Callable[[dict], None] | None = None) -> Case:
    def case(tmp: Path, cli: Cli) -> CliResult:
        cases = (_fifo(tmp, "cases.yaml") if change is None else _landmark_cases(tmp, change))
        return cli("run", str(LANDMARKS), "--set", f"casebase.initial={cases}",
                   "--out", str(tmp / "out"))
    return case


def _validate_trials(setting: str) -> Case:
    return lambda tmp, cli: cli("validate", str(ROOT / "configs" / "world2d_trials.yaml"),
                                "--set", setting)


def _triangle(field: str) -> Callable[[dict], None]:
    def change(case: dict) -> None:
        case["problem"][field][0][1] = [1e308, 1e308, 1e308]
    return change


def _delta_past_floats(case: dict) -> None:
    case["problem"]["delta"][0][1] = [10**400] * 3


def _along(case: dict) -> None:
    case["solution"]["along"] = 1e308


def _nul_landmark(case: dict) -> None:
    case["problem"]["landmarks"][0] = "l\x001"


FIFOS: dict[str, tuple[Case, str | tuple[str, ...]]] = {
    "config": (lambda tmp, cli: cli("validate", _fifo(tmp, "c.yaml")),
               ("c.yaml", PIPE)),
    "import document": (lambda tmp, cli: cli("casebase", "import", str(tmp / "new.sqlite"),
                                             _fifo(tmp, "doc.yaml")),
                        ("doc.yaml", PIPE)),
    ".map": (_plan_pipe("x.map"), ("x.map", PIPE)),
    ".scen": (lambda tmp, cli: cli("plan", str(tmp / "small.map"), "--scen",
                                   _fifo(tmp, "x.scen")),
              ("x.scen", PIPE)),
    "ROS .yaml": (_plan_pipe("ros.yaml"), ("ros.yaml", PIPE)),
    "ROS image": (_plan_pipe("pipe.pgm", "pipe.yaml"), ("pipe.pgm", PIPE)),
    ".grid": (_plan_pipe("x.grid"), ("x.grid", PIPE)),
    ".npy": (_plan_pipe("x.npy"), ("x.npy", PIPE)),
    "case base": (lambda tmp, cli: cli("casebase", "info", _fifo(tmp, "cb.sqlite")),
                  ("cb.sqlite", PIPE)),
    "landmark initial": (_landmarks_run(), ("cases.yaml", PIPE)),
    "world file": (lambda tmp, cli: cli("sim", "show", _fifo(tmp, "w.yaml")),
                   ("w.yaml", PIPE)),
    ".sexp": (lambda tmp, cli: cli("rupart", "show", _fifo(tmp, "s.sexp")),
              ("s.sexp", PIPE)),
    "run manifest": (lambda tmp, cli: (_fifo(tmp, "manifest.json"),
                                       cli("rupart", "day", str(tmp)))[1],
                     ("manifest.json", PIPE)),
}

SIM_RUN = ("run", "--start", "start", "--target", "target")

BOUNDS: dict[str, tuple[Case, str | tuple[str, ...]]] = {
    ".npy declaring 100000 x 100000": (
        _plan("huge.npy"),
        "huge.npy: its header declares an array of 10000000000 cells, more than the 268435456 "
        "a map may have (cbr_grid.formats.MAX_GRID_CELLS)"),
    ".npy shorter than its header": (
        _plan("short.npy"), "short.npy: its data ends before the size its header declares "
                            "(100 cells of 8 bytes)"),
    "ROS map of a 20000 x 20000 PNG": (
        _plan("huge.yaml"),
        "huge.png: cannot read the image: it has 400000000 pixels, more than the 268435456 a "
        "map image may have (cbr_grid.formats.MAX_IMAGE_PIXELS)"),
    "start past 64-bit integers": (
        _plan("small.map", "--start", "100000000000000000000,0", "--goal", "0,0"),
        "start (100000000000000000000, 0) is outside the 3x2 grid"),
    "start 1e300 m off a ROS map": (
        _plan("small.yaml", "--frame", "map", "--start", "1e300,0", "--goal", "0.1,0.1"),
        "--start (1e+300, 0) m is outside the 4x2 grid, which covers x 0 to 0.2 m and y 0 to "
        "0.1 m"),
    "a million workers": (
        lambda tmp, cli: cli("experiment", "cbr-share", "--out", str(tmp / "out"),
                             "--scheduler", "local", "--workers", "1000000"),
        f"--workers: 1000000 is more than the {4 * (os.cpu_count() or 1)} worker processes"),
    "sim batch workers": (
        _sim("batch", "--workers", "1000000"),
        f"'--workers': 1000000 is more than the {4 * (os.cpu_count() or 1)} processes"),
    "dt 1e-9": (_sim(*SIM_RUN, "--dt", "1e-9"),
                "'--dt': expected a step from 0.0001 to 1 seconds, got 1e-09"),
    "dt 1e308": (_sim(*SIM_RUN, "--dt", "1e308"),
                 "'--dt': expected a step from 0.0001 to 1 seconds, got 1e+308"),
    "a million GIF frames": (_sim(*SIM_RUN, "--frames", "1000000"),
                             "'--frames': Input should be less than or equal to 10000"),
    "timeout 1e12": (_sim(*SIM_RUN, "--timeout", "1e12", "--rescue", "off"),
                     "'--timeout': a timeout of 1e+12 s in steps of 0.1 s is more than the "
                     "10000000 steps a trial may take"),
    "config dt 1e-9": (
        _validate_trials("workload.dt=1.0e-9"),
        "--set workload.dt=1.0e-9: must lie in [0.0001, 1] seconds, not 1e-09"),
    "config timeout 1e12": (
        _validate_trials("workload.timeout=1.0e+12"),
        "--set workload.timeout=1.0e+12: must be within the step limit: a timeout of 1e+12 s in "
        "steps of 0.1 s is more than the 10000000 steps a trial may take"),
    "config repeat 1e9": (
        _validate_trials("workload.repeat=1000000000"),
        "--set workload.repeat=1000000000: must keep the trials within 100000 (the limit, "
        "cbr_world2d.checks.MAX_TRIALS)"),
    "sim batch a million trials": (
        _sim("batch", "--trials", "1000000"),
        "'--trials': Input should be less than or equal to 100000"),
    ".sexp 100000 lists deep": (
        lambda tmp, cli: cli("rupart", "show", _write(tmp, "deep.sexp",
                                                      "(" * 100_000 + ")" * 100_000)),
        "deep.sexp, line 1: column 101: lists nested more than 100 levels deep (the limit, set "
        "by CBR_MAX_DOCUMENT_DEPTH)"),
    ".sexp 5000-digit integer": (
        lambda tmp, cli: cli("rupart", "show", _write(tmp, "digits.sexp",
                                                      "(case " + "9" * 5000 + ")")),
        "digits.sexp, line 1: column 7: an integer of more than 4300 digits"),
    "world bounds 1e308 plotted": (
        lambda tmp, cli: cli("sim", "show", _write(tmp, "far.yaml",
                                                   "bounds: [0, 0, 1.0e+308, 6]\n"),
                             "--plot", str(tmp / "far.png")),
        "bounds (line 1, column 9): expected bounds [xmin, ymin, xmax, ymax] of numbers within "
        "±1e+06 (the limit), got [0, 0, 1e+308, 6]"),
    "generated world of a 30-digit seed": (
        lambda tmp, cli: cli("sim", "show", "generated:office:" + "9" * 30),
        "SEED an integer >= 0 of at most 19 digits, got 'generated:office:" + "9" * 30),
    "sim show --at nan": (_sim("show", "--at", "nan"),
                          "'--at': expected a time from 0 to 1e+06 seconds, got nan"),
    "person speed 1e308": (
        lambda tmp, cli: cli("sim", "show", _write(
            tmp, "fast.yaml", WORLD + "people: [{waypoints: [[1, 1], [7, 1]], speed: 1.0e+308, "
                                      "radius: 0.25}]\n")),
        "people.0.speed (line 3, column 47): expected a number within ±1e+06 (the limit), got "
        "1e+308"),
    "person speed 1e5": (
        lambda tmp, cli: cli("sim", "show", _write(
            tmp, "fast.yaml", WORLD + "people: [{waypoints: [[1, 1], [7, 1]], speed: 100000, "
                                      "radius: 0.25}]\n")),
        "people.0.speed (line 3, column 47): expected a speed from 0 to 100 m/s (the limit), "
        "got 100000"),
    "landmark alpha 1e308": (
        _landmarks_run(_triangle("alpha")),
        "landmark_situation case 1: alpha[0][1]: every measure must be a finite number within "
        "±1e+06 (the limit), not [1e+308, 1e+308, 1e+308]"),
    "landmark delta 10^400": (
        _landmarks_run(_delta_past_floats),
        "landmark_situation case 1: delta: expected 2 x 2 triangles [low, peak, high] of "
        "numbers"),
    "landmark along 1e308": (
        _landmarks_run(_along),
        "landmark_situation case 1: action.along: expected a finite number of metres within "
        "±1e+06 (the limit), got 1e+308"),
    "behavior parameter 1e308": (
        lambda tmp, cli: cli("rupart", "show", _write(
            tmp, "fast.sexp", _behavior_case("mod-fast", "1e308"))),
        "fast.sexp, line 3: behavior-case open-area, item 0 ((goStraight 1e+308 curr-head) "
        "med): goStraight velocity: expected a finite number within ±1e+06 (the limit), got "
        "1e+308"),
    "behavior parameter past the floats": (
        lambda tmp, cli: cli("rupart", "show", _write(
            tmp, "fast.sexp", _behavior_case("mod-fast", PAST_FLOATS))),
        "goStraight velocity: expected a finite number within ±1e+06 (the limit), got "
        + SHOWN_PAST_FLOATS),
    "behavior index feature past the floats": (
        lambda tmp, cli: cli("rupart", "show", _write(
            tmp, "far.sexp", _behavior_case("(front 1.0)", f"(front {PAST_FLOATS})"))),
        "far.sexp, line 2: behavior-case open-area, index feature front: expected a number in "
        "[0, 1], got " + SHOWN_PAST_FLOATS),
    "world radius past the floats": (
        lambda tmp, cli: cli("sim", "show", _write(
            tmp, "wide.yaml", WORLD + f"points: [{{at: [4, 3], radius: {PAST_FLOATS}}}]\n")),
        "points.0.radius (line 3, column 31): expected a number within ±1e+06 (the limit), got "
        + SHOWN_PAST_FLOATS),
    "world bounds past the floats": (
        lambda tmp, cli: cli("sim", "show", _write(
            tmp, "wide.yaml", f"bounds: [0, 0, {PAST_FLOATS}, 6]\n")),
        "bounds (line 1, column 9): expected bounds [xmin, ymin, xmax, ymax] of numbers within "
        f"±1e+06 (the limit), got [0, 0, {SHOWN_PAST_FLOATS}, 6]"),
    "config number past the floats": (
        _validate_trials(f"workload.timeout={PAST_FLOATS}"),
        "expected a number within ±1.798e+308, got " + SHOWN_PAST_FLOATS),
    "NUL in a case name": (
        lambda tmp, cli: cli("rupart", "show", _write(
            tmp, "nul.sexp", _behavior_case("open-area", "open\x00area"))),
        "nul.sexp, line 1: behavior-case: expected a name, but a name holds no control "
        "characters, got U+0000 at character 5"),
    "NUL in a landmark id of a case": (
        _landmarks_run(_nul_landmark),
        "landmark_situation case 1: landmarks[0]: expected a landmark id, but a name holds no "
        "control characters, got U+0000 at character 2"),
    "NUL in a place name": (
        lambda tmp, cli: cli("sim", "show", _write(
            tmp, "nul.yaml", 'bounds: [0, 0, 8, 6]\nplaces: {"a\\0b": [1, 1]}\n')),
        "places (line 2, column 9): expected place names, but a name holds no control "
        "characters, got U+0000 at character 2"),
}


def _prepare(tmp: Path) -> None:
    _write(tmp, "small.map", SMALL_MAP)
    _write(tmp, "world.yaml", WORLD)
    _write(tmp, "huge.npy", _npy_header((100_000, 100_000)))
    _write(tmp, "short.npy", _npy_header((10, 10)))
    _write(tmp, "huge.png", _png_header(20_000, 20_000))
    _write(tmp, "huge.yaml", ROS_YAML.format(image="huge.png"))
    _write(tmp, "pipe.yaml", ROS_YAML.format(image="pipe.pgm"))
    _write(tmp, "small.pgm", b"P5\n4 2\n255\n" + bytes([255] * 8))
    _write(tmp, "small.yaml", ROS_YAML.format(image="small.pgm"))


def _release(tmp: Path) -> None:
    """Give every named pipe under ``tmp`` a writer that closes at once: a read waiting on one
    ends, reading nothing."""
    for path in tmp.rglob("*"):
        if stat.S_ISFIFO(path.lstat().st_mode):
            with contextlib.suppress(OSError):  # no reader waits on it
                os.close(os.open(path, os.O_WRONLY | os.O_NONBLOCK))


def _guarded(case: Case, tmp: Path, cli: Cli) -> CliResult:
    """``case`` run in a thread; a test failure, not a hang, when it waits past the guard."""
    outcome: list[CliResult | BaseException] = []

    def run() -> None:
        try:
            outcome.append(case(tmp, cli))
        except BaseException as exc:  # re-raised in the test's thread
            outcome.append(exc)

    thread = threading.Thread(target=run, daemon=True)
    thread.start()
    thread.join(GUARD_SECONDS)
    if thread.is_alive():
        _release(tmp)
        thread.join(GUARD_SECONDS)
        pytest.fail(f"the command still ran after {GUARD_SECONDS} s: it waits on a named pipe")
    if isinstance(outcome[0], BaseException):
        raise outcome[0]
    return outcome[0]


CASES = {**{f"named pipe as {k}": v for k, v in FIFOS.items()}, **BOUNDS}


@pytest.mark.parametrize(("case", "message"), CASES.values(), ids=list(CASES))
def test_an_input_past_the_bounds_is_one_error_naming_the_limit(
        invoke_cbr: Cli, tmp_path: Path, case: Case, message: str | tuple[str, ...]) -> None:
    _prepare(tmp_path)

    result = _guarded(case, tmp_path, invoke_cbr)

    assert result.exit_code == 2, result
    assert "Traceback" not in result.stderr
    for fragment in (message,) if isinstance(message, str) else message:
        assert fragment in result.stderr, result.stderr
    assert "\x00" not in result.stdout + result.stderr


def test_a_scheduler_address_of_another_service_is_refused(invoke_cbr: Cli, tmp_path: Path,
                                                           not_dask: str) -> None:
    """A service that answers with something other than a Dask handshake (its first bytes
    read as Dask's byte count announce exabytes) is refused before distributed reads it."""
    result = _guarded(lambda tmp, cli: cli("experiment", "cbr-share", "--out", str(tmp / "out"),
                                           "--scheduler", not_dask), tmp_path, invoke_cbr)

    assert result.exit_code == 2, result
    assert "Traceback" not in result.stderr
    assert (f"--scheduler {not_dask!r}: the service there does not speak Dask's protocol "
            "(its first message is not a Dask handshake)") in result.stderr


def test_a_device_and_a_folder_are_refused_as_inputs(invoke_cbr: Cli, tmp_path: Path) -> None:
    (tmp_path / "zero.map").symlink_to("/dev/zero")
    (tmp_path / "folder.map").mkdir()

    device = invoke_cbr("plan", str(tmp_path / "zero.map"), "--start", "0,0", "--goal", "1,1")
    folder = invoke_cbr("plan", str(tmp_path / "folder.map"), "--start", "0,0", "--goal", "1,1")

    assert device.exit_code == folder.exit_code == 2
    assert "zero.map: cannot read: a character device, not a regular file" in device.stderr
    assert "folder.map: cannot read: a folder, not a regular file" in folder.stderr


def test_a_map_at_the_cell_limit_reads(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """The limit refuses what passes it, not what reaches it."""
    import cbr_grid.formats
    from cbr_grid.formats import load_npy

    monkeypatch.setattr(cbr_grid.formats, "MAX_GRID_CELLS", 6)
    np.save(tmp_path / "six.npy", np.zeros((2, 3)))
    np.save(tmp_path / "seven.npy", np.zeros((1, 7)))

    assert load_npy(tmp_path / "six.npy").risk.shape == (2, 3)
    with pytest.raises(CbrError, match="declares an array of 7 cells, more than the 6"):
        load_npy(tmp_path / "seven.npy")
