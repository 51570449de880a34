"""Occupancy maps in map_server's format (YAML + PGM or PNG), without ROS.

``load_map(yaml_path)`` reads a map exactly as map_server does and returns an
``OccupancyMap``; ``save_map(occupancy_map, yaml_path)`` writes one as map_saver does.

Reading follows map_server (Noetic ``image_loader.cpp``):

* YAML keys ``image`` (relative to the YAML file's folder), ``resolution`` (m/cell),
  ``origin`` ``[x, y, yaw]`` (world pose of the lower-left corner of cell (0, 0)), ``negate``,
  ``occupied_thresh``, ``free_thresh`` (all required) and ``mode`` (``trinary`` default,
  ``scale``, ``raw``).
* A pixel value ``p`` (0..255) gives ``occ = (255 - p) / 255``, with ``p`` replaced by
  ``255 - p`` when ``negate`` is set; ``occ > occupied_thresh`` -> 100,
  ``occ < free_thresh`` -> 0, otherwise -1 (``scale`` mode: ``1 + 98 * ratio`` in between;
  ``raw`` mode: the pixel value itself, as a signed byte).
* The image is a PGM (P5 or P2, maxval up to 255, a smaller one scaled to 0..255) or a PNG
  (grey, grey + alpha, RGB or RGBA; 16-bit samples keep their high byte), as map_server's image
  loader, SDL_image over libpng, hands them over. In colour, ``p`` is the mean of the channels,
  alpha included in ``trinary`` mode; in ``scale`` mode a pixel of alpha 0 between the
  thresholds is unknown, and map_server reads an RGB pixel's blue as its alpha. Grey + alpha
  counts as RGBA; a grey PNG's transparent grey (tRNS) becomes an alpha channel, averaged in. A
  palette PNG is refused: map_server would read its palette indices as grey values. A file
  libpng refuses (a critical chunk with a bad CRC, cut short) is refused.
* ``scale`` mode with equal thresholds gives a pixel exactly on them 0, as map_server does.
* Grid row 0 is the BOTTOM row of the image, so ``grid[row, col]`` has y growing with row,
  the layout of ``nav_msgs/OccupancyGrid.data`` (index ``row * width + col``).

Example::

    m = load_map("maps/lab.yaml")
    cell = m.world_to_cell(1.75, 1.5)          # GridCell(col=45, row=40)
    m.grid[cell.row, cell.col] == OCCUPIED     # a column of the lab
    m.cell_to_world(cell.col, cell.row)        # WorldPoint(x=1.775, y=1.525), the cell centre
    m.is_free(0.5, 0.5)                        # True: a start pose
"""
from __future__ import annotations

import io
import math
import struct
import zlib
from dataclasses import dataclass
from pathlib import Path
from typing import NamedTuple, Optional, Tuple, Union

import numpy as np
from scipy import ndimage
from marl_mrta.common.yaml_file import YamlFileError, load_yaml_file

OCCUPIED = 100
FREE = 0
UNKNOWN = -1

# map_saver's pixel values for the three trinary states.
PIXEL_OCCUPIED = 0
PIXEL_FREE = 254
PIXEL_UNKNOWN = 205

DEFAULT_OCCUPIED_THRESH = 0.65
DEFAULT_FREE_THRESH = 0.196

MAP_MODES = ("trinary", "scale", "raw")
#: The most cells a map may have: a 250 m square at 0.05 m. Every robot's move_base holds costmaps
#: and planner arrays of the map's size (about 17 bytes a cell), so 16 robots need some 7 GB at
#: this size; a larger image (often a resolution typed too fine) is refused before it is read.
#: include/marl_mrta/map/occupancy_map.h's kMaxMapCells is the same number (a test compares them).
MAX_MAP_CELLS = 25_000_000
_REQUIRED_KEYS = ("image", "resolution", "origin", "negate", "occupied_thresh", "free_thresh")

PathLike = Union[str, Path]


class MapFileError(ValueError):
    """A map file is missing or invalid. The message is one line: file, field, problem."""


class GridCell(NamedTuple):
    """Index of a map cell: column (along the map's x axis) and row (along its y axis)."""

    col: int
    row: int


class WorldPoint(NamedTuple):
    """A point in the map frame, in metres."""

    x: float
    y: float


@dataclass(frozen=True)
class MapOrigin:
    """World pose of the lower-left corner of cell (0, 0): metres and radians."""

    x: float
    y: float
    yaw: float = 0.0


@dataclass
class OccupancyMap:
    """A map_server map. ``grid[row, col]`` is int8 OCCUPIED (100), FREE (0) or UNKNOWN (-1)
    (other values only in ``scale``/``raw`` mode); row 0 is the lowest y."""

    grid: np.ndarray
    resolution: float
    origin: MapOrigin

    @property
    def width(self) -> int:
        """Number of columns (cells along x)."""
        return int(self.grid.shape[1])

    @property
    def height(self) -> int:
        """Number of rows (cells along y)."""
        return int(self.grid.shape[0])

    def contains_cell(self, col: int, row: int) -> bool:
        """Whether (col, row) is a cell of the map."""
        return 0 <= col < self.width and 0 <= row < self.height

    def world_to_cell(self, x: float, y: float) -> Optional[GridCell]:
        """The cell containing world point (x, y), or None outside the map.
        A point on a cell border belongs to the cell above/right of it (floor)."""
        along_x, along_y = self._in_cells(x, y)
        col, row = math.floor(along_x), math.floor(along_y)
        if not self.contains_cell(col, row):
            return None
        return GridCell(col, row)

    def world_to_cells(self, xs: np.ndarray, ys: np.ndarray) -> Tuple[np.ndarray, np.ndarray, np.ndarray]:
        """world_to_cell for arrays of points: columns, rows, and whether each point is on the map."""
        along_x, along_y = self._in_cells(xs, ys)
        cols, rows = np.floor(along_x).astype(int), np.floor(along_y).astype(int)
        return cols, rows, (cols >= 0) & (cols < self.width) & (rows >= 0) & (rows < self.height)

    def _in_cells(self, x, y):
        """World point(s) in the map's own axes, in cells (floats or numpy arrays)."""
        dx, dy = x - self.origin.x, y - self.origin.y
        cos_yaw, sin_yaw = math.cos(self.origin.yaw), math.sin(self.origin.yaw)
        # Rotate into the map's own axes (map_server maps may carry an origin yaw).
        return (cos_yaw * dx + sin_yaw * dy) / self.resolution, (-sin_yaw * dx + cos_yaw * dy) / self.resolution

    def cell_to_world(self, col: int, row: int) -> WorldPoint:
        """World coordinates of the centre of cell (col, row) (not checked against the bounds);
        numpy arrays of columns and rows give arrays."""
        map_x = (col + 0.5) * self.resolution
        map_y = (row + 0.5) * self.resolution
        cos_yaw, sin_yaw = math.cos(self.origin.yaw), math.sin(self.origin.yaw)
        return WorldPoint(self.origin.x + cos_yaw * map_x - sin_yaw * map_y,
                          self.origin.y + sin_yaw * map_x + cos_yaw * map_y)

    def clearance(self) -> np.ndarray:
        """Per cell, metres from its centre to the nearest centre of a cell that is not FREE (0 on
        those; unknown cells count as obstacles, as a robot cannot know what is there)."""
        return ndimage.distance_transform_edt(self.grid == FREE) * self.resolution

    def value_at(self, x: float, y: float) -> int:
        """Grid value at world point (x, y); UNKNOWN outside the map."""
        cell = self.world_to_cell(x, y)
        if cell is None:
            return UNKNOWN
        return int(self.grid[cell.row, cell.col])

    def is_free(self, x: float, y: float) -> bool:
        """Whether world point (x, y) lies in a FREE cell (False outside the map)."""
        return self.value_at(x, y) == FREE


# ---------------------------------------------------------------- reading


def load_map(yaml_path: PathLike) -> OccupancyMap:
    """Load a map_server map. Raises MapFileError (one line: file, field, problem)."""
    yaml_path = Path(yaml_path)
    config = _read_yaml(yaml_path)
    missing = [key for key in _REQUIRED_KEYS if key not in config]
    if missing:
        raise MapFileError(f"{yaml_path}: {missing[0]}: missing")
    unknown = sorted(set(config) - set(_REQUIRED_KEYS) - {"mode"})
    if unknown:
        raise MapFileError(f"{yaml_path}: {unknown[0]}: unknown key")

    resolution = _number(yaml_path, config, "resolution")
    if not resolution > 0.0:
        raise MapFileError(f"{yaml_path}: resolution: must be positive, got {resolution}")
    origin = _origin(yaml_path, config["origin"])
    negate = _negate(yaml_path, config["negate"])
    occupied_thresh = _number(yaml_path, config, "occupied_thresh")
    free_thresh = _number(yaml_path, config, "free_thresh")
    if not 0.0 <= free_thresh <= occupied_thresh <= 1.0:
        raise MapFileError(f"{yaml_path}: free_thresh/occupied_thresh: need 0 <= free_thresh "
                           f"<= occupied_thresh <= 1, got {free_thresh}/{occupied_thresh}")
    mode = config.get("mode", "trinary")
    if mode not in MAP_MODES:
        raise MapFileError(f"{yaml_path}: mode: '{mode}' is not one of {', '.join(MAP_MODES)}")
    if not isinstance(config["image"], str) or not config["image"]:
        raise MapFileError(f"{yaml_path}: image: must be a file name")

    image_path = yaml_path.parent / config["image"]
    pixels = read_image(image_path)
    grid = pixels_to_grid(pixels, negate, occupied_thresh, free_thresh, mode)
    return OccupancyMap(grid=grid, resolution=resolution, origin=origin)


def pixels_to_grid(pixels: np.ndarray, negate: bool, occupied_thresh: float,
                   free_thresh: float, mode: str = "trinary") -> np.ndarray:
    """map_server's pixel -> occupancy rule. ``pixels`` is the image (row 0 = top), uint8, of
    shape (rows, cols) or (rows, cols, channels) with 3 (RGB) or 4 (RGBA) channels; returns the
    grid (row 0 = bottom), int8."""
    pixels = np.asarray(pixels)
    alpha = None
    if pixels.ndim == 3:
        channels = pixels.shape[2]
        # As map_server: alpha is averaged in with the colours in trinary mode, and its "alpha"
        # is the last channel, an RGB pixel's blue included.
        averaged = channels if mode == "trinary" or channels != 4 else channels - 1
        values = pixels[..., :averaged].astype(np.int64).sum(axis=2) / float(averaged)
        alpha = pixels[..., -1]
    else:
        values = pixels.astype(np.float64)
    if negate:
        values = 255.0 - values
    if mode == "raw":
        # map_server stores the byte as it is; nav_msgs data is signed.
        return np.flipud(values.astype(np.uint8).view(np.int8)).copy()
    occ = (255.0 - values) / 255.0
    grid = np.full(values.shape, UNKNOWN, dtype=np.int8)
    if mode == "scale":
        if occupied_thresh > free_thresh:
            ratio = (occ - free_thresh) / (occupied_thresh - free_thresh)
            grid = (1 + 98 * np.clip(ratio, 0.0, 1.0)).astype(np.int8)
        else:   # equal thresholds, occ on them: map_server's 0/0 ratio, which x86 turns into 0
            grid = np.full(values.shape, FREE, dtype=np.int8)
        if alpha is not None:
            grid[alpha < 1] = UNKNOWN
    grid[occ > occupied_thresh] = OCCUPIED
    grid[occ < free_thresh] = FREE
    return np.flipud(grid).copy()


PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"


def read_image(path: PathLike) -> np.ndarray:
    """A map's image, PNG or PGM by its first bytes: uint8 (rows, cols) or (rows, cols, channels),
    row 0 = top."""
    path = Path(path)
    try:
        with path.open("rb") as image:
            magic = image.read(len(PNG_SIGNATURE))
    except OSError as err:
        raise MapFileError(f"{path}: image: cannot read ({err.strerror})") from None
    return read_png(path) if magic == PNG_SIGNATURE else read_pgm(path)


class _PngChunks(NamedTuple):
    width: int
    height: int
    bit_depth: int
    colour_type: int
    stream: bytes            # the chunks libpng would read, rebuilt for Pillow
    transparent_grey: Optional[int]   # a grey image's tRNS sample, masked to its bit depth


#: libpng's default limit on a PNG's width and height (PNG_USER_WIDTH_MAX, PNG_USER_HEIGHT_MAX).
_PNG_SIDE_MAX = 1_000_000


def _valid_png_header(width, height, bit_depth, colour_type, compression, filtering, interlace) -> bool:
    """libpng's png_check_IHDR."""
    depths = {0: (1, 2, 4, 8, 16), 2: (8, 16), 3: (1, 2, 4, 8), 4: (8, 16), 6: (8, 16)}
    return (0 < width <= _PNG_SIDE_MAX and 0 < height <= _PNG_SIDE_MAX and bit_depth in depths.get(colour_type, ())
            and compression == 0 and filtering == 0 and interlace in (0, 1))


def _png_chunks(path: Path, data: bytes) -> _PngChunks:
    """The chunks map_server's loader (SDL_image over libpng) reads, checked as libpng checks them:
    a critical chunk (IHDR, PLTE, IDAT) with a bad CRC or cut short is an error; an ancillary one
    with a bad CRC is dropped; nothing after the image data is read (not even IEND). Pillow gets
    only these chunks, so that it reads what libpng reads."""
    pos, kept, idat, header, trns = len(PNG_SIGNATURE), [], [], None, None
    while pos + 8 <= len(data):
        length, kind = struct.unpack(">I", data[pos:pos + 4])[0], data[pos + 4:pos + 8]
        name = kind.decode("latin-1")
        if (idat and kind != b"IDAT") or kind == b"IEND":
            break                              # past the image data: libpng reads no further
        end = pos + 12 + length
        if end > len(data):
            raise MapFileError(f"{path}: PNG: file truncated")
        body = data[pos + 8:pos + 8 + length]
        if zlib.crc32(kind + body) != struct.unpack(">I", data[end - 4:end])[0]:
            if kind[:1].isupper():
                raise MapFileError(f"{path}: PNG: {name}: CRC error")
            pos = end
            continue
        if header is None and kind != b"IHDR":
            raise MapFileError(f"{path}: PNG: IHDR: missing (the first chunk is {name})")
        if kind == b"IHDR":
            if length != 13 or not _valid_png_header(*struct.unpack(">IIBBBBB", body)):
                raise MapFileError(f"{path}: PNG: Invalid IHDR data")   # libpng's words
            header = struct.unpack(">IIBB", body[:10])
        elif kind == b"IDAT":
            idat.append(body)
        elif kind == b"tRNS":
            trns = body
        if kind in (b"IHDR", b"PLTE", b"IDAT", b"tRNS"):
            kept.append(data[pos:end])
        pos = end
    if header is None or (not idat and pos + 8 > len(data)):
        raise MapFileError(f"{path}: PNG: file truncated")
    if not idat:
        raise MapFileError(f"{path}: PNG: no image data (IDAT chunk)")
    width, height, bit_depth, colour_type = header
    transparent = None
    if colour_type == 0 and trns is not None and len(trns) == 2:
        # libpng compares the sample at the image's bit depth, the tRNS value masked to it.
        transparent = struct.unpack(">H", trns)[0] & ((1 << bit_depth) - 1)
    iend = struct.pack(">I", 0) + b"IEND" + struct.pack(">I", zlib.crc32(b"IEND"))
    return _PngChunks(width, height, bit_depth, colour_type, PNG_SIGNATURE + b"".join(kept) + iend, transparent)


def read_png(path: PathLike) -> np.ndarray:
    """Read a PNG as map_server's loader (SDL_image) hands it over: grey (1-, 2- and 4-bit scaled
    to 0..255, 16-bit to its high byte) as (rows, cols), or (rows, cols, 2) grey + alpha where a
    tRNS chunk names a transparent grey; RGB and RGBA as (rows, cols, 3 or 4); grey + alpha as
    RGBA. Refuses palette images, images of more than MAX_MAP_CELLS cells (from the header) and
    files libpng refuses."""
    from PIL import Image   # Pillow: only maps in PNG need it

    path = Path(path)
    try:
        data = path.read_bytes()
    except OSError as err:
        raise MapFileError(f"{path}: image: cannot read ({err.strerror})") from None
    png = _png_chunks(path, data)
    if png.width * png.height > MAX_MAP_CELLS:
        raise MapFileError(f"{path}: PNG header: {png.width} x {png.height} = {png.width * png.height} cells, more "
                           f"than the {MAX_MAP_CELLS} a map may have (a 250 m square at 0.05 m)")
    if png.colour_type == 3:
        raise MapFileError(f"{path}: PNG: a palette image; map_server reads its palette indices as grey "
                           f"values, not its colours: save the map as greyscale or RGB")
    stream = io.BytesIO(png.stream)
    try:   # the pixels are decoded here
        with Image.open(stream) as image:
            if png.colour_type != 0:
                pixels = np.asarray(image, dtype=np.uint8)
                if pixels.shape[2] == 2:   # SDL_image turns grey + alpha into RGBA (Pillow: 8-bit only)
                    return np.concatenate([pixels[..., :1]] * 3 + [pixels[..., 1:]], axis=2)
                return pixels.copy()
            if png.bit_depth == 16:
                samples = np.asarray(image, dtype=np.int64)
                grey = (samples >> 8).astype(np.uint8)
            else:
                grey = np.asarray(image.convert("L"), dtype=np.uint8).copy()
                samples = grey // (255 // ((1 << png.bit_depth) - 1))   # back to the file's samples
    except (OSError, SyntaxError, ValueError, zlib.error) as err:
        raise MapFileError(f"{path}: PNG: {str(err).replace(repr(stream), repr(str(path)))}") from None
    if png.transparent_grey is None:
        return grey
    # libpng's expansion of a grey tRNS: an alpha channel, 0 on that grey, 255 elsewhere.
    alpha = np.where(samples == png.transparent_grey, 0, 255).astype(np.uint8)
    return np.stack([grey, alpha], axis=2)


def read_pgm(path: PathLike) -> np.ndarray:
    """Read a binary (P5) or plain (P2) PGM of up to 8 bits; returns uint8 (rows, cols), row 0 =
    top. As map_server's loader (SDL_image): a maxval below 255 scales the samples to 0..255
    (sample * 255 // maxval, kept to a byte); a larger maxval is refused."""
    path = Path(path)
    try:
        with path.open("rb") as image:
            head = image.read(_HEADER_BYTES)
            (magic, width, height, maxval), offset = _pgm_header(path, head)
            if not 1 <= maxval <= 255:
                raise MapFileError(f"{path}: PGM header: maxval {maxval}: map_server reads PGMs of 8 bits or "
                                   f"fewer (maxval 1 to 255)")
            if width * height > MAX_MAP_CELLS:
                raise MapFileError(f"{path}: PGM header: {width} x {height} = {width * height} cells, more than "
                                   f"the {MAX_MAP_CELLS} a map may have (a 250 m square at 0.05 m)")
            data = head + image.read()
    except OSError as err:
        raise MapFileError(f"{path}: image: cannot read ({err.strerror})") from None
    if magic == b"P5":
        body = data[offset:offset + width * height]
        if len(body) != width * height:
            raise MapFileError(f"{path}: PGM data: expected {width * height} bytes, "
                               f"got {len(body)}")
        samples = np.frombuffer(body, dtype=np.uint8).reshape(height, width).astype(np.int64)
    else:
        try:
            values = [int(token) for token in _strip_comments(data[offset:]).split()]
        except ValueError:
            raise MapFileError(f"{path}: PGM data: non-numeric pixel value") from None
        if len(values) != width * height or not all(0 <= v <= maxval for v in values):
            raise MapFileError(f"{path}: PGM data: expected {width * height} values in 0..{maxval}")
        samples = np.array(values, dtype=np.int64).reshape(height, width)
    if maxval < 255:
        # SDL_image's scaling, into a byte (a P5 sample above maxval wraps, as it does there).
        samples = samples * 255 // maxval
    return (samples & 0xFF).astype(np.uint8)


#: The widest and tallest PGM either reader takes (a side of more cells than a map may have).
_PGM_SIDE_MAX = 1 << 20
#: Bytes read for the header before the image's size is checked (comments included).
_HEADER_BYTES = 65536


def _pgm_header(path: Path, data: bytes):
    """Parse 'P5 width height maxval' (comments allowed); return tokens and data offset."""
    tokens = []
    pos = 0
    while len(tokens) < 4:
        while pos < len(data) and data[pos:pos + 1].isspace():
            pos += 1
        if data[pos:pos + 1] == b"#":
            while pos < len(data) and data[pos:pos + 1] not in (b"\n", b"\r"):
                pos += 1
            continue
        start = pos
        while pos < len(data) and not data[pos:pos + 1].isspace() and data[pos:pos + 1] != b"#":
            pos += 1
        if start == pos:
            raise MapFileError(f"{path}: PGM header: truncated")
        tokens.append(data[start:pos])
        if tokens[0] not in (b"P5", b"P2"):
            found = "".join(chr(b) if 0x20 <= b < 0x7F else f"\\x{b:02x}" for b in data[:2])
            raise MapFileError(f"{path}: PGM header: not a PGM or PNG file (expected magic P5 or P2, or a PNG, "
                               f"found '{found}')")
    try:
        width, height, maxval = (int(token) for token in tokens[1:])
    except ValueError:
        raise MapFileError(f"{path}: PGM header: non-numeric size or maxval") from None
    for side, value in (("width", width), ("height", height)):
        if not 1 <= value <= _PGM_SIDE_MAX:
            raise MapFileError(f"{path}: PGM header: {side} {value} out of range [1, {_PGM_SIDE_MAX}]")
    # Exactly one whitespace byte separates the header from binary data.
    return (tokens[0], width, height, maxval), pos + 1


def _strip_comments(data: bytes) -> bytes:
    return b"\n".join(line.split(b"#", 1)[0] for line in data.splitlines())


def _read_yaml(yaml_path: Path) -> dict:
    try:
        config = load_yaml_file(yaml_path)
    except YamlFileError as error:
        raise MapFileError(str(error)) from None
    if not isinstance(config, dict):
        raise MapFileError(f"{yaml_path}: YAML: expected a mapping of keys to values")
    return config


def _number(yaml_path: Path, config: dict, key: str) -> float:
    value = config[key]
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise MapFileError(f"{yaml_path}: {key}: must be a number, got {value!r}")
    return float(value)


def load_navigation_map(yaml_path: PathLike) -> OccupancyMap:
    """load_map for a floor that robots navigate: its origin yaw must be 0. map_server publishes
    the yaw, but move_base's costmaps (stock and built-in) and stock amcl ignore it, so a rotated map
    would put the obstacles navigation sees elsewhere than the ones localisation and the scenario
    see. map_saver always writes 0."""
    grid_map = load_map(yaml_path)
    if abs(grid_map.origin.yaw) > 1e-9:
        raise MapFileError(f"{yaml_path}: origin: yaw {grid_map.origin.yaw:g} rad is not 0: move_base's costmaps and "
                           "amcl ignore a map's origin yaw; rotate the image instead")
    return grid_map


def _origin(yaml_path: Path, value) -> MapOrigin:
    if (not isinstance(value, list) or len(value) != 3
            or not all(isinstance(v, (int, float)) and not isinstance(v, bool)
                       and math.isfinite(v) for v in value)):
        raise MapFileError(f"{yaml_path}: origin: must be [x, y, yaw] numbers, got {value!r}")
    return MapOrigin(float(value[0]), float(value[1]), float(value[2]))


def _negate(yaml_path: Path, value) -> bool:
    if value in (0, 1) or isinstance(value, bool):
        return bool(value)
    raise MapFileError(f"{yaml_path}: negate: must be 0 or 1, got {value!r}")


# ---------------------------------------------------------------- writing


def grid_to_pixels(grid: np.ndarray) -> np.ndarray:
    """map_saver's rule: OCCUPIED -> 0, FREE -> 254, UNKNOWN -> 205; image row 0 = top."""
    if not np.isin(grid, (OCCUPIED, FREE, UNKNOWN)).all():
        raise ValueError("only trinary grids (100, 0, -1) can be saved")
    pixels = np.full(grid.shape, PIXEL_UNKNOWN, dtype=np.uint8)
    pixels[grid == OCCUPIED] = PIXEL_OCCUPIED
    pixels[grid == FREE] = PIXEL_FREE
    return np.flipud(pixels)


def save_map(occupancy_map: OccupancyMap, yaml_path: PathLike, comment: str = "") -> Path:
    """Write ``<stem>.yaml`` and ``<stem>.pgm`` (P5, negate 0, thresholds 0.65/0.196) the way
    map_saver does; ``comment`` lines head the YAML. Returns the image path."""
    yaml_path = Path(yaml_path)
    image_path = yaml_path.with_suffix(".pgm")
    pixels = grid_to_pixels(occupancy_map.grid)
    header = f"P5\n{occupancy_map.width} {occupancy_map.height}\n255\n".encode("ascii")
    image_path.write_bytes(header + pixels.tobytes())
    origin = occupancy_map.origin
    lines = [f"# {line}" for line in comment.splitlines()] + [
        f"image: {image_path.name}",
        f"resolution: {occupancy_map.resolution:.6f}",
        f"origin: [{origin.x:.6f}, {origin.y:.6f}, {origin.yaw:.6f}]",
        "negate: 0",
        f"occupied_thresh: {DEFAULT_OCCUPIED_THRESH}",
        f"free_thresh: {DEFAULT_FREE_THRESH}",
    ]
    yaml_path.write_text("\n".join(lines) + "\n")
    return image_path
