"""The paper's synchronous mode is unchanged by event mode: the episodes of the labs and site_8r
under random, GA, auction and exact policies, with and without noise and the hold, give the same
episode documents and the same outputs at every step, to the bit, as before event mode existed
(test/data/sync_golden/episodes.json, written by make_golden.py from that code)."""
import importlib.util
import json
from pathlib import Path

import pytest

GOLDEN = Path(__file__).resolve().parents[1] / "data" / "sync_golden"


@pytest.mark.slow
def test_synchronous_episodes_are_identical_to_the_bit(tmp_path):
    spec = importlib.util.spec_from_file_location("make_golden", GOLDEN / "make_golden.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    module.main(str(tmp_path / "now.json"))
    expected = json.loads((GOLDEN / "episodes.json").read_text())
    now = json.loads((tmp_path / "now.json").read_text())
    assert sorted(now) == sorted(expected)
    differing = [key for key in expected if now[key] != expected[key]]
    assert not differing, f"synchronous episodes changed: {differing[:5]}"
