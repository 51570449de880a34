"""The Python map_server reader: semantics (negate, thresholds, modes, origin, row order),
world <-> cell conversion at the borders, bad input, and the lab and TurtleBot3 maps."""
import math
import re
import sys
from pathlib import Path

import numpy as np
import pytest

REPO = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(REPO / "src"))  # runnable without a sourced catkin workspace

from marl_mrta.model.occupancy_map import (  # noqa: E402
    FREE, MAX_MAP_CELLS, OCCUPIED, UNKNOWN, GridCell, MapFileError, MapOrigin, OccupancyMap, load_map,
    read_pgm, save_map)

TB3_MAP = REPO.parent / "shared" / "external" / "turtlebot3_noetic" / "turtlebot3_navigation" \
    / "maps" / "map.yaml"


def write_map(tmp_path, pixels, yaml_text=None, name="m", **keys):
    """A PGM of the given rows (row 0 = top) and its YAML; keys override the defaults."""
    pixels = np.asarray(pixels, dtype=np.uint8)
    (tmp_path / f"{name}.pgm").write_bytes(
        b"P5\n# made by a test\n%d %d\n255\n" % (pixels.shape[1], pixels.shape[0])
        + pixels.tobytes())
    config = {"image": f"{name}.pgm", "resolution": 0.1, "origin": "[0.0, 0.0, 0.0]",
              "negate": 0, "occupied_thresh": 0.65, "free_thresh": 0.196, **keys}
    text = yaml_text if yaml_text is not None else \
        "".join(f"{key}: {value}\n" for key, value in config.items())
    path = tmp_path / f"{name}.yaml"
    path.write_text(text)
    return path


# ---------------------------------------------------------------- map_server semantics


def test_row_zero_is_the_bottom_image_row(tmp_path):
    # Black pixel in the image's top-left corner -> highest row, first column.
    pixels = np.full((3, 4), 254)
    pixels[0, 0] = 0
    grid_map = load_map(write_map(tmp_path, pixels))
    assert grid_map.grid.dtype == np.int8 and grid_map.grid.shape == (3, 4)
    assert grid_map.grid[2, 0] == OCCUPIED
    assert int((grid_map.grid == OCCUPIED).sum()) == 1
    assert grid_map.value_at(0.05, 0.25) == OCCUPIED


def test_trinary_thresholds_follow_map_server(tmp_path):
    # occ = (255 - p) / 255: p=89 -> 0.651 (> 0.65), p=90 -> 0.647, p=205 -> 0.196 (not < 0.196),
    # p=206 -> 0.192.
    pixels = [[0, 89, 90, 205, 206, 254, 255]]
    grid_map = load_map(write_map(tmp_path, pixels))
    assert grid_map.grid[0].tolist() == [OCCUPIED, OCCUPIED, UNKNOWN, UNKNOWN, FREE, FREE, FREE]


def test_negate_swaps_black_and_white(tmp_path):
    grid_map = load_map(write_map(tmp_path, [[0, 128, 254]], negate=1))
    assert grid_map.grid[0].tolist() == [FREE, UNKNOWN, OCCUPIED]


def test_scale_and_raw_modes(tmp_path):
    scale = load_map(write_map(tmp_path, [[0, 128, 254]], mode="scale"))
    # occ(128) = 0.498 -> 1 + 98 * (0.498 - 0.196) / (0.65 - 0.196) = 66.2 -> 66
    assert scale.grid[0].tolist() == [OCCUPIED, 66, FREE]
    raw = load_map(write_map(tmp_path, [[0, 100, 254]], mode="raw", name="raw"))
    assert raw.grid[0].tolist() == [0, 100, -2]   # the byte as nav_msgs' signed data holds it


def test_origin_resolution_and_cell_borders(tmp_path):
    grid_map = load_map(write_map(tmp_path, np.full((20, 10), 254), resolution=0.25,
                                  origin="[-1.0, 2.0, 0.0]"))
    assert grid_map.origin == MapOrigin(-1.0, 2.0, 0.0)
    assert (grid_map.width, grid_map.height, grid_map.resolution) == (10, 20, 0.25)
    assert grid_map.world_to_cell(-1.0, 2.0) == GridCell(0, 0)
    assert grid_map.world_to_cell(-0.7501, 2.2499) == GridCell(0, 0)
    assert grid_map.world_to_cell(-0.75, 2.25) == GridCell(1, 1)      # border -> next cell
    assert grid_map.world_to_cell(1.4999, 6.9999) == GridCell(9, 19)
    assert grid_map.world_to_cell(1.5, 3.0) is None                   # right edge: outside
    assert grid_map.world_to_cell(-1.0001, 3.0) is None
    assert grid_map.cell_to_world(0, 0) == pytest.approx((-0.875, 2.125))
    assert grid_map.cell_to_world(9, 19) == pytest.approx((1.375, 6.875))
    assert grid_map.value_at(5.0, 5.0) == UNKNOWN and not grid_map.is_free(5.0, 5.0)


def test_origin_yaw_rotates_the_grid():
    grid = np.zeros((2, 4), dtype=np.int8)
    grid_map = OccupancyMap(grid, 0.5, MapOrigin(1.0, 1.0, math.pi / 2))
    # The map's x axis points along world +y: cell (3, 0) centre is 1.75 m up, 0.25 m left.
    assert grid_map.cell_to_world(3, 0) == pytest.approx((0.75, 2.75))
    assert grid_map.world_to_cell(0.75, 2.75) == GridCell(3, 0)
    assert grid_map.world_to_cell(1.25, 2.75) is None



def test_arrays_of_points_and_cells_follow_the_same_rule_as_one():
    rng = np.random.default_rng(3)
    grid_map = OccupancyMap(np.zeros((7, 9), dtype=np.int8), 0.25, MapOrigin(-1.0, 0.5, 0.7))
    xs, ys = rng.uniform(-2.5, 1.0, 400), rng.uniform(0.0, 3.5, 400)
    cols, rows, inside = grid_map.world_to_cells(xs, ys)
    for x, y, col, row, on_map in zip(xs, ys, cols, rows, inside):
        cell = grid_map.world_to_cell(x, y)
        assert (cell is not None) == on_map
        if on_map:
            assert cell == GridCell(col, row)
    assert inside.sum() > 50 and (~inside).sum() > 50
    centres = grid_map.cell_to_world(np.array([0, 8, 3]), np.array([0, 6, 2]))
    for k, (col, row) in enumerate([(0, 0), (8, 6), (3, 2)]):
        assert (centres.x[k], centres.y[k]) == pytest.approx(grid_map.cell_to_world(col, row))


def test_clearance_is_the_distance_to_the_nearest_cell_that_is_not_free():
    grid = np.zeros((5, 8), dtype=np.int8)
    grid[2, 0] = OCCUPIED
    grid[4, 7] = UNKNOWN
    clearance = OccupancyMap(grid, 0.5, MapOrigin(0.0, 0.0, 0.0)).clearance()
    assert clearance[2, 0] == 0.0 and clearance[4, 7] == 0.0
    assert clearance[2, 3] == pytest.approx(1.5)          # three cells right of the occupied one
    assert clearance[3, 6] == pytest.approx(math.hypot(0.5, 0.5))   # next to the unknown one

def test_save_then_load_round_trips(tmp_path):
    grid = np.array([[OCCUPIED, FREE, UNKNOWN], [FREE, FREE, OCCUPIED]], dtype=np.int8)
    original = OccupancyMap(grid, 0.05, MapOrigin(-2.0, 3.5, 0.0))
    image = save_map(original, tmp_path / "saved.yaml", comment="a test map")
    assert image == tmp_path / "saved.pgm"
    assert read_pgm(image).tolist() == [[254, 254, 0], [0, 254, 205]]   # top row first
    loaded = load_map(tmp_path / "saved.yaml")
    assert np.array_equal(loaded.grid, grid) and loaded.origin == original.origin
    assert loaded.resolution == pytest.approx(0.05)


def test_plain_pgm_is_read(tmp_path):
    (tmp_path / "plain.pgm").write_text("P2\n# comment\n3 1\n255\n0 205\n254\n")
    assert read_pgm(tmp_path / "plain.pgm").tolist() == [[0, 205, 254]]


# ---------------------------------------------------------------- bad input


@pytest.mark.parametrize("keys, expected", [
    ({"resolution": -0.05}, "m.yaml: resolution: must be positive, got -0.05"),
    ({"origin": "[0, 0]"}, "m.yaml: origin: must be [x, y, yaw] numbers, got [0, 0]"),
    ({"negate": 2}, "m.yaml: negate: must be 0 or 1, got 2"),
    ({"mode": "fuzzy"}, "m.yaml: mode: 'fuzzy' is not one of trinary, scale, raw"),
    ({"free_thresh": 0.9}, "m.yaml: free_thresh/occupied_thresh: need 0 <= free_thresh"),
    ({"resolutoin": 0.05}, "m.yaml: resolutoin: unknown key"),
    ({"image": "absent.pgm"}, "absent.pgm: image: cannot read (No such file or directory)"),
])
def test_bad_yaml_values_give_one_line_naming_file_and_field(tmp_path, keys, expected):
    with pytest.raises(MapFileError) as error:
        load_map(write_map(tmp_path, [[0]], **keys))
    assert expected in str(error.value) and "\n" not in str(error.value)


def test_malformed_and_incomplete_yaml(tmp_path):
    with pytest.raises(MapFileError, match=r"m\.yaml: line 2: mapping values are not allowed here$"):
        load_map(write_map(tmp_path, [[0]], yaml_text="image: m.pgm\nresolution: 0.1: 2\n"))
    with pytest.raises(MapFileError, match=r"m\.yaml: negate: missing$"):
        load_map(write_map(tmp_path, [[0]], yaml_text="image: m.pgm\nresolution: 0.1\n"
                                                      "origin: [0, 0, 0]\n"))
    with pytest.raises(MapFileError, match=r"absent\.yaml: cannot read"):
        load_map(tmp_path / "absent.yaml")


def test_bad_images(tmp_path):
    path = write_map(tmp_path, [[0, 0]])
    (tmp_path / "m.pgm").write_bytes(b"P5\n2 1\n255\n\x00")
    with pytest.raises(MapFileError, match=r"m\.pgm: PGM data: expected 2 bytes, got 1"):
        load_map(path)
    (tmp_path / "m.pgm").write_bytes(b"\x89PNG\r\n\x1a\n....")   # read as a PNG, whatever its name
    with pytest.raises(MapFileError, match=r"m\.pgm: PNG: "):
        load_map(path)
    (tmp_path / "m.pgm").write_bytes(b"\xff\xd8\xff\xe0 a JPEG")
    with pytest.raises(MapFileError, match=r"m\.pgm: PGM header: not a PGM or PNG file \(expected magic P5 or P2, "
                                           r"or a PNG, found '\\xff\\xd8'\)$"):
        load_map(path)
    (tmp_path / "m.pgm").write_bytes(b"P5\n2 1\n65535\n\x00\x00\x00\x00")
    with pytest.raises(MapFileError, match=r"m\.pgm: PGM header: maxval 65535: map_server reads PGMs of 8 bits or "
                                           r"fewer \(maxval 1 to 255\)$"):
        load_map(path)


# ---------------------------------------------------------------- real maps


def test_lab_map_start_poses_free_and_a_column_occupied():
    lab = load_map(REPO / "maps" / "lab.yaml")
    assert (lab.width, lab.height) == (160, 120)
    assert set(np.unique(lab.grid).tolist()) == {FREE, OCCUPIED}
    assert all(lab.is_free(x, y) for x, y in [(0.5, 0.5), (0.5, 4.5), (6.5, 0.5), (6.5, 4.5)])
    column = lab.world_to_cell(5.25, 3.5)
    assert lab.grid[column.row, column.col] == OCCUPIED
    assert lab.cell_to_world(*column) == pytest.approx((5.275, 3.525))


def test_turtlebot3_map_has_the_centre_pillar_at_the_origin():
    if not TB3_MAP.exists():
        pytest.skip(f"TurtleBot3's map is not at {TB3_MAP} (expected beside the repository, "
                    "in ../shared/external/turtlebot3_noetic)")
    tb3 = load_map(TB3_MAP)
    assert (tb3.width, tb3.height, tb3.resolution) == (384, 384, 0.05)
    assert tb3.origin == MapOrigin(-10.0, -10.0, 0.0)
    # turtlebot3_world's middle pillar (radius ~0.15 m) is mapped as a ring round (0, 0):
    # outline occupied, inside never seen (unknown), the floor around it free.
    assert tb3.value_at(0.15, 0.0) == OCCUPIED and tb3.value_at(-0.1, 0.0) == OCCUPIED
    assert tb3.value_at(0.0, 0.15) == OCCUPIED
    assert tb3.value_at(0.0, 0.0) == UNKNOWN
    assert tb3.value_at(0.0, -0.2) == FREE and tb3.value_at(0.55, 0.0) == FREE
    # Unexplored space outside the arena.
    assert tb3.value_at(-9.0, -9.0) == UNKNOWN


def test_an_image_of_too_many_cells_is_refused_from_its_header():
    """A map past MAX_MAP_CELLS (often a resolution typed too fine) is one line before its pixels
    are read; the fixture's header promises 30 M cells and holds three bytes. The C++ reader keeps
    the same limit."""
    path = REPO / "test" / "data" / "maps" / "bad_too_large.yaml"
    with pytest.raises(MapFileError) as error:
        load_map(path)
    assert str(error.value) == (f"{path.parent / 'too_large.pgm'}: PGM header: 6000 x 5000 = 30000000 cells, "
                                "more than the 25000000 a map may have (a 250 m square at 0.05 m)")
    header = (REPO / "include" / "marl_mrta" / "map" / "occupancy_map.h").read_text()
    assert re.search(r"constexpr size_t kMaxMapCells = (\d+);", header).group(1) == str(MAX_MAP_CELLS)
