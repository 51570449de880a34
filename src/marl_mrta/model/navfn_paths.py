"""navfn's paths between every pair of poses, from the C++ navigation core (ROS-free).

libmarl_mrta_travel.so (src/nav/travel_c_api.cpp, a C ABI) builds move_base's global costmap
from the map file and the navigation's parameter files, and plans with the navfn core that
move_base runs: the embedded travel times come from the planner navigation uses, not from a
second implementation of it. The library is a product of the package's build; the workspace's
setup.bash puts its directory on LD_LIBRARY_PATH. read_map_native gives a map's grid as that C++
side reads it, to hold it to model/occupancy_map.py's reader.
"""
from __future__ import annotations

import ctypes
import os
from pathlib import Path
from typing import List, NamedTuple, Optional, Sequence, Tuple

import numpy as np

from marl_mrta.common.config import ConfigError
from marl_mrta.model.occupancy_map import MapFileError

LIBRARY_NAME = "libmarl_mrta_travel.so"
_ERROR_SIZE = 1024


class PlanningError(ValueError):
    """Planning failed; `pose` is the index of the pose at fault, or -1 for a map or parameter error."""

    def __init__(self, pose: int, message: str):
        super().__init__(message)
        self.pose = pose


class LibraryMissing(ConfigError):
    """The package's C++ library is not built or not on the library path (an installation
    problem, reported in one line as a configuration error is)."""


class NavfnPlans(NamedTuple):
    paths: List[List[Optional[np.ndarray]]]   # paths[a][b]: (k, 2) x, y [m] (None for a == b)
    max_speed: float                          # m/s, the fastest the local planner drives (DWA)


_library: Optional[ctypes.CDLL] = None


def _candidates() -> List[str]:
    # dlopen searches LD_LIBRARY_PATH (set by devel/ or install/setup.bash); the catkin prefixes
    # cover a shell where only CMAKE_PREFIX_PATH was kept.
    prefixes = [p for p in os.environ.get("CMAKE_PREFIX_PATH", "").split(os.pathsep) if p]
    return [LIBRARY_NAME] + [str(Path(prefix) / "lib" / LIBRARY_NAME) for prefix in prefixes]


def _load() -> ctypes.CDLL:
    global _library
    if _library is not None:
        return _library
    for candidate in _candidates():
        try:
            library = ctypes.CDLL(candidate)
            break
        except OSError:
            continue
    else:
        raise LibraryMissing(f"{LIBRARY_NAME} not found: build the package (make build) and source its "
                             "workspace's devel/setup.bash")
    library.marl_mrta_travel_plan.restype = ctypes.c_void_p
    library.marl_mrta_travel_plan.argtypes = [ctypes.c_char_p, ctypes.c_char_p, ctypes.c_int,
                                              ctypes.POINTER(ctypes.c_double), ctypes.c_char_p, ctypes.c_int,
                                              ctypes.POINTER(ctypes.c_int)]
    library.marl_mrta_travel_path_size.restype = ctypes.c_int
    library.marl_mrta_travel_path_size.argtypes = [ctypes.c_void_p, ctypes.c_int, ctypes.c_int]
    library.marl_mrta_travel_path.restype = None
    library.marl_mrta_travel_path.argtypes = [ctypes.c_void_p, ctypes.c_int, ctypes.c_int,
                                              ctypes.POINTER(ctypes.c_double)]
    library.marl_mrta_travel_max_speed.restype = ctypes.c_double
    library.marl_mrta_travel_max_speed.argtypes = [ctypes.c_void_p]
    library.marl_mrta_travel_free.restype = None
    library.marl_mrta_travel_free.argtypes = [ctypes.c_void_p]
    library.marl_mrta_map_read.restype = ctypes.c_int
    library.marl_mrta_map_read.argtypes = [ctypes.c_char_p, ctypes.POINTER(ctypes.c_byte), ctypes.c_int,
                                           ctypes.POINTER(ctypes.c_int), ctypes.POINTER(ctypes.c_int),
                                           ctypes.c_char_p, ctypes.c_int]
    _library = library
    return library


def plan_all_pairs(map_yaml: str, nav_config_dir: str,
                   poses: Sequence[Tuple[float, float, float]]) -> NavfnPlans:
    """paths[a][b]: navfn's path a -> b as (k, 2) x, y [m] in the map frame (None for a == b),
    from the corner of a's cell, where navfn places its points, to b; with the local planner's
    top speed from the same files. PlanningError when a pose cannot be planned from or to, or
    the map or a parameter file is bad."""
    library = _load()
    n = len(poses)
    flat = (ctypes.c_double * (3 * n))(*[float(v) for pose in poses for v in pose])
    error = ctypes.create_string_buffer(_ERROR_SIZE)
    failed = ctypes.c_int(-1)
    handle = library.marl_mrta_travel_plan(str(map_yaml).encode(), str(nav_config_dir).encode(), n, flat,
                                           error, _ERROR_SIZE, ctypes.byref(failed))
    if not handle:
        raise PlanningError(failed.value, error.value.decode(errors="replace"))
    try:
        paths: List[List[Optional[np.ndarray]]] = [[None] * n for _ in range(n)]
        for a in range(n):
            for b in range(n):
                size = library.marl_mrta_travel_path_size(handle, a, b)
                if a == b or size == 0:
                    continue
                buffer = (ctypes.c_double * (2 * size))()
                library.marl_mrta_travel_path(handle, a, b, buffer)
                paths[a][b] = np.frombuffer(buffer, dtype=np.float64).reshape(size, 2).copy()
        return NavfnPlans(paths, library.marl_mrta_travel_max_speed(handle))
    finally:
        library.marl_mrta_travel_free(handle)


def read_map_native(map_yaml: str) -> np.ndarray:
    """The grid of a map_server map as the C++ reader reads it (the simulator's, navigation's and
    the travel planning's), int8 (rows, cols) with row 0 the lowest, as OccupancyMap.grid: for
    holding the two readers to one rule. MapFileError (its one line) on a bad map."""
    library = _load()
    error = ctypes.create_string_buffer(_ERROR_SIZE)
    width, height = ctypes.c_int(0), ctypes.c_int(0)
    cells = library.marl_mrta_map_read(str(map_yaml).encode(), None, 0, ctypes.byref(width), ctypes.byref(height),
                                       error, _ERROR_SIZE)
    if cells >= 0:
        data = (ctypes.c_byte * max(cells, 1))()
        cells = library.marl_mrta_map_read(str(map_yaml).encode(), data, cells, ctypes.byref(width),
                                           ctypes.byref(height), error, _ERROR_SIZE)
    if cells < 0:
        raise MapFileError(error.value.decode(errors="replace"))
    return np.frombuffer(data, dtype=np.int8, count=cells).reshape(height.value, width.value).copy()
