"""A map the package refuses is one line from each command-line tool, naming the file and the
field, and exit status 2 without a traceback: a mode that is not known, a palette PNG, a PNG cut
short or with a damaged chunk, a 16-bit PGM; through `evaluate --scenario`, `travel_table` and
`generate_scenarios --layout`."""
import struct
import subprocess
import sys
from pathlib import Path

import pytest

from marl_mrta.common.paths import package_root
from marl_mrta.model.occupancy_map import read_pgm

Image = pytest.importorskip("PIL.Image", reason="Pillow not installed (python3-pil)")

ROOT = package_root()


def with_idat_crc_flipped(data: bytes) -> bytes:
    at = data.index(b"IDAT")
    crc = at + 4 + struct.unpack(">I", data[at - 4:at])[0]
    return data[:crc] + bytes([data[crc] ^ 1]) + data[crc + 1:]


def bad_maps(folder: Path) -> dict:
    """name -> (map YAML, the line's text after the tool's own prefix)."""
    pixels = read_pgm(ROOT / "maps" / "lab.pgm")
    yaml = (ROOT / "maps" / "lab.yaml").read_text()
    Image.fromarray(pixels, "L").convert("P").save(folder / "palette.png")
    Image.fromarray(pixels, "L").save(folder / "grey.png")
    whole = (folder / "grey.png").read_bytes()
    (folder / "cut.png").write_bytes(whole[:len(whole) // 2])
    (folder / "damaged.png").write_bytes(with_idat_crc_flipped(whole))
    (folder / "deep.pgm").write_bytes(b"P5\n%d %d\n65535\n" % pixels.shape[::-1] + pixels.astype(">u2").tobytes())
    cases = {
        "bogus_mode": ("lab.pgm", "mode: bogus\n", "{yaml}: mode: 'bogus' is not one of trinary, scale, raw"),
        "palette": ("palette.png", "", "{image}: PNG: a palette image; map_server reads its palette indices as grey "
                                       "values, not its colours: save the map as greyscale or RGB"),
        "cut": ("cut.png", "", "{image}: PNG: file truncated"),
        "damaged": ("damaged.png", "", "{image}: PNG: IDAT: CRC error"),
        "deep": ("deep.pgm", "", "{image}: PGM header: maxval 65535: map_server reads PGMs of 8 bits or fewer "
                                 "(maxval 1 to 255)"),
    }
    (folder / "lab.pgm").write_bytes((ROOT / "maps" / "lab.pgm").read_bytes())
    maps = {}
    for name, (image, extra, line) in cases.items():
        path = folder / f"{name}.yaml"
        path.write_text(yaml.replace("image: lab.pgm", f"image: {image}") + extra)
        maps[name] = (path, line.format(yaml=path, image=folder / image))
    return maps


def run(tool: str, *args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, str(ROOT / "scripts" / tool), *args], capture_output=True, text=True,
                          timeout=120)


@pytest.fixture(scope="module")
def maps(tmp_path_factory):
    return bad_maps(tmp_path_factory.mktemp("bad_maps"))


@pytest.mark.parametrize("name", ["bogus_mode", "palette", "cut", "damaged", "deep"])
def test_a_bad_map_is_one_line_and_exit_2_from_each_tool(maps, name, tmp_path):
    map_yaml, line = maps[name]
    scenario = tmp_path / f"{name}.xml"
    scenario.write_text((ROOT / "scenarios" / "lab_2r.xml").read_text().replace('file="../maps/lab.yaml"',
                                                                                f'file="{map_yaml}"'))
    runs = {
        "travel_table": (run("travel_table", str(scenario)), f"travel_table: {scenario}: <map>: cannot load the map: "),
        "generate_scenarios": (run("generate_scenarios", str(tmp_path / "out"), "--count", "1", "--layout",
                                   str(map_yaml)), "generate_scenarios: layout: "),
    }
    if name == "bogus_mode":   # evaluate's start is the slowest: one map is enough for its wiring
        runs["evaluate"] = (run("evaluate", "--scenario", str(scenario), "--method", "random", "--episodes", "1"),
                            f"evaluate: {scenario}: <map>: cannot load the map: ")
    for tool, (done, prefix) in runs.items():
        assert done.returncode == 2, f"{tool}: {done.stderr}"
        assert done.stderr.splitlines() == [prefix + line], tool
        assert "Traceback" not in done.stdout + done.stderr
    assert not (tmp_path / "out").exists() or not any((tmp_path / "out").iterdir())
