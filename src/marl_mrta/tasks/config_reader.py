"""Strict reading of the task-allocation YAML files (config/reward.yaml, config/task*.yaml).

Every value is read through a typed getter that knows where it came from, and at the end every
key of the file must have been read, so a typo is an error instead of a silently ignored line.
Errors are one line: file, key path, problem.
"""
from __future__ import annotations

import math
from pathlib import Path
from typing import Any, Dict, List, Optional, Union

from ..yaml_file import YamlFileError, load_yaml_file


class ConfigError(ValueError):
    """A bad configuration file or value; str(error) is one line naming file, key and problem."""


class ConfigSection:
    """One mapping of a YAML file; getters record which keys were used."""

    def __init__(self, data: Dict[str, Any], source: str, path: str = ""):
        if not isinstance(data, dict):
            raise ConfigError(f"{source}: {path or 'top level'}: expected a mapping, got {type(data).__name__}")
        self.data = data
        self.source = source
        self.path = path
        self.used: set = set()
        self.children: List["ConfigSection"] = []

    def _where(self, key: str) -> str:
        return f"{self.path}.{key}" if self.path else key

    def has(self, key: str) -> bool:
        return key in self.data

    def section(self, key: str) -> "ConfigSection":
        if key not in self.data:
            raise ConfigError(f"{self.source}: {self._where(key)}: missing section")
        self.used.add(key)
        child = ConfigSection(self.data[key], self.source, self._where(key))
        self.children.append(child)
        return child

    def number(self, key: str, default: Optional[float] = None, minimum: Optional[float] = None,
               maximum: Optional[float] = None) -> float:
        if key not in self.data:
            if default is None:
                raise ConfigError(f"{self.source}: {self._where(key)}: missing value")
            return float(default)
        self.used.add(key)
        value = self.data[key]
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(float(value)):
            raise ConfigError(f"{self.source}: {self._where(key)}: expected a finite number, got {value!r}")
        value = float(value)
        if minimum is not None and value < minimum:
            raise ConfigError(f"{self.source}: {self._where(key)}: {value} is below the minimum {minimum}")
        if maximum is not None and value > maximum:
            raise ConfigError(f"{self.source}: {self._where(key)}: {value} is above the maximum {maximum}")
        return value

    def boolean(self, key: str, default: Optional[bool] = None) -> bool:
        if key not in self.data:
            if default is None:
                raise ConfigError(f"{self.source}: {self._where(key)}: missing value")
            return default
        self.used.add(key)
        value = self.data[key]
        if not isinstance(value, bool):
            raise ConfigError(f"{self.source}: {self._where(key)}: expected true or false, got {value!r}")
        return value

    def choice(self, key: str, choices: List[str], default: Optional[str] = None) -> str:
        if key not in self.data:
            if default is None:
                raise ConfigError(f"{self.source}: {self._where(key)}: missing value")
            return default
        self.used.add(key)
        value = self.data[key]
        if value not in choices:
            raise ConfigError(f"{self.source}: {self._where(key)}: {value!r} is not one of {', '.join(choices)}")
        return str(value)

    def keys(self) -> List[str]:
        return list(self.data.keys())

    def check_all_used(self) -> None:
        """Raise on the first key nobody read (a typo or an option that does not exist)."""
        for key in self.data:
            if key not in self.used:
                raise ConfigError(f"{self.source}: {self._where(key)}: unknown key")
        for child in self.children:
            child.check_all_used()


def read_yaml(path: Union[str, Path]) -> ConfigSection:
    """The top-level mapping of a YAML file, as a strict section."""
    try:
        data = load_yaml_file(path)
    except YamlFileError as error:
        raise ConfigError(str(error)) from None
    return ConfigSection(data if data is not None else {}, str(path))


def package_root() -> Path:
    """The marl_mrta package directory (source checkout or installed share directory)."""
    checkout = Path(__file__).resolve().parents[3]   # <root>/src/marl_mrta/tasks/this file
    if (checkout / "package.xml").is_file():
        return checkout
    import rospkg  # an installed package: ask ROS where its share directory is
    return Path(rospkg.RosPack().get_path("marl_mrta"))


def default_config_path(name: str) -> Path:
    """config/<name> of the package."""
    return package_root() / "config" / name
