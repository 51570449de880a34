"""Maps in PNG, as map_server reads them: grey, grey + alpha, RGB and RGBA, 1- and 16-bit, in the
three modes, the same grid as the same image in PGM where it is grey; bad PNGs give one line; and
against the stock map_server itself (where the stock stack is built), the Python reader and the
built-in map_server publish the grid stock's map_server publishes."""
import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

REPO = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(REPO / "src"))  # runnable without a sourced catkin workspace

Image = pytest.importorskip("PIL.Image", reason="Pillow not installed (python3-pil)")

from marl_mrta.model.occupancy_map import (  # noqa: E402
    FREE, MAX_MAP_CELLS, OCCUPIED, UNKNOWN, MapFileError, load_map, read_image)

YAML = ("image: {image}\nresolution: 0.05\norigin: [-0.4, -0.2, 0.0]\nnegate: {negate}\n"
        "occupied_thresh: 0.65\nfree_thresh: 0.196\nmode: {mode}\n")


def write_png_map(folder: Path, name: str, pixels: np.ndarray, pil_mode: str, mode: str = "trinary",
                  negate: int = 0) -> Path:
    Image.fromarray(pixels, pil_mode).save(folder / f"{name}.png")
    path = folder / f"{name}.yaml"
    path.write_text(YAML.format(image=f"{name}.png", negate=negate, mode=mode))
    return path


def grey_ramp(rows=8, cols=16, seed=0) -> np.ndarray:
    """Every threshold's neighbourhood and a few random values (row 0 = top)."""
    values = np.array([0, 1, 88, 89, 90, 204, 205, 206, 253, 254, 255, 100, 150, 166, 167, 168], dtype=np.uint8)
    pixels = np.random.default_rng(seed).integers(0, 256, size=(rows, cols)).astype(np.uint8)
    pixels[0, :len(values)] = values
    return pixels


def colour(rows=8, cols=16, channels=3, seed=1) -> np.ndarray:
    pixels = np.random.default_rng(seed).integers(0, 256, size=(rows, cols, channels)).astype(np.uint8)
    pixels[0, :4, :3] = [[0, 0, 0], [254, 254, 254], [205, 205, 205], [200, 210, 0]]   # the last: blue 0
    if channels == 4:
        pixels[1, :6, 3] = [0, 0, 255, 255, 128, 1]
    return pixels


# ---------------------------------------------------------------- the Python reader


@pytest.mark.parametrize("mode", ["trinary", "scale", "raw"])
@pytest.mark.parametrize("negate", [0, 1])
def test_a_grey_png_is_the_same_map_as_the_same_pgm(tmp_path, mode, negate):
    pixels = grey_ramp()
    png = load_map(write_png_map(tmp_path, "grey", pixels, "L", mode, negate))
    (tmp_path / "grey.pgm").write_bytes(b"P5\n%d %d\n255\n" % (pixels.shape[1], pixels.shape[0]) + pixels.tobytes())
    (tmp_path / "pgm.yaml").write_text(YAML.format(image="grey.pgm", negate=negate, mode=mode))
    pgm = load_map(tmp_path / "pgm.yaml")
    assert np.array_equal(png.grid, pgm.grid)
    assert (png.resolution, png.origin) == (pgm.resolution, pgm.origin)
    if mode == "trinary":
        assert {FREE, OCCUPIED, UNKNOWN} <= set(np.unique(png.grid).tolist())


def test_colour_is_the_mean_of_the_channels_and_alpha_counts_as_map_server_counts_it(tmp_path):
    rgb = colour()
    grid = load_map(write_png_map(tmp_path, "rgb", rgb, "RGB")).grid
    top = grid[-1]   # the image's top row is the grid's last
    assert list(top[:3]) == [OCCUPIED, FREE, UNKNOWN]
    mean = rgb.astype(float).mean(axis=2)
    occ = (255 - mean) / 255
    assert np.array_equal(np.flipud(grid) == OCCUPIED, occ > 0.65)
    assert np.array_equal(np.flipud(grid) == FREE, occ < 0.196)

    # scale mode: map_server takes an RGB pixel's last channel, blue, for its alpha
    scale = load_map(write_png_map(tmp_path, "rgb_scale", rgb, "RGB", "scale")).grid
    assert scale[-1, 3] == UNKNOWN and 1 <= scale[-1, 2] <= 99

    rgba = colour(channels=4)
    trinary = np.flipud(load_map(write_png_map(tmp_path, "rgba", rgba, "RGBA")).grid)
    occ4 = (255 - rgba.astype(float).mean(axis=2)) / 255   # trinary: alpha averaged in
    assert np.array_equal(trinary == OCCUPIED, occ4 > 0.65)
    scaled = np.flipud(load_map(write_png_map(tmp_path, "rgba_scale", rgba, "RGBA", "scale")).grid)
    occ3 = (255 - rgba[..., :3].astype(float).mean(axis=2)) / 255   # scale: colours only
    between = (occ3 >= 0.196) & (occ3 <= 0.65)
    assert np.array_equal(scaled == OCCUPIED, occ3 > 0.65)
    assert np.all(scaled[between & (rgba[..., 3] == 0)] == UNKNOWN)
    assert np.all(scaled[between & (rgba[..., 3] > 0)] >= 1)


def test_grey_alpha_reads_as_rgba_and_one_and_sixteen_bit_grey_as_eight(tmp_path):
    grey = grey_ramp()
    alpha = np.full_like(grey, 255)
    alpha[2] = 0
    folder = tmp_path
    Image.fromarray(np.stack([grey, alpha], axis=2), "LA").save(folder / "la.png")
    assert np.array_equal(read_image(folder / "la.png"), np.stack([grey, grey, grey, alpha], axis=2))
    Image.fromarray(grey.astype(np.uint16) * 256 + 3, "I;16").save(folder / "g16.png")
    assert np.array_equal(read_image(folder / "g16.png"), grey)
    Image.fromarray(grey > 127).save(folder / "bits.png")
    assert np.array_equal(read_image(folder / "bits.png"), np.where(grey > 127, 255, 0))


def test_bad_pngs_give_one_line_naming_the_file(tmp_path):
    path = write_png_map(tmp_path, "m", grey_ramp(), "L")
    Image.fromarray(grey_ramp(), "L").convert("P").save(tmp_path / "m.png")
    with pytest.raises(MapFileError, match=r"m\.png: PNG: a palette image; map_server reads its palette indices"):
        load_map(path)
    whole = (tmp_path / "m.png").read_bytes()
    Image.fromarray(grey_ramp(), "L").save(tmp_path / "m.png")
    (tmp_path / "m.png").write_bytes((tmp_path / "m.png").read_bytes()[:60])
    with pytest.raises(MapFileError, match=r"m\.png: PNG: ") as error:
        load_map(path)
    assert "\n" not in str(error.value) and len(whole) > 60
    (tmp_path / "m.png").write_bytes(b"\x89PNG\r\n\x1a\n" + b"\x00" * 30)
    with pytest.raises(MapFileError, match=r"m\.png: PNG: "):
        load_map(path)


def test_a_png_of_too_many_cells_is_refused_from_its_header(tmp_path):
    side = int(MAX_MAP_CELLS ** 0.5) + 1
    Image.new("1", (side, side)).save(tmp_path / "big.png")   # 1-bit: small on disk
    (tmp_path / "big.yaml").write_text(YAML.format(image="big.png", negate=0, mode="trinary"))
    with pytest.raises(MapFileError, match=r"big\.png: PNG header: .* cells, more than"):
        load_map(tmp_path / "big.yaml")


# ---------------------------------------------------------------- against stock map_server


COLLECT = r"""
import json, sys, rospy
from nav_msgs.msg import OccupancyGrid
rospy.init_node("collect_maps", anonymous=True)
grids = {}
for topic in sys.argv[2:]:
    grid = rospy.wait_for_message(topic, OccupancyGrid, timeout=60)
    grids[topic] = {"width": grid.info.width, "height": grid.info.height, "data": list(grid.data),
                    "resolution": grid.info.resolution, "origin": [grid.info.origin.position.x,
                                                                   grid.info.origin.position.y]}
json.dump(grids, open(sys.argv[1], "w"))
"""


def stock_map_server() -> bool:
    rospkg = pytest.importorskip("rospkg", reason="ROS not available")
    known = rospkg.RosPack().list()
    return "map_server" in known and "marl_mrta" in known


@pytest.mark.ros
@pytest.mark.slow
def test_png_maps_are_read_as_stock_map_server_reads_them(tmp_path):
    if not stock_map_server():
        pytest.skip("stock navigation not available (no map_server package; make stock-nav)")
    from marl_mrta.ros.process_group import free_port, stop_process_group
    grey, rgba = grey_ramp(), colour(channels=4)
    alpha = np.full_like(grey, 255)
    alpha[3] = 0
    cases = {
        "grey_trinary": write_png_map(tmp_path, "grey_trinary", grey, "L"),
        "grey_scale_negate": write_png_map(tmp_path, "grey_scale_negate", grey, "L", "scale", 1),
        "rgb_trinary": write_png_map(tmp_path, "rgb_trinary", colour(), "RGB"),
        "rgb_scale": write_png_map(tmp_path, "rgb_scale", colour(), "RGB", "scale"),
        "rgba_trinary": write_png_map(tmp_path, "rgba_trinary", rgba, "RGBA"),
        "rgba_scale": write_png_map(tmp_path, "rgba_scale", rgba, "RGBA", "scale"),
        "rgba_raw": write_png_map(tmp_path, "rgba_raw", rgba, "RGBA", "raw"),
        "la_scale": write_png_map(tmp_path, "la_scale", np.stack([grey, alpha], axis=2), "LA", "scale"),
        "grey16_raw": write_png_map(tmp_path, "grey16_raw", grey.astype(np.uint16) * 257, "I;16", "raw"),
    }
    nodes = "".join(
        f'<group ns="{stack}_{name}"><node pkg="{package}" type="map_server" name="map_server" args="{path}"/></group>'
        for name, path in cases.items() for stack, package in (("stock", "map_server"), ("builtin", "marl_mrta")))
    (tmp_path / "maps.launch").write_text(f"<launch>{nodes}</launch>")
    port = free_port()
    env = {**os.environ, "ROS_MASTER_URI": f"http://localhost:{port}", "ROS_LOG_DIR": str(tmp_path / "log")}
    launch = subprocess.Popen(["roslaunch", "-p", str(port), str(tmp_path / "maps.launch")], env=env,
                              stdout=subprocess.DEVNULL, stderr=subprocess.STDOUT, start_new_session=True)
    try:
        topics = [f"/{stack}_{name}/map" for name in cases for stack in ("stock", "builtin")]
        collect = subprocess.run([sys.executable, "-c", COLLECT, str(tmp_path / "grids.json"), *topics], env=env,
                                 capture_output=True, text=True, timeout=120)
        assert collect.returncode == 0, collect.stderr[-2000:]
    finally:
        stop_process_group(launch, timeout=20.0)
    grids = json.loads((tmp_path / "grids.json").read_text())
    for name, path in cases.items():
        stock, builtin = grids[f"/stock_{name}/map"], grids[f"/builtin_{name}/map"]
        ours = load_map(path)
        assert (stock["width"], stock["height"]) == (ours.width, ours.height) == (16, 8), name
        assert stock["data"] == ours.grid.reshape(-1).tolist(), f"{name}: the Python reader differs from stock"
        assert builtin["data"] == stock["data"], f"{name}: the built-in map_server differs from stock"
        assert builtin["origin"] == pytest.approx(stock["origin"]) and builtin["resolution"] == pytest.approx(0.05)
