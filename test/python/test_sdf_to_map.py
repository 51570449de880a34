"""sdf_to_map: the committed lab and site maps, geometry digitising, and one-line errors for bad input."""
import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

REPO = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(REPO / "src"))  # runnable without a sourced catkin workspace

from marl_mrta.model.occupancy_map import FREE, OCCUPIED, load_map  # noqa: E402
from marl_mrta.model.sdf_to_map import (  # noqa: E402
    HeightBand, MapRequest, SdfError, sdf_to_occupancy_map)

SCRIPT = REPO / "scripts" / "sdf_to_map"
LAB_SDF = REPO / "maps" / "lab.sdf"
LAB_ARGS = ["--origin", "-0.5", "-0.5", "--size", "8.0", "6.0"]


def run_script(*args):
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(
        [str(REPO / "src"), os.environ.get("PYTHONPATH", "")]))
    return subprocess.run([sys.executable, str(SCRIPT), *map(str, args)], env=env,
                          capture_output=True, text=True, timeout=60)


def write_sdf(tmp_path, body, name="world.sdf"):
    path = tmp_path / name
    path.write_text(f'<?xml version="1.0"?>\n<sdf version="1.7"><world name="w">{body}'
                    "</world></sdf>\n")
    return path


def box_model(name, pose, size, link_pose="0 0 0 0 0 0"):
    return (f'<model name="{name}"><pose>{pose}</pose><link name="l"><pose>{link_pose}</pose>'
            f'<collision name="c"><geometry><box><size>{size}</size></box></geometry>'
            "</collision></link></model>")


def small_request(**kwargs):
    return MapRequest(origin=(0.0, 0.0), size=(2.0, 2.0), **kwargs)


# ---------------------------------------------------------------- the committed lab map


def test_regenerated_lab_map_is_byte_identical_to_the_committed_one(tmp_path):
    result = run_script(LAB_SDF, tmp_path / "lab.yaml", *LAB_ARGS)
    assert result.returncode == 0, result.stderr
    assert (tmp_path / "lab.pgm").read_bytes() == (REPO / "maps" / "lab.pgm").read_bytes()
    assert (tmp_path / "lab.yaml").read_text() == (REPO / "maps" / "lab.yaml").read_text()


def test_regenerated_site_map_is_byte_identical_to_the_committed_one(tmp_path):
    result = run_script(REPO / "maps" / "site.sdf", tmp_path / "site.yaml", "--origin", "-0.5", "-0.5",
                        "--size", "17.0", "11.0")
    assert result.returncode == 0, result.stderr
    assert (tmp_path / "site.pgm").read_bytes() == (REPO / "maps" / "site.pgm").read_bytes()
    assert (tmp_path / "site.yaml").read_text() == (REPO / "maps" / "site.yaml").read_text()


def test_site_map_has_its_bays_doors_columns_and_office():
    site = load_map(REPO / "maps" / "site.yaml")
    assert (site.width, site.height) == (340, 220)
    for y in (0.5, 5.0, 9.5):                       # partitions closed outside the doors
        assert site.value_at(5.3, y) == OCCUPIED and site.value_at(10.7, y) == OCCUPIED
    for y in (2.4, 7.6):                            # two 1.2 m doors in each partition
        assert site.value_at(5.3, y) == FREE and site.value_at(10.7, y) == FREE
    for x, y in ((1.8, 3.3), (9.1, 7.5), (14.2, 6.0), (8.0, 5.0)):   # columns, the stair core
        assert site.value_at(x, y) == OCCUPIED
    assert site.value_at(13.8, 7.6) == OCCUPIED and site.value_at(14.7, 7.6) == FREE   # the office door


@pytest.fixture(scope="module")
def lab():
    return load_map(REPO / "maps" / "lab.yaml")


def test_lab_map_has_the_documented_size_and_origin(lab):
    assert (lab.width, lab.height) == (160, 120)
    assert lab.resolution == pytest.approx(0.05)
    assert (lab.origin.x, lab.origin.y, lab.origin.yaw) == (-0.5, -0.5, 0.0)
    header = (REPO / "maps" / "lab.pgm").read_bytes()[:15]
    assert header == b"P5\n160 120\n255\n"


@pytest.mark.parametrize("x, y", [(1.75, 1.5), (1.75, 3.5), (5.25, 1.5), (5.25, 3.5)])
def test_lab_columns_are_occupied_exactly_0_4_m_wide(lab, x, y):
    assert lab.value_at(x, y) == OCCUPIED
    # Faces at x +- 0.2: the cells just inside are occupied, just outside free.
    for inside, outside in [((x - 0.175, y), (x - 0.225, y)), ((x + 0.175, y), (x + 0.225, y)),
                            ((x, y - 0.175), (x, y - 0.225)), ((x, y + 0.175), (x, y + 0.225))]:
        assert lab.value_at(*inside) == OCCUPIED
        assert lab.value_at(*outside) == FREE


def test_lab_door_is_open_1_m_wide_and_the_partition_closed_elsewhere(lab):
    row_of = lambda y: lab.world_to_cell(3.5, y).row  # noqa: E731
    partition_col = lab.world_to_cell(3.5, 2.5).col
    column = lab.grid[:, partition_col]
    door_rows = [r for r in range(row_of(0.01), row_of(4.99) + 1) if column[r] == FREE]
    assert door_rows == list(range(row_of(2.01), row_of(2.99) + 1))
    assert len(door_rows) * lab.resolution == pytest.approx(1.0)
    # The lintel above the door is outside the height band and must not close it.
    assert lab.value_at(3.5, 2.5) == FREE
    assert lab.value_at(3.5, 1.0) == OCCUPIED and lab.value_at(3.5, 4.0) == OCCUPIED


def test_lab_walls_enclose_the_interior(lab):
    for x, y in [(-0.075, 2.5), (7.075, 2.5), (3.5, -0.075), (3.5, 5.075), (-0.1, -0.1)]:
        assert lab.value_at(x, y) == OCCUPIED, (x, y)
    # Interior next to the wall faces, and the start poses, are free.
    for x, y in [(0.025, 2.5), (6.975, 2.5), (2.0, 0.025), (2.0, 4.975),
                 (0.5, 0.5), (0.5, 4.5), (6.5, 0.5), (6.5, 4.5)]:
        assert lab.value_at(x, y) == FREE, (x, y)
    # Outer walls are 3 cells (0.15 m) thick: outside them is free ground.
    assert lab.value_at(-0.175, 2.5) == FREE and lab.value_at(7.175, 2.5) == FREE


# ---------------------------------------------------------------- digitising geometry


def test_yawed_box_is_digitised_along_its_diagonal(tmp_path):
    sdf = write_sdf(tmp_path, box_model("beam", "1 1 0.25 0 0 0.7853981633974483",
                                        "1.2 0.1 0.5"))
    grid_map = sdf_to_occupancy_map(sdf, small_request())
    for t in (-0.4, 0.0, 0.4):        # along the beam's axis (45 degrees)
        assert grid_map.value_at(1 + t * math.cos(math.pi / 4), 1 + t * math.sin(math.pi / 4)) \
            == OCCUPIED
    assert grid_map.value_at(1.3, 0.7) == FREE and grid_map.value_at(0.7, 1.3) == FREE


def test_nested_model_link_and_collision_poses_compose(tmp_path):
    # Outer model turned 90 deg at (1, 0.5): the link's +0.5 m along x lands at world (1, 1).
    inner = box_model("inner", "0 0 0 0 0 0", "0.1 0.1 1", link_pose="0.5 0 0.5 0 0 0")
    sdf = write_sdf(tmp_path, f'<model name="outer"><pose>1 0.5 0 0 0 1.5707963267948966'
                              f'</pose>{inner}</model>')
    grid_map = sdf_to_occupancy_map(sdf, small_request())
    occupied = np.argwhere(grid_map.grid == OCCUPIED)
    assert sorted(map(tuple, occupied)) == [(19, 19), (19, 20), (20, 19), (20, 20)]


def test_cylinder_is_round_and_sphere_is_cut_by_the_band(tmp_path):
    sdf = write_sdf(tmp_path, (
        '<model name="pillar"><pose>0.5 0.5 0 0 0 0</pose><link name="l"><collision name="c">'
        "<pose>0 0 1 0 0 0</pose><geometry><cylinder><radius>0.2</radius><length>2</length>"
        "</cylinder></geometry></collision></link></model>"
        '<model name="ball"><pose>1.5 1.5 0.7 0 0 0</pose><link name="l"><collision name="c">'
        "<geometry><sphere><radius>0.3</radius></sphere></geometry></collision></link></model>"))
    grid_map = sdf_to_occupancy_map(sdf, small_request())
    assert grid_map.value_at(0.5, 0.5) == OCCUPIED
    assert grid_map.value_at(0.5 + 0.175, 0.5) == OCCUPIED
    assert grid_map.value_at(0.5 + 0.175, 0.5 + 0.175) == FREE   # corner of its bounding square
    # The ball (centre 0.7 m) meets the band's top (0.5 m) in a circle of radius sqrt(0.05).
    assert grid_map.value_at(1.5, 1.5 + 0.175) == OCCUPIED
    assert grid_map.value_at(1.5, 1.5 + 0.275) == FREE


def test_only_geometry_within_the_height_band_is_mapped(tmp_path):
    sdf = write_sdf(tmp_path, (
        '<model name="ground"><link name="l"><collision name="c"><geometry><plane>'
        "<normal>0 0 1</normal></plane></geometry></collision></link></model>"
        + box_model("shelf", "0.5 0.5 1.5 0 0 0", "0.4 0.4 0.2")
        + box_model("crate", "1.5 1.5 0.2 0 0 0", "0.4 0.4 0.4")))
    default = sdf_to_occupancy_map(sdf, small_request())
    assert default.value_at(0.5, 0.5) == FREE and default.value_at(1.5, 1.5) == OCCUPIED
    tall = sdf_to_occupancy_map(sdf, small_request(band=HeightBand(0.05, 2.0)))
    assert tall.value_at(0.5, 0.5) == OCCUPIED


def test_default_origin_and_size_cover_the_obstacles_with_the_margin(tmp_path):
    sdf = write_sdf(tmp_path, box_model("crate", "1.0 2.0 0.2 0 0 0", "1.0 0.5 0.4"))
    grid_map = sdf_to_occupancy_map(sdf, MapRequest(margin=0.25))
    assert (grid_map.origin.x, grid_map.origin.y) == pytest.approx((0.25, 1.5))
    assert (grid_map.width, grid_map.height) == (30, 20)
    assert int((grid_map.grid == OCCUPIED).sum()) == 20 * 10


# ---------------------------------------------------------------- bad input


@pytest.mark.parametrize("case, content, expected", [
    ("malformed", '<sdf version="1.7"><world name="w"><model></world></sdf>',
     ["malformed.sdf: XML: mismatched tag"]),
    ("mesh", '<sdf version="1.7"><world name="w">' + box_model("ok", "0 0 0 0 0 0", "1 1 1")
     .replace("<box><size>1 1 1</size></box>", "<mesh><uri>a.dae</uri></mesh>") + "</world></sdf>",
     ["mesh.sdf: world[w]/model[ok]/link[l]/collision[c]/geometry/mesh:",
      "unsupported geometry <mesh>"]),
    ("size", '<sdf version="1.7"><world name="w">' + box_model("wall", "0 0 0 0 0 0", "1 x 1")
     + "</world></sdf>",
     ["size.sdf: world[w]/model[wall]/link[l]/collision[c]/geometry/box/size:",
      "expected 3 number(s), got '1 x 1'"]),
    ("negative", '<sdf version="1.7"><world name="w">' + box_model("wall", "0 0 0 0 0 0",
                                                                   "1 -1 1") + "</world></sdf>",
     ["geometry/box/size: must be positive"]),
    ("pose", '<sdf version="1.7"><world name="w">' + box_model("wall", "0 0 0", "1 1 1")
     + "</world></sdf>", ["model[wall]/pose: expected 6 number(s), got '0 0 0'"]),
])
def test_bad_sdf_gives_one_line_naming_file_element_and_problem(tmp_path, case, content,
                                                                 expected):
    sdf = tmp_path / f"{case}.sdf"
    sdf.write_text(content)
    result = run_script(sdf, tmp_path / "out.yaml")
    assert result.returncode == 1
    assert result.stderr.count("\n") == 1 and "Traceback" not in result.stderr
    for fragment in expected:
        assert fragment in result.stderr
    assert not (tmp_path / "out.yaml").exists()


def test_missing_sdf_file_gives_one_line(tmp_path):
    result = run_script(tmp_path / "absent.sdf", tmp_path / "out.yaml")
    assert result.returncode == 1
    assert result.stderr.strip() == f"{tmp_path / 'absent.sdf'}: file: cannot read " \
                                    "(No such file or directory)"


def test_bad_command_line_gives_one_line(tmp_path):
    result = run_script(LAB_SDF, tmp_path / "out.yaml", "--resolution", "fine")
    assert result.returncode != 0
    assert result.stderr.count("\n") == 1 and "--resolution" in result.stderr
    result = run_script(LAB_SDF, tmp_path / "out.yaml", "--resolution", "-0.05")
    assert result.returncode == 1
    assert result.stderr.strip().endswith("resolution: must be positive, got -0.05")
    result = run_script(LAB_SDF, tmp_path / "out.yaml", "--resolution", "0.001")   # more cells than a map may have
    assert result.returncode == 1
    assert result.stderr.strip() == (f"{LAB_SDF}: resolution: 0.001 m gives 8300 x 6300 cells, more than the "
                                     "25000000 a map may have")
    assert not (tmp_path / "out.yaml").exists()


def test_core_raises_sdf_error_for_an_sdf_without_geometry(tmp_path):
    sdf = write_sdf(tmp_path, '<model name="empty"><link name="l"/></model>')
    with pytest.raises(SdfError, match=r"world\.sdf: sdf: no collision geometry found"):
        sdf_to_occupancy_map(sdf, small_request())
