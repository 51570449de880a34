"""Reading a user's YAML file with a one-line error: `<file>: line N: <problem>`.

Every reader of the package's YAML inputs (maps, task and reward settings, MAPPO presets) goes
through `load_yaml_file`, so that a typo gives the same kind of message whichever file it is in.
"""
from __future__ import annotations

from pathlib import Path
from typing import Any, Union

import yaml


class YamlFileError(ValueError):
    """A YAML file cannot be read or parsed; str(error) is one line naming the file."""


def load_yaml_file(path: Union[str, Path]) -> Any:
    """The parsed content of `path` (None for an empty file)."""
    path = Path(path)
    try:
        text = path.read_text()
    except OSError as error:
        raise YamlFileError(f"{path}: cannot read ({error.strerror})") from None
    try:
        return yaml.safe_load(text)
    except yaml.YAMLError as error:
        mark = getattr(error, "problem_mark", None)
        where = f"line {mark.line + 1}" if mark is not None else "YAML"
        problem = getattr(error, "problem", None) or str(error).splitlines()[0]
        raise YamlFileError(f"{path}: {where}: {problem}") from None
