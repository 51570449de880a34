"""tools/stock_nav.sh (make stock-nav): what `setup-file` tells `make build`, where the stock
navigation workspace may not live, and its one-line errors. Nothing is built here."""
import hashlib
import os
import subprocess
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
SCRIPT = REPO / "tools" / "stock_nav.sh"


def os_id():
    fields = dict(line.strip().split("=", 1) for line in Path("/etc/os-release").read_text().splitlines() if "=" in line)
    return "%s-%s" % (fields.get("ID", "").strip('"'), fields.get("VERSION_ID", "").strip('"'))


debian_only = pytest.mark.skipif(os_id() != "debian-12", reason="builds only on Debian 12 (Ubuntu uses the installed packages)")


def run(*args, **env):
    return subprocess.run(["bash", str(SCRIPT), *args], capture_output=True, text=True,
                          env={**os.environ, **env}, timeout=60)


def fake_clone(tmp_path):
    clone = tmp_path / "navigation"
    (clone / "move_base").mkdir(parents=True, exist_ok=True)
    (clone / "move_base" / "package.xml").write_text("<package/>")
    return clone


@debian_only
def test_setup_file_names_a_finished_build_only(tmp_path):
    clone = fake_clone(tmp_path)
    ws = tmp_path / "ws"
    assert run("setup-file", str(clone), STOCK_NAV_WS=str(ws)).stdout == ""  # not built
    (ws / "devel").mkdir(parents=True)
    (ws / "devel" / "setup.bash").write_text("")
    assert run("setup-file", str(clone), STOCK_NAV_WS=str(ws)).stdout == ""  # the build did not finish
    (ws / ".stock_nav_stamp").write_text("source=%s\n" % clone)
    assert run("setup-file", str(clone), STOCK_NAV_WS=str(ws)).stdout == str(ws / "devel" / "setup.bash") + "\n"
    assert run("setup-file", "", STOCK_NAV_WS=str(ws)).stdout == ""  # no source: no underlay
    assert run("setup-file", str(tmp_path / "missing"), STOCK_NAV_WS=str(ws)).stdout == ""


@debian_only
def test_default_workspace_is_in_the_cache_keyed_by_the_tarballs_content(tmp_path):
    env = {"XDG_CACHE_HOME": str(tmp_path / "cache"), "STOCK_NAV_WS": ""}
    tarball = tmp_path / "navigation.tar.gz"
    tarball.write_bytes(b"a tarball")
    key = hashlib.sha256(b"a tarball").hexdigest()[:12]
    ws = tmp_path / "cache" / "marl_mrta" / "stock_nav" / key
    (ws / "devel").mkdir(parents=True)
    (ws / "devel" / "setup.bash").write_text("")
    (ws / ".stock_nav_stamp").write_text("")
    assert run("setup-file", str(tarball), **env).stdout == str(ws / "devel" / "setup.bash") + "\n"
    tarball.write_bytes(b"another tarball")  # another source, another workspace (not built)
    assert run("setup-file", str(tarball), **env).stdout == ""


@debian_only
def test_errors_are_one_line_each(tmp_path):
    result = run("build", "")
    assert result.returncode == 1 and "no source" in result.stderr and "NAV_SRC" in result.stderr
    result = run("build", str(tmp_path / "missing"))
    assert result.returncode == 1
    assert result.stderr.strip() == "stock-nav: NAV_SRC=%s does not exist" % (tmp_path / "missing")
    result = run("build", str(tmp_path))
    assert result.returncode == 1 and "not a clone of ros-planning/navigation" in result.stderr
    inside = REPO / ".ws" / "stock_nav_test_ws"
    result = run("build", str(fake_clone(tmp_path)), STOCK_NAV_WS=str(inside))
    assert result.returncode == 1 and "inside the checkout or ../shared" in result.stderr
    assert not inside.exists()
    result = run("frobnicate", "x")
    assert result.returncode == 2 and result.stderr.startswith("usage:")


# The differential harness (bench_nav_vs_stock) without ROS: its legs, its comparison, its skip.
from marl_mrta.evaluation.nav_comparison import (LegRecord, LegRequest, LegTimings, LocalisationFigures,  # noqa: E402
                                                 compare_map, draw_legs, headline, is_stale_success, pose_at)
from marl_mrta.model.occupancy_map import load_map  # noqa: E402

LAB = REPO / "maps" / "lab.yaml"


def record(index, succeeded, t):
    return LegRecord(index=index, succeeded=succeeded, outcome="x", time=t, path_length=1.0)


def test_legs_are_seeded_apart_and_clear_of_obstacles():
    grid = load_map(LAB)
    legs = draw_legs(grid, LegRequest(count=6, seed=3))
    assert legs == draw_legs(grid, LegRequest(count=6, seed=3))
    assert legs != draw_legs(grid, LegRequest(count=6, seed=4))
    for leg in legs:
        assert 1.0 <= leg.straight_line <= 4.0
        for x, y, _ in (leg.start, leg.goal):  # every point within 0.3 m is free (clearance 0.35 m)
            assert all(grid.is_free(x + 0.3 * dx, y + 0.3 * dy) for dx in (-1, 0, 1) for dy in (-1, 0, 1))
        assert type(leg).from_list(leg.as_list()) == leg


def test_comparison_ratios_and_what_misses_the_goals():
    runs = {"builtin": [record(0, True, 10.0), record(1, True, 16.0), record(2, False, 60.0)],
            "stock": [record(0, True, 10.0), record(1, True, 10.0), record(2, True, 20.0)]}
    c = compare_map("m", 3, runs)
    assert c.ratios == [1.0, 1.6, None]
    assert c.stock_only == [2]
    assert c.success == {"builtin": 2 / 3, "stock": 1.0}
    assert c.median_ratio == pytest.approx(1.3) and c.max_ratio == pytest.approx(1.6)
    misses = c.misses()
    assert misses == ["m: leg 2: stock reached the goal more often than the built-in move_base",
                      "m: median time ratio 1.300 above 1.05", "m: leg 1: time ratio 1.600 above 1.5"]
    assert compare_map("m", 3, {"builtin": runs["stock"], "stock": runs["stock"]}).misses() == []
    figures = [row["figure"] for row in headline([c], {})]
    assert "m: time built-in / stock, max per leg" in figures
    with pytest.raises(ValueError):
        compare_map("m", 3, {"builtin": runs["builtin"][:2], "stock": runs["stock"]})


def test_leg_record_round_trips_through_json_form():
    r = LegRecord(index=1, succeeded=True, outcome="ok", time=3.0, path_length=2.0,
                  localisation=LocalisationFigures(4, 0.01, 0.02, 0.03, 0.04), filter_cpu=0.1, filter_updates=4)
    assert LegRecord.from_dict(r.to_dict()) == r
    assert LegTimings().goal_timeout == 120.0


def test_bench_has_the_pillar_leg_first_and_skips_in_one_line_without_stock(monkeypatch, capsys):
    bench = pytest.importorskip("marl_mrta.apps.bench_nav_vs_stock")
    maps = bench.map_files()
    assert maps["lab"] == LAB
    if "tb3_world" in maps:
        legs = bench.legs_of("tb3_world", maps["tb3_world"], 3, 0)
        assert legs[0] == bench.FIXED_LEGS["tb3_world"][0] and len(legs) == 3
    monkeypatch.setattr(bench, "stock_available", lambda: False)
    assert bench.main(["--out", "/nonexistent/dir"]) == 0
    out = capsys.readouterr().out.strip().splitlines()
    assert out == ["bench_nav_vs_stock: skipped: stock navigation not available (no move_base/amcl package; make stock-nav)"]


def test_stale_success_is_a_quick_success_away_from_the_goal():
    # ros-planning/navigation#949: the previous goal's plan taken for the new goal.
    assert is_stale_success(True, 0.0, 1.8)
    assert not is_stale_success(True, 0.0, 0.03)     # already there: a real success
    assert not is_stale_success(True, 12.0, 1.8)     # drove, then stopped short: counted as it is
    assert not is_stale_success(False, 0.0, 1.8)
    assert not is_stale_success(True, 0.0, None)
    track = [(0.0, 1.0, 2.0, 0.1), (0.05, 1.1, 2.0, 0.1)]
    assert pose_at(track, 0.04) == (1.0, 2.0, 0.1) and pose_at(track, 1.0) == (1.1, 2.0, 0.1)
    assert pose_at(track, -1.0) is None
