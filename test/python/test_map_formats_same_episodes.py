"""The same floor as PGM and as PNG is the same map to the package: the lab's map converted to a
grey PNG, an RGB PNG, a 16-bit grey PNG and a plain PGM gives the same grid to both readers, the
same travel table (navigation's paths and times) and the same embedded episodes, noise included;
`evaluate` plans and plays the same episodes on it."""
import json
from pathlib import Path

import numpy as np
import pytest

from marl_mrta.apps.evaluate import main as evaluate
from marl_mrta.baselines.random_policy import RandomPolicy
from marl_mrta.common.paths import package_root
from marl_mrta.env.factory import make_env, scenario_travel_table
from marl_mrta.evaluation.loop import run_episodes
from marl_mrta.model.navfn_paths import read_map_native
from marl_mrta.model.occupancy_map import load_map, read_pgm
from marl_mrta.model.scenario import load_scenario

Image = pytest.importorskip("PIL.Image", reason="Pillow not installed (python3-pil)")

ROOT = package_root()
LAB_YAML = ROOT / "maps" / "lab.yaml"


def converted(folder: Path) -> dict:
    """lab.yaml's map as other images beside YAML files with the same keys."""
    pixels = read_pgm(ROOT / "maps" / "lab.pgm")
    Image.fromarray(pixels, "L").save(folder / "grey.png")
    Image.fromarray(np.stack([pixels] * 3, axis=2), "RGB").save(folder / "rgb.png")
    Image.fromarray(pixels.astype(np.uint16) * 257, "I;16").save(folder / "grey16.png")
    (folder / "plain.pgm").write_text(f"P2\n{pixels.shape[1]} {pixels.shape[0]}\n255\n"
                                      + "\n".join(" ".join(map(str, row)) for row in pixels) + "\n")
    yaml = LAB_YAML.read_text()
    maps = {}
    for image in ("grey.png", "rgb.png", "grey16.png", "plain.pgm"):
        path = folder / f"lab_{image.replace('.', '_')}.yaml"
        path.write_text(yaml.replace("image: lab.pgm", f"image: {image}"))
        maps[image] = path
    return maps


def scenario_on(folder: Path, map_yaml: Path) -> Path:
    """scenarios/lab_2r.xml on another map file."""
    text = (ROOT / "scenarios" / "lab_2r.xml").read_text().replace('file="../maps/lab.yaml"', f'file="{map_yaml}"')
    path = folder / f"{map_yaml.stem}.xml"
    path.write_text(text)
    return path


def test_the_lab_as_pgm_and_as_png_gives_the_same_episodes(tmp_path):
    reference = load_scenario(ROOT / "scenarios" / "lab_2r.xml")
    reference_table = scenario_travel_table(reference)
    env = make_env(reference, profile="measured_tb3")
    reference_episodes = run_episodes(env, RandomPolicy(env.n_agents, env.n_tasks, "unfinished", seed=3), 3, seed=3)
    grid = load_map(LAB_YAML).grid
    for image, map_yaml in converted(tmp_path).items():
        assert np.array_equal(load_map(map_yaml).grid, grid), image
        assert np.array_equal(read_map_native(map_yaml), grid), image
        scenario = load_scenario(scenario_on(tmp_path, map_yaml))
        table = scenario_travel_table(scenario)
        assert np.array_equal(table.nominal_time, reference_table.nominal_time), image
        assert all(np.array_equal(a, b) for row, ref_row in zip(table.paths, reference_table.paths)
                   for a, b in zip(row, ref_row)), image
        env = make_env(scenario, profile="measured_tb3")
        episodes = run_episodes(env, RandomPolicy(env.n_agents, env.n_tasks, "unfinished", seed=3), 3, seed=3)
        assert episodes == reference_episodes, image


def test_evaluate_plans_and_plays_the_same_episodes_on_the_png(tmp_path):
    png_scenario = scenario_on(tmp_path, converted(tmp_path)["grey.png"])
    runs = []
    for scenario in (ROOT / "scenarios" / "lab_2r.xml", png_scenario):
        out = tmp_path / f"{scenario.stem}.json"
        assert evaluate(["--method", "auction", "--scenario", str(scenario), "--episodes", "2", "--no-exact",
                         "--seed", "3", "--out", str(out), "--quiet"]) == 0
        result = json.loads(out.read_text())["results"][0]
        runs.append((result["plan"], result["episodes"], result["representative_episode"]))
    assert runs[0] == runs[1]
