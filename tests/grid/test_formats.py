"""Grid file formats: ROS map_server maps with P2/P5 greymaps, PNG, NumPy and text grids."""

from __future__ import annotations

import re
from pathlib import Path

import matplotlib.image
import numpy as np
import pytest
from PIL import Image

import cbr_grid
import cbr_grid.formats
from cbr_grid.formats import load_grid, load_npy, load_png, load_ros, load_text, read_image
from cbr_grid.frame import MapFrame
from cbr_grid.grid import Grid
from cbr_grid.inflation import Inflation, inflate
from cbr_grid.occupancy import occupancy_risk, occupancy_values
from cbrcore.context import Context
from cbrcore.errors import CbrError, ConfigError
from cbrcore.options import paths_relative_to, structure_options
from cbrcore.registry import Registry

# with occupied_thresh 0.65 and free_thresh 0.2, occ = (255 - v) / 255 reads these pixels as
# occupied (0: occ 1, 50: occ 0.80), free (255: occ 0, 230: occ 0.098) and in between (128: occ
# 127/255, 200: occ 55/255, 100: occ 155/255, 166: occ 89/255)
PIXELS = [[0, 255, 128, 230], [200, 100, 50, 166]]
A = 252 / 254  # the risk of unknown cells a planner may cross (Nav2's cost 252 of 254)
TRINARY = [[1, 0, A, 0], [A, A, 1, A]]
# scale: rint((occ - 0.2) / 0.45 * 100) for the in-between pixels: 128: 66.23 -> 66, 200: 3.49
# -> 3, 100: 90.63 -> 91, 166: 33.12 -> 33; the static layer's cost int(v / 100 * 254) of each:
# 167.64 -> 167, 7.62 -> 7, 231.14 -> 231, 83.82 -> 83
SCALE_VALUES = [[100, 0, 66, 0], [3, 91, 100, 33]]
SCALE = [[1, 0, 167 / 254, 0], [7 / 254, 231 / 254, 1, 83 / 254]]
# negated, occ = v / 255: 0 and 50 (0.196) free, 255, 230 (0.90) and 166 (0.651) occupied,
# 128 (0.502), 200 (0.784 > 0.65: occupied) and 100 (0.392) as marked
NEGATED = [[0, 1, A, 1], [1, A, 0, 1]]

P2 = b"P2\n# a hand-made map\n4 2\n255\n0 255 128 230\n200 100 50 166\n"
P5 = b"P5\n4 2\n# comment in the header\n255\n" + np.array(PIXELS, dtype=np.uint8).tobytes()


def write(folder: Path, name: str, data: bytes | str) -> Path:
    path = folder / name
    path.write_bytes(data.encode() if isinstance(data, str) else data)
    return path


def ros_yaml(folder: Path, image: str, *, negate: int = 0, mode: str | None = None,
             occupied: float = 0.65, free: float = 0.2, name: str = "map.yaml") -> Path:
    text = (f"image: {image}\nresolution: 0.05\norigin: [-1.0, -2.5, 0.0]\n"
            f"negate: {negate}\noccupied_thresh: {occupied}\nfree_thresh: {free}\n")
    if mode is not None:
        text += f"mode: {mode}\n"
    return write(folder, name, text)


@pytest.mark.parametrize("data", [P2, P5], ids=["P2", "P5"])
def test_pgm_pixels_read_top_row_first(tmp_path: Path, data: bytes) -> None:
    levels = read_image(write(tmp_path, "map.pgm", data))
    np.testing.assert_array_equal(levels * 255, PIXELS)


def test_16_bit_pgm_reads_as_levels(tmp_path: Path) -> None:
    # binary 16-bit samples are big-endian; a maximum value of 1000 reads v as v / 1000
    pixels = np.array([[0, 65535, 32768]], dtype=">u2")
    path = write(tmp_path, "deep.pgm", b"P5\n3 1\n65535\n" + pixels.tobytes())
    np.testing.assert_array_equal(read_image(path), pixels / 65535)
    plain = write(tmp_path, "plain.pgm", b"P2\n3 1\n1000\n0 1000 250\n")
    np.testing.assert_allclose(read_image(plain), [[0, 1, 0.25]], atol=0.5 / 65535)
    # a 16-bit map reads like an 8-bit one: 0 (p 1) occupied, 65535 (p 0) free and 32768
    # (p 32767 / 65535, just below 0.5) unknown
    grid = load_ros(ros_yaml(tmp_path, "deep.pgm"))
    np.testing.assert_array_equal(grid.risk, [[1, 0, A]])


def test_a_map_image_past_pillows_pixel_limit_is_read(tmp_path: Path,
                                                      monkeypatch: pytest.MonkeyPatch) -> None:
    from PIL import Image

    path = write(tmp_path, "map.pgm", P5)  # 4 x 2 = 8 pixels
    # past the limit Pillow warns, past twice the limit it refuses: a map is read either way
    for limit in (7, 3):
        monkeypatch.setattr(Image, "MAX_IMAGE_PIXELS", limit)
        np.testing.assert_array_equal(read_image(path) * 255, PIXELS)
        # the limit is Pillow's again for everything else
        assert limit == Image.MAX_IMAGE_PIXELS


@pytest.mark.parametrize("limit", [7, 3])
def test_a_map_image_past_the_map_limit_is_refused_for_its_size(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch, limit: int) -> None:
    monkeypatch.setattr(cbr_grid.formats, "MAX_IMAGE_PIXELS", limit)
    path = write(tmp_path, "map.pgm", P5)
    message = (f"{path}: cannot read the image: it has 8 pixels, more than the {limit} a map "
               "image may have (cbr_grid.formats.MAX_IMAGE_PIXELS)")
    with pytest.raises(CbrError, match=f"^{re.escape(message)}$"):
        read_image(path)


@pytest.mark.parametrize("data", [P2, P5], ids=["P2", "P5"])
def test_ros_trinary(tmp_path: Path, data: bytes) -> None:
    write(tmp_path, "map.pgm", data)
    grid = load_ros(ros_yaml(tmp_path, "map.pgm"))
    np.testing.assert_array_equal(grid.risk, TRINARY)
    np.testing.assert_array_equal(grid.unknown, np.array(TRINARY) == A)
    # by default a planner may cross unknown cells, at the highest cost short of an obstacle
    assert grid.passable[grid.unknown].all()
    # without allow_unknown they are obstacles, still marked unknown
    lethal = load_ros(ros_yaml(tmp_path, "map.pgm", mode="trinary"), allow_unknown=False)
    np.testing.assert_array_equal(lethal.risk, np.where(np.array(TRINARY) == A, 1, TRINARY))
    np.testing.assert_array_equal(lethal.unknown, grid.unknown)


def test_ros_keeps_resolution_and_origin_as_the_frame(tmp_path: Path) -> None:
    write(tmp_path, "map.pgm", P2)
    grid = load_ros(ros_yaml(tmp_path, "map.pgm"))
    assert grid.frame == MapFrame(0.05, -1.0, -2.5, 0.0)
    assert grid.frame.origin == (-1.0, -2.5, 0.0)
    # the lower-left cell (0, 1) has its centre half a cell up and right of the origin
    np.testing.assert_allclose(grid.to_map([(0, 1)]), [[-0.975, -2.475]])


def test_ros_accepts_nav2s_map_type_key(tmp_path: Path) -> None:
    write(tmp_path, "map.pgm", P2)
    path = ros_yaml(tmp_path, "map.pgm")
    path.write_text(path.read_text() + "map_type: occupancy\n")
    assert load_ros(path).width == 4


def test_ros_scale_rescales_the_band_between_the_thresholds(tmp_path: Path) -> None:
    write(tmp_path, "map.pgm", P5)
    path = ros_yaml(tmp_path, "map.pgm", mode="scale")
    levels = read_image(path.parent / "map.pgm")
    values = occupancy_values(levels, mode="scale", negate=False, occupied_thresh=0.65,
                              free_thresh=0.2)
    np.testing.assert_array_equal(values, SCALE_VALUES)
    grid = load_ros(path)
    np.testing.assert_allclose(grid.risk, SCALE, rtol=0, atol=1e-15)
    assert grid.unknown is None  # an opaque image has no unknown pixel in scale mode


def test_ros_negate(tmp_path: Path) -> None:
    write(tmp_path, "map.pgm", P2)
    grid = load_ros(ros_yaml(tmp_path, "map.pgm", negate=1))
    np.testing.assert_array_equal(grid.risk, NEGATED)


def test_ros_thresholds_move_the_bands(tmp_path: Path) -> None:
    write(tmp_path, "map.pgm", P2)
    # free below 0.5, occupied above 0.55: 128 (0.498) and 200 become free, 100 (0.608) occupied
    grid = load_ros(ros_yaml(tmp_path, "map.pgm", occupied=0.55, free=0.5))
    np.testing.assert_array_equal(grid.risk, [[1, 0, 0, 0], [0, 1, 1, 0]])


def test_ros_image_path_is_relative_to_the_yaml_file(tmp_path: Path, monkeypatch:
                                                     pytest.MonkeyPatch) -> None:
    (tmp_path / "maps").mkdir()
    write(tmp_path / "maps", "map.pgm", P2)
    path = ros_yaml(tmp_path / "maps", "map.pgm")
    monkeypatch.chdir(tmp_path)
    grid = load_grid(Path("maps/map.yaml"), corner_cutting=True)
    assert (grid.width, grid.height, grid.corner_cutting) == (4, 2, True)
    assert load_grid(path).risk.tolist() == grid.risk.tolist()


def test_ros_with_a_png_image_averages_channels(tmp_path: Path) -> None:
    # red averages to 1/3 (occ 2/3, occupied); white is free; black is occupied
    Image.fromarray(np.array([[[255, 0, 0], [255, 255, 255], [0, 0, 0]]], dtype=np.uint8),
                    "RGB").save(tmp_path / "map.png")
    grid = load_ros(ros_yaml(tmp_path, "map.png"))
    np.testing.assert_array_equal(grid.risk, [[1, 0, 1]])


# RGBA pixels: black and white opaque, white and black transparent, grey 102 (level 0.4)
# opaque and half transparent (alpha 128), red opaque
RGBA = [[[0, 0, 0, 255], [255, 255, 255, 255], [255, 255, 255, 0], [0, 0, 0, 0],
         [102, 102, 102, 255], [102, 102, 102, 128], [255, 0, 0, 255]]]


@pytest.mark.parametrize(("mode", "expected"), [
    # the mean of R, G, B and alpha (1 opaque), occ = 1 - mean, against 0.65 and 0.2:
    # black (0 + 0 + 0 + 1) / 4 = 0.25, occ 0.75: occupied; white 1: free; transparent white
    # 0.75, occ 0.25: unknown; transparent black 0, occ 1: occupied; grey (1.2 + 1) / 4 = 0.55,
    # occ 0.45: unknown; half-transparent grey (1.2 + 128/255) / 4 = 0.4255, occ 0.5745:
    # unknown; red (1 + 1) / 4 = 0.5: unknown
    ("trinary", [100, 0, -1, 100, -1, -1, -1]),
    # every pixel that is not fully opaque unknown; the others by R, G, B: grey occ 0.6 is
    # rint((0.6 - 0.2) / 0.45 * 100) = rint(88.9) = 89; red occ 2/3 > 0.65: occupied
    ("scale", [100, 0, -1, -1, 89, -1, 100]),
    # the mean of R, G and B as 0-255, alpha ignored: 0 and 85 (red) are values, 255 and 102
    # are above 100: unknown
    ("raw", [0, -1, -1, 0, -1, -1, 85]),
])
def test_ros_alpha_reads_as_map_server_reads_it(tmp_path: Path, mode: str,
                                                expected: list[int]) -> None:
    Image.fromarray(np.array(RGBA, dtype=np.uint8), "RGBA").save(tmp_path / "map.png")
    path = ros_yaml(tmp_path, "map.png", mode=mode)
    values = occupancy_values(read_image(tmp_path / "map.png"), mode=mode, negate=False,
                              occupied_thresh=0.65, free_thresh=0.2)
    np.testing.assert_array_equal(values, [expected])
    grid = load_ros(path, allow_unknown=False)
    np.testing.assert_array_equal(grid.unknown, [np.array(expected) == -1])
    cost = np.floor(np.array(expected) / 100 * 254)
    np.testing.assert_array_equal(grid.risk[0], np.where(
        np.array(expected) == -1, 1, np.where(np.array(expected) == 100, 1, cost / 254)))


def test_ros_grey_with_alpha_weighs_grey_as_three_channels(tmp_path: Path) -> None:
    # map_server sees grey as three equal channels: the trinary mean is (3 L + A) / 4. White
    # transparent: 0.75, occ 0.25; black opaque: 0.25, occ 0.75. (A mean of the two channels
    # would read white transparent as 0.5, occ 0.5.)
    Image.fromarray(np.array([[[255, 0], [0, 255]]], dtype=np.uint8), "LA").save(
        tmp_path / "map.png")
    levels = read_image(tmp_path / "map.png")
    assert levels.shape == (1, 2, 2)
    for free, white in ((0.2, -1), (0.3, 0)):
        values = occupancy_values(levels, mode="trinary", negate=False, occupied_thresh=0.65,
                                  free_thresh=free)
        np.testing.assert_array_equal(values, [[white, 100]])


def test_ros_transparent_grey_and_cmyk_read_as_colour_and_alpha(tmp_path: Path) -> None:
    # a greyscale PNG whose white is the transparent grey (tRNS): in scale mode white is
    # unknown and black, opaque, occupied
    Image.fromarray(np.array([[0, 255]], dtype=np.uint8), "L").save(tmp_path / "map.png",
                                                                    transparency=255)
    grid = load_ros(ros_yaml(tmp_path, "map.png", mode="scale"), allow_unknown=False)
    np.testing.assert_array_equal(grid.unknown, [[False, True]])
    np.testing.assert_array_equal(grid.risk, [[1, 1]])
    # CMYK black (K 255) and white (nothing) read as the RGB black and white they are, not as a
    # colour with alpha
    cmyk = np.array([[[0, 0, 0, 255], [0, 0, 0, 0]]], dtype=np.uint8)
    Image.fromarray(cmyk, "CMYK").save(tmp_path / "map.tiff")
    np.testing.assert_array_equal(read_image(tmp_path / "map.tiff"), [[[0, 0, 0], [1, 1, 1]]])
    grid = load_ros(ros_yaml(tmp_path, "map.tiff"))
    np.testing.assert_array_equal(grid.risk, [[1, 0]])


def test_ros_scale_with_equal_thresholds_is_refused_only_with_a_pixel_between() -> None:
    # a pixel exactly at both thresholds would be scaled by a division by zero
    with pytest.raises(CbrError, match=r"^scale mode needs free_thresh below occupied_thresh, "
                                       r"got both 0\.5$"):
        occupancy_values(np.array([[0.5, 0.0]]), mode="scale", negate=False,
                         occupied_thresh=0.5, free_thresh=0.5)
    values = occupancy_values(np.array([[0.25, 0.0]]), mode="scale", negate=False,
                              occupied_thresh=0.5, free_thresh=0.5)
    np.testing.assert_array_equal(values, [[100, 100]])


def test_occupancy_values_become_risk_as_the_static_layer_reads_them() -> None:
    values = np.array([[0, 1, 50, 99, 100, -1]], dtype=np.int8)
    # cost int(v / 100 * 254): 2.54 -> 2, 127, 251.46 -> 251; 100 lethal
    risk, unknown = occupancy_risk(values, allow_unknown=True)
    np.testing.assert_array_equal(risk, [[0, 2 / 254, 127 / 254, 251 / 254, 1, 252 / 254]])
    np.testing.assert_array_equal(unknown, [[False] * 5 + [True]])
    risk, _ = occupancy_risk(values, allow_unknown=False)
    assert risk[0, -1] == 1


def test_png_luminance_threshold(tmp_path: Path) -> None:
    grey = np.array([[0.0, 1.0, 0.3], [0.7, 0.49, 0.51]])
    path = tmp_path / "grey.png"
    matplotlib.image.imsave(path, grey, cmap="gray", vmin=0, vmax=1)
    grid = load_grid(path)
    np.testing.assert_array_equal(grid.risk, [[1, 0, 1], [0, 1, 0]])

    # luminance of red is 0.299, of green 0.587
    rgb = np.array([[[1.0, 0, 0], [0, 1, 0]]])
    matplotlib.image.imsave(tmp_path / "rgb.png", rgb)
    np.testing.assert_array_equal(load_png(tmp_path / "rgb.png").risk, [[1, 0]])
    np.testing.assert_array_equal(load_png(tmp_path / "rgb.png", threshold=0.25).risk, [[0, 0]])
    np.testing.assert_array_equal(load_png(tmp_path / "rgb.png", threshold=0.6).risk, [[1, 1]])


def test_npy(tmp_path: Path) -> None:
    risk = np.array([[0.0, 0.25, 1.0], [0.5, 0.0, 0.0]])
    np.save(tmp_path / "risk.npy", risk)
    grid = load_grid(tmp_path / "risk.npy", corner_cutting=True)
    np.testing.assert_array_equal(grid.risk, risk)
    assert grid.corner_cutting
    np.testing.assert_array_equal(load_npy(tmp_path / "risk.npy").risk, risk)


def test_text_grid(tmp_path: Path) -> None:
    path = write(tmp_path, "small.grid", "..#\r\n.5#\r\n90.\r\n\r\n")
    grid = load_grid(path)
    np.testing.assert_array_equal(grid.risk, [[0, 0, 1], [0, 0.5, 1], [0.9, 0, 0]])
    assert load_text(write(tmp_path, "one.grid", "#.")).risk.tolist() == [[1, 0]]


def test_map_extension_reads_moving_ai(tmp_path: Path) -> None:
    path = write(tmp_path, "small.map", "type octile\nheight 1\nwidth 3\nmap\n.@.\n")
    assert load_grid(path).risk.tolist() == [[0, 1, 0]]


@pytest.mark.parametrize(("data", "message"), [
    (b"", "cannot read the image; expected a PGM (P2 or P5), PNG or another image format"),
    (b"\n# secret words\nP4", "cannot read the image; expected a PGM"),
    (b"P2\n0 2\n255\n", "cannot read the image; expected a PGM"),
    (b"P5\n2 2\n255\n\x00\x00\x00", "cannot read the image: its pixel data ends before the "
     "size its header gives"),
    (b"P2\n2 1\n255\n0\n", "cannot read the image: its pixel data ends before the size"),
    (b"P2\n2 2\n15\n0 0\n0 16\n", "cannot read the image: a pixel value exceeds the image's "
     "maximum value"),
    (b"P2\n2 1\n255\n0 secret\n", "cannot read the image: the file is damaged"),
])
def test_bad_pgm(tmp_path: Path, data: bytes, message: str) -> None:
    path = write(tmp_path, "bad.pgm", data)
    with pytest.raises(CbrError) as error:
        read_image(path)
    assert str(error.value).startswith(str(path))
    assert message in str(error.value)
    # the file's own words are never repeated
    assert "secret" not in str(error.value).removeprefix(str(path))


@pytest.mark.parametrize(("text", "message"), [
    ("- a list\n", "line 1: expected a YAML mapping"),
    ("image: [\n", "expected a YAML map description, got invalid YAML"),
    ("resolution: 0.05\n", "expected a 'image' entry (an image file name), it is missing"),
    ("image: map.pgm\nresolution: 0\n", "line 2: expected 'resolution' to be a positive number"),
    ("image: map.pgm\nresolution: 0.1\norigin: [0, 0]\n", "line 3: expected 'origin' to be a "
     "list of three numbers"),
    ("image: map.pgm\nresolution: 0.1\norigin: [0, 0, 0]\nnegate: 2\n",
     "line 4: expected 'negate' to be 0 or 1, got 2"),
    ("image: map.pgm\nresolution: 0.1\norigin: [0, 0, 0]\nnegate: 0\noccupied_thresh: 0.5\n"
     "free_thresh: 0.6\n", "line 6: expected 'free_thresh' to be a number within "
     "[0, occupied_thresh = 0.5], got 0.6"),
    ("image: map.pgm\nresolution: 0.1\norigin: [0, 0, 0]\nnegate: 0\noccupied_thresh: 0.6\n"
     "free_thresh: 0.2\nmode: secret\n", "line 7: expected 'mode' to be trinary, scale, raw, got "
     "a string"),
    ("image: map.pgm\nsize: 3\n", "line 2: expected only the keys"),
])
def test_bad_ros_yaml(tmp_path: Path, text: str, message: str) -> None:
    write(tmp_path, "map.pgm", P2)
    path = write(tmp_path, "map.yaml", text)
    with pytest.raises(CbrError) as error:
        load_ros(path)
    assert str(error.value).startswith(str(path))
    assert message in str(error.value)


def test_ros_missing_or_unreadable_image_names_the_image(tmp_path: Path) -> None:
    with pytest.raises(CbrError, match=r"missing\.pgm: cannot read"):
        load_ros(ros_yaml(tmp_path, "missing.pgm"))
    write(tmp_path, "broken.png", b"not a png at all")
    with pytest.raises(CbrError, match=r"broken\.png: cannot read the image"):
        load_ros(ros_yaml(tmp_path, "broken.png"))


def test_bad_png_npy_and_text(tmp_path: Path) -> None:
    cases: list[tuple[Path, str]] = [
        (write(tmp_path, "broken.png", b"\x89PNG garbage"), "cannot read the image"),
        (tmp_path / "missing.png", "cannot read: no such file"),
        (write(tmp_path, "text.npy", b"not numpy"), "expected a NumPy array file"),
        (write(tmp_path, "ragged.grid", "...\n..\n"), "line 2: expected a row of 3 cells like "
         "line 1, got 2"),
        (write(tmp_path, "char.grid", "..\n.x\n"), "line 2: expected '.', '#' or a digit at "
         "column 2"),
        (write(tmp_path, "empty.grid", "\n\n"), "line 1: expected a row of cells"),
        (write(tmp_path, "map.txt", ".."), "expected a map file ending in .map"),
    ]
    np.save(tmp_path / "cube.npy", np.zeros((2, 2, 2)))
    cases.append((tmp_path / "cube.npy", "grid risk must be 2-D"))
    np.save(tmp_path / "high.npy", np.array([[0.0, 1.5]]))
    cases.append((tmp_path / "high.npy", "the first is (1, 0) with 1.5"))
    np.save(tmp_path / "words.npy", np.array([["a"]]))
    cases.append((tmp_path / "words.npy", "expected a numeric array"))
    for path, message in cases:
        with pytest.raises(CbrError) as error:
            load_grid(path)
        assert str(error.value).startswith(str(path)), path
        assert message in str(error.value), path
    with pytest.raises(CbrError, match="threshold must be within"):
        load_png(tmp_path / "x.png", threshold=2)


def test_map_file_world_component(tmp_path: Path) -> None:
    write(tmp_path, "small.grid", ".#\n3.\n")
    registry = Registry()
    cbr_grid.cbr_register(registry=registry)
    component = registry.get("world", "map_file")
    with paths_relative_to(tmp_path):
        options = structure_options(component.options, {"path": "small.grid",
                                                        "corner_cutting": True}, "world")
    world = registry.create("world", "map_file", options, Context(registry=registry, seed=0))
    assert isinstance(world, Grid)
    assert world.corner_cutting
    np.testing.assert_array_equal(world.risk, [[0, 1], [0.3, 0]])
    with pytest.raises(ConfigError) as error:
        structure_options(component.options, {"path": "a.png", "threshold": 1.5}, "world")
    assert error.value.problems == ["world.threshold: must be <= 1.0: 1.5"]


def test_load_grid_places_a_map_of_cells_in_a_given_frame(tmp_path: Path) -> None:
    path = write(tmp_path, "small.grid", ".#\n..\n")
    frame = MapFrame(0.5, 10.0, 20.0)
    grid = load_grid(path, frame=frame)
    assert grid.frame == frame
    np.testing.assert_allclose(grid.to_map([(1, 0)]), [[10.75, 20.75]])
    assert load_grid(path).frame is None
    write(tmp_path, "map.pgm", P2)
    with pytest.raises(CbrError, match="a ROS map has its own frame"):
        load_grid(ros_yaml(tmp_path, "map.pgm"), frame=frame)


def test_map_file_world_inflates_in_metres(tmp_path: Path) -> None:
    # a 1 x 7 strip, 0.1 m cells, one obstacle at x = 0: the robot (radius 0.15 m) keeps its
    # centre out of the cell 0.1 m away, and the cost decays over 0.3 m
    write(tmp_path, "strip.pgm", b"P2\n7 1\n255\n0 255 255 255 255 255 255\n")
    text = (tmp_path / "strip.yaml")
    text.write_text("image: strip.pgm\nresolution: 0.1\norigin: [0, 0, 0]\nnegate: 0\n"
                    "occupied_thresh: 0.65\nfree_thresh: 0.2\n")
    registry = Registry()
    cbr_grid.cbr_register(registry=registry)
    component = registry.get("world", "map_file")
    with paths_relative_to(tmp_path):
        options = structure_options(component.options, {
            "path": "strip.yaml", "inflation": {"robot_radius": 0.15, "inflation_radius": 0.3,
                                                "cost_scaling_factor": 3.0}}, "world")
    world = registry.create("world", "map_file", options, Context(registry=registry, seed=0))
    # Nav2: int(252 exp(-3 (d - 0.15))) at d = 0.2 and 0.3 m: 216 and 160, risk cost / 254
    np.testing.assert_allclose(world.risk, [[1, 1, 216 / 254, 160 / 254, 0, 0, 0]])
    assert world.frame == MapFrame(0.1)
    problems = [
        ({"robot_radius": 0.3, "inflation_radius": 0.2},
         "world.inflation.inflation_radius: must be at least robot_radius (0.3), got 0.2"),
        ({"robot_radius": -1.0}, "world.inflation.robot_radius: must be a finite number >= 0"),
        ({"inflation_radius": 1.0}, "world.inflation.robot_radius: required option is missing"),
        (0.3, "world.inflation: expected a mapping with keys robot_radius, inflation_radius, "
              "cost_scaling_factor, got 0.3"),
    ]
    for inflation, message in problems:
        with pytest.raises(ConfigError) as error:
            structure_options(component.options, {"path": "a.yaml", "inflation": inflation},
                              "world")
        assert any(message in problem for problem in error.value.problems), error.value.problems


@pytest.mark.parametrize(("name", "options"), [
    ("movingai", {"map": "small.map"}),
    ("generated", {"kind": "maze", "width": 9, "height": 9}),
])
def test_every_grid_world_inflates(tmp_path: Path, name: str, options: dict[str, object]
                                   ) -> None:
    write(tmp_path, "small.map", "type octile\nheight 3\nwidth 5\nmap\n.....\n..@..\n.....\n")
    registry = Registry()
    cbr_grid.cbr_register(registry=registry)
    component = registry.get("world", name)
    ctx = Context(registry=registry, seed=0)
    with paths_relative_to(tmp_path):
        plain = registry.create("world", name, structure_options(component.options, options,
                                                                  "world"), ctx)
        inflated = registry.create("world", name, structure_options(
            component.options, {**options, "inflation": {"robot_radius": 1.0}}, "world"), ctx)
    # without a frame the radius is in cells: every 4-neighbour of an obstacle is blocked too
    np.testing.assert_array_equal(inflated.risk, inflate(plain, Inflation(1.0)).risk)
    blocked = ~plain.passable
    near = blocked.copy()
    near[1:] |= blocked[:-1]
    near[:-1] |= blocked[1:]
    near[:, 1:] |= blocked[:, :-1]
    near[:, :-1] |= blocked[:, 1:]
    np.testing.assert_array_equal(~inflated.passable, near)
