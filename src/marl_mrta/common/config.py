"""The one strict reader of the package's settings: YAML files, MAPPO presets, node parameters.

Every value is read through a typed getter that knows where it came from; at the end every key
must have been read (`check_all_used`), so a typo is an error instead of a silently ignored
line. Every error is a ConfigError whose text is one line naming the source (file or node),
the key and the problem:

    config/reward.yaml: logic.typo: unknown key
    /rl_task_allocation_manager/arena: must be >= 0, got -1
"""
from __future__ import annotations

import difflib
import math
from pathlib import Path
from typing import Any, Dict, List, Optional, Sequence, Union

from marl_mrta.common.yaml_file import YamlFileError, load_yaml_file


class ConfigError(ValueError):
    """A bad configuration file, parameter or value; str(error) is one line naming source, key and problem."""


#: Marks a getter's key as required (there is no default).
REQUIRED: Any = object()


class ConfigSection:
    """One mapping of a settings source; the getters record which keys were used.

    source: the file (messages "<file>: <key path>: <problem>") or, with `separator="/"`, a node
    namespace (messages "<namespace>/<key>: <problem>"). noun: what a key is called in the
    "unknown ..." message (key, setting, parameter).
    """

    def __init__(self, data: Any, source: str, path: str = "", separator: str = ": ", noun: str = "key"):
        self.source = source
        self.path = path
        self.separator = separator
        self.noun = noun
        if not isinstance(data, dict):
            kind = "setting names to values" if noun == "setting" else "keys to values"
            raise self._error(path or "", f"expected a mapping of {kind}, got {type(data).__name__}")
        self.data = data
        self.used: set = set()
        self.children: List["ConfigSection"] = []

    # ------------------------------------------------------------------ messages
    def where(self, key: str) -> str:
        return f"{self.path}.{key}" if self.path else key

    def location(self, key: str) -> str:
        """Where `key` of this section was given: "<file>: <key path>" or "<namespace>/<key>"."""
        return f"{self.source}{self.separator}{self.where(key)}"

    def _error(self, where: str, problem: str) -> ConfigError:
        if not where:
            return ConfigError(f"{self.source}: {problem}")
        return ConfigError(f"{self.source}{self.separator}{where}: {problem}")

    def fail(self, key: str, problem: str) -> ConfigError:
        """A ConfigError about `key` of this section (for checks the getters do not make)."""
        return self._error(self.where(key), problem)

    # ------------------------------------------------------------------ structure
    def has(self, key: str) -> bool:
        return key in self.data

    def keys(self) -> List[str]:
        return list(self.data.keys())

    def _take(self, key: str, default: Any) -> Any:
        """The raw value (marked used), `default` when absent; a missing required key fails."""
        if key not in self.data:
            if default is REQUIRED:
                raise self.fail(key, "missing value")
            return default
        self.used.add(key)
        return self.data[key]

    def section(self, key: str, required: bool = True) -> "ConfigSection":
        """The mapping under `key` (an empty one when absent and not required)."""
        if key not in self.data:
            if required:
                raise self.fail(key, "missing section")
            value: Any = {}
        else:
            self.used.add(key)
            value = self.data[key]
        if not isinstance(value, dict):
            raise self.fail(key, f"expected a mapping, got {value!r}")
        child = ConfigSection(value, self.source, self.where(key), self.separator, self.noun)
        self.children.append(child)
        return child

    def raw(self, key: str, default: Any = REQUIRED) -> Any:
        """The value as it stands (for values a getter of its own checks)."""
        return self._take(key, default)

    # ------------------------------------------------------------------ typed getters
    def number(self, key: str, default: Any = REQUIRED, minimum: Optional[float] = None,
               maximum: Optional[float] = None, above: Optional[float] = None) -> float:
        """A finite number in [minimum, maximum], strictly greater than `above` when given."""
        value = self._take(key, default)
        if value is default and key not in self.data:
            return float(value)
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise self.fail(key, f"expected a number, got {value!r}")
        value = float(value)
        if not math.isfinite(value):
            raise self.fail(key, f"expected a finite number, got {value!r}")
        self._check_range(key, value, minimum, maximum, above)
        return value

    def integer(self, key: str, default: Any = REQUIRED, minimum: Optional[int] = None,
                maximum: Optional[int] = None) -> int:
        value = self._take(key, default)
        if value is default and key not in self.data:
            return int(value)
        if isinstance(value, bool) or not isinstance(value, int):
            raise self.fail(key, f"expected an integer, got {value!r}")
        self._check_range(key, value, minimum, maximum, None)
        return value

    def boolean(self, key: str, default: Any = REQUIRED) -> bool:
        value = self._take(key, default)
        if not isinstance(value, bool):
            raise self.fail(key, f"expected true or false, got {value!r}")
        return value

    def string(self, key: str, default: Any = REQUIRED, allow_empty: bool = True) -> str:
        value = self._take(key, default)
        if not isinstance(value, str):
            raise self.fail(key, f"expected a string, got {value!r}")
        if not allow_empty and not value:
            raise self.fail(key, "expected a non-empty string, got ''")
        return value

    def choice(self, key: str, choices: Sequence[str], default: Any = REQUIRED) -> str:
        value = self._take(key, default)
        if value not in choices:
            raise self.fail(key, f"{value!r} is not one of {', '.join(choices)}")
        return str(value)

    def _check_range(self, key: str, value: float, minimum, maximum, above) -> None:
        if above is not None and not value > above:
            raise self.fail(key, f"must be > {above}, got {value!r}")
        if minimum is not None and value < minimum:
            raise self.fail(key, f"must be >= {minimum}, got {value!r}")
        if maximum is not None and value > maximum:
            raise self.fail(key, f"must be <= {maximum}, got {value!r}")

    # ------------------------------------------------------------------ completeness
    def check_all_used(self, known: Optional[Sequence[str]] = None) -> None:
        """Raise on the first key nobody read (a typo, or an option that does not exist).
        known: the names that exist here, for a "did you mean" hint."""
        for key in self.data:
            if key not in self.used:
                hint = ""
                if known is not None:
                    close = difflib.get_close_matches(str(key), list(known), n=1)
                    hint = f" (did you mean {close[0]}?)" if close else f" (known: {', '.join(sorted(known))})"
                raise self.fail(str(key), f"unknown {self.noun}{hint}")
        for child in self.children:
            child.check_all_used()


def read_yaml(path: Union[str, Path], noun: str = "key") -> ConfigSection:
    """The top-level mapping of a YAML file (an empty file is an empty mapping), as a strict section."""
    try:
        data = load_yaml_file(path)
    except YamlFileError as error:
        raise ConfigError(str(error)) from None
    return ConfigSection(data if data is not None else {}, str(path), noun=noun)


def node_parameters(values: Dict[str, Any], namespace: str) -> ConfigSection:
    """A node's private parameters as a strict section ("<namespace>/<name>: <problem>")."""
    return ConfigSection(dict(values), namespace.rstrip("/"), separator="/", noun="parameter")
