"""An actor file's settings are read without torch (common/actor_settings.py), so that launch files
give the task manager the action masks the policy was trained with, and nothing in a foreign pickle
is imported."""
import io
import pickle
import zipfile

import pytest

from marl_mrta.common.actor_settings import read_actor_settings
from marl_mrta.mappo.policy import read_actor_file
from marl_mrta.ros.launch_args import policy_mask


def test_the_settings_read_without_torch_are_the_ones_torch_reads():
    path, data = read_actor_file("generalist")
    assert read_actor_settings(path) == data["settings"]
    assert policy_mask("generalist") == data["settings"]["action_mask"]


def test_a_planner_or_an_unreadable_file_gets_the_default_masks(tmp_path):
    assert policy_mask("generalist", method="exact") == "logic"
    assert policy_mask("") == "logic"
    (tmp_path / "x.pt").write_text("not an actor")
    assert policy_mask(str(tmp_path / "x.pt")) == "logic"
    with pytest.raises(ValueError, match="x.pt: not a readable actor file"):
        read_actor_settings(tmp_path / "x.pt")


class Foreign:
    pass


def test_a_pickle_naming_another_class_is_refused(tmp_path):
    path = tmp_path / "foreign.pt"
    with zipfile.ZipFile(path, "w") as archive:
        buffer = io.BytesIO()
        pickle.dump({"settings": {"action_mask": "logic"}, "x": Foreign()}, buffer)
        archive.writestr("archive/data.pkl", buffer.getvalue())
    with pytest.raises(ValueError, match="not in an actor file"):
        read_actor_settings(path)
