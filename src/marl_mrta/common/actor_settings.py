"""An actor file's settings read without torch: what launch files need to know of a policy (its
action masks, its decision mode) while roslaunch runs on a Python that may not have torch.

A torch file is a zip archive whose `data.pkl` pickles the saved dictionary; its tensors are
stored apart and referenced by persistent ids. The reader below unpickles that dictionary with
every tensor left out, and refuses any class other than torch's own rebuild functions and plain
containers (a pickle is code: nothing else is imported).
"""
from __future__ import annotations

import pickle
import zipfile
from pathlib import Path
from typing import Any, Dict, Union

#: The shipped actors (policies/<name>.pt), named in place of a path.
SHIPPED_POLICIES = ("generalist",)
_ALLOWED = {("collections", "OrderedDict")}


class _Skipped:
    """Stands for a tensor or a torch object: its value is not needed here."""

    def __init__(self, *_args: Any, **_kwargs: Any) -> None:
        pass

    def __setstate__(self, _state: Any) -> None:
        pass


class _SettingsUnpickler(pickle.Unpickler):
    def find_class(self, module: str, name: str) -> Any:
        if module == "torch" or module.startswith("torch."):
            return _Skipped
        if (module, name) in _ALLOWED:
            import collections
            return collections.OrderedDict
        raise pickle.UnpicklingError(f"{module}.{name}: not in an actor file")

    def persistent_load(self, _pid: Any) -> Any:
        return None


def actor_path(policy: Union[str, Path], package: Path) -> Path:
    """The file an actor reference names: a shipped policy's name, or a path."""
    return package / "policies" / f"{policy}.pt" if str(policy) in SHIPPED_POLICIES else Path(policy)


def read_actor_settings(path: Union[str, Path]) -> Dict[str, Any]:
    """The `settings` of an actor file (or of a training checkpoint's embedded actor). ValueError
    with one line for a file that is not one."""
    path = Path(path)
    try:
        with zipfile.ZipFile(path) as archive:
            name = next((n for n in archive.namelist() if n.endswith("/data.pkl") or n == "data.pkl"), None)
            if name is None:
                raise ValueError(f"{path}: not an actor file (no data.pkl)")
            data = _SettingsUnpickler(archive.open(name)).load()
    except FileNotFoundError:
        raise ValueError(f"{path}: no such file") from None
    except (zipfile.BadZipFile, pickle.UnpicklingError, EOFError, IsADirectoryError) as error:
        raise ValueError(f"{path}: not a readable actor file ({error})") from None
    if isinstance(data, dict) and "actor_file" in data:
        data = data["actor_file"]
    if not isinstance(data, dict) or not isinstance(data.get("settings"), dict):
        raise ValueError(f"{path}: not an actor file (no settings)")
    return dict(data["settings"])
