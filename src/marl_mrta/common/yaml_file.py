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


def read_input_file(path: Path, error: type, where: str = "") -> bytes:
    """The bytes of a user's input file; `error` (an exception class) with one line
    "<file>: [<where>: ]cannot read (<reason>)" when it cannot be read."""
    try:
        return path.read_bytes()
    except OSError as problem:
        raise error(f"{path}: {where + ': ' if where else ''}cannot read ({problem.strerror})") from None


def load_yaml_file(path: Union[str, Path]) -> Any:
    """The parsed content of `path` (None for an empty file)."""
    path = Path(path)
    text = read_input_file(path, YamlFileError)
    try:
        return yaml.safe_load(text)
    except yaml.YAMLError as error:
        mark = getattr(error, "problem_mark", None)
        where = f"line {mark.line + 1}" if mark is not None else "YAML"
        problem = getattr(error, "problem", None) or str(error).splitlines()[0]
        raise YamlFileError(f"{path}: {where}: {problem}") from None
