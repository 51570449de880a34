"""The Python reader on map_server's own test maps (navigation noetic, map_server/test/): the grids
map_server's utest.cpp and rtest.cpp expect, in the modes and thresholds they load them with
(test/gtest/map/test_map_server_maps.cpp holds the C++ reader to the same). The maps and the
expected grids (test_constants.cpp) come from the navigation source tarball beside the checkout,
which users do not have: without it the tests skip."""
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

REPO = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(REPO / "src"))  # runnable without a sourced catkin workspace

from marl_mrta.model.occupancy_map import MapFileError, load_map, pixels_to_grid, read_image  # noqa: E402

TARBALL = REPO.parent / "shared" / "external" / "navigation_noetic" / "navigation_noetic.tar.gz"
FILES = ("testmap.png", "testmap2.png", "spectrum.png", "testmap.yaml", "testmap2.yaml", "test_constants.cpp")


@pytest.fixture(scope="module")
def test_dir(tmp_path_factory):
    """map_server/test/ of the tarball, extracted into a temporary directory."""
    if not TARBALL.exists():
        pytest.skip(f"map_server's test maps not available: no {TARBALL} (the stock navigation source beside "
                    "the checkout)")
    folder = tmp_path_factory.mktemp("map_server_test")
    for name in FILES:
        with (folder / name).open("wb") as out:
            subprocess.run(["tar", "-xzOf", str(TARBALL), f"./map_server/test/{name}"], stdout=out, check=True)
    return folder


@pytest.fixture(scope="module")
def expected_grids(test_dir):
    """test_constants.cpp's grids, testmap's then tmap2's: row-major, the lowest row first."""
    source = (test_dir / "test_constants.cpp").read_text()
    grids = [[int(v) for v in body.split(",") if v.strip()]
             for body in re.findall(r"g_valid_image_content\[\]\s*=\s*\{([^}]*)\}", source)]
    assert [len(g) for g in grids] == [100, 144]
    return grids


def load_image(folder: Path, name: str, negate: bool, occupied_thresh: float, free_thresh: float,
               mode: str = "trinary") -> np.ndarray:
    """utest.cpp's call: loadMapFromFile(image, resolution, negate, occupied, free, origin 0, mode),
    as the flat grid map_server publishes."""
    return pixels_to_grid(read_image(folder / name), negate, occupied_thresh, free_thresh, mode).reshape(-1)


def test_load_valid_png(test_dir, expected_grids):
    # utest.cpp, loadValidPNG: not negated, thresholds 0.65 / 0.1, trinary.
    assert read_image(test_dir / "testmap.png").shape[:2] == (10, 10)
    assert load_image(test_dir, "testmap.png", False, 0.65, 0.1).tolist() == expected_grids[0]


def test_testmap_yaml(test_dir, expected_grids):
    # rtest.cpp, call_service: map_server started on testmap.yaml (0.65 / 0.196, origin yaw 1).
    loaded = load_map(test_dir / "testmap.yaml")
    assert (loaded.width, loaded.height, np.float32(loaded.resolution)) == (10, 10, np.float32(0.1))
    assert (loaded.origin.x, loaded.origin.y, loaded.origin.yaw) == (2.0, 3.0, 1.0)
    assert loaded.grid.reshape(-1).tolist() == expected_grids[0]


def test_testmap2_yaml(test_dir, expected_grids):
    # rtest.cpp, change_map: testmap2.yaml (negate 1, thresholds 0.5 / 0.2).
    loaded = load_map(test_dir / "testmap2.yaml")
    assert (loaded.width, loaded.height, np.float32(loaded.resolution)) == (12, 12, np.float32(0.1))
    assert loaded.grid.reshape(-1).tolist() == expected_grids[1]


def test_spectrum_in_every_mode(test_dir):
    # utest.cpp, testMapMode: every grey once, thresholds 0.65 / 0.1.
    def counts(mode):
        return np.bincount(load_image(test_dir, "spectrum.png", False, 0.65, 0.1, mode).view(np.uint8),
                           minlength=256)
    trinary = counts("trinary")
    assert (trinary[100], trinary[0], trinary[255]) == (90, 26, 140)
    scale = counts("scale")
    assert (scale[100], scale[0], scale[1:100].sum()) == (90, 26, 140)
    assert counts("raw").tolist() == [1] * 256


def test_load_invalid_file(test_dir):
    # utest.cpp, loadInvalidFile: a file that is not there is an error.
    with pytest.raises(MapFileError, match=r"foo: image: cannot read"):
        read_image(test_dir / "foo")
