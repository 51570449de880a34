"""The two map readers are one rule: the Python reader (model/occupancy_map.py) and the C++ one
(src/map/, through libmarl_mrta_travel.so) give the same grid on every kind of image map_server
reads (PNG of every colour type and bit depth, interlaced, with a transparent grey; PGM binary and
plain, of any maxval up to 255), in every mode, and the same one line on the maps they refuse. The
expectations on transparent greys, maxval and damaged chunks are map_server's (SDL_image over
libpng), checked against its image loader."""
import struct
import zlib
from pathlib import Path

import numpy as np
import pytest

from marl_mrta.model.navfn_paths import LibraryMissing, read_map_native
from marl_mrta.model.occupancy_map import FREE, OCCUPIED, UNKNOWN, MapFileError, load_map

CHANNELS = {0: 1, 2: 3, 3: 1, 4: 2, 6: 4}   # PNG colour type -> samples per pixel
ADAM7 = [(0, 0, 8, 8), (4, 0, 8, 8), (0, 4, 4, 8), (2, 0, 4, 4), (0, 2, 2, 4), (1, 0, 2, 2), (0, 1, 1, 2)]


@pytest.fixture(scope="module", autouse=True)
def native_reader():
    try:
        read_map_native("/nonexistent.yaml")
    except LibraryMissing as missing:
        pytest.skip(f"the C++ reader is not available ({missing})")
    except MapFileError:
        pass


def chunk(kind: bytes, body: bytes) -> bytes:
    return struct.pack(">I", len(body)) + kind + body + struct.pack(">I", zlib.crc32(kind + body))


def packed_rows(samples: np.ndarray, depth: int) -> bytes:
    """Filter type 0 rows of samples (rows, samples per row) at a bit depth."""
    out = []
    for row in samples:
        if depth == 16:
            data = row.astype(">u2").tobytes()
        elif depth == 8:
            data = row.astype(np.uint8).tobytes()
        else:
            data = np.packbits(np.unpackbits(row.astype(np.uint8)[:, None], axis=1)[:, 8 - depth:]).tobytes()
        out.append(b"\x00" + data)
    return b"".join(out)


def png_bytes(samples: np.ndarray, colour_type: int, depth: int, interlaced: bool = False,
              extra: bytes = b"") -> bytes:
    """A PNG of samples (rows, cols, samples per pixel); `extra` chunks go before the image data."""
    rows, cols = samples.shape[:2]
    if interlaced:
        raw = b"".join(packed_rows(samples[y0::dy, x0::dx].reshape(len(range(y0, rows, dy)), -1), depth)
                       for x0, y0, dx, dy in ADAM7 if x0 < cols and y0 < rows)
    else:
        raw = packed_rows(samples.reshape(rows, -1), depth)
    header = struct.pack(">IIBBBBB", cols, rows, depth, colour_type, 0, 0, int(interlaced))
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header) + extra + chunk(b"IDAT", zlib.compress(raw))
            + chunk(b"IEND", b""))


def write_map(folder: Path, name: str, image: bytes, suffix: str, mode: str = "trinary", negate: int = 0,
              occupied: float = 0.65, free: float = 0.196) -> Path:
    (folder / f"{name}.{suffix}").write_bytes(image)
    path = folder / f"{name}_{mode}_{negate}.yaml"
    path.write_text(f"image: {name}.{suffix}\nresolution: 0.05\norigin: [0.0, 0.0, 0.0]\nnegate: {negate}\n"
                    f"occupied_thresh: {occupied}\nfree_thresh: {free}\nmode: {mode}\n")
    return path


def images():
    """(name, bytes, suffix) of every kind of image map_server reads, 9 x 13 pixels of random samples."""
    rng = np.random.default_rng(7)
    kinds = [(0, 1), (0, 2), (0, 4), (0, 8), (0, 16), (2, 8), (2, 16), (4, 8), (4, 16), (6, 8), (6, 16)]
    for colour_type, depth in kinds:
        samples = rng.integers(0, 1 << depth, size=(9, 13, CHANNELS[colour_type]))
        if colour_type in (4, 6):
            samples[0, :3, -1] = [0, 1, (1 << depth) - 1]   # transparent, nearly, opaque
        for interlaced in (False, True):
            image = png_bytes(samples, colour_type, depth, interlaced)
            yield f"png_{colour_type}_{depth}_{int(interlaced)}", image, "png"
    for depth, transparent in [(1, 1), (4, 9), (8, 205), (16, 40000)]:
        samples = rng.integers(0, 1 << depth, size=(9, 13, 1))
        samples[0, :4, 0] = transparent
        trns = chunk(b"tRNS", struct.pack(">H", transparent))
        yield f"grey_trns_{depth}", png_bytes(samples, 0, depth, extra=trns), "png"
    rgb = rng.integers(0, 256, size=(9, 13, 3))
    yield "rgb_trns", png_bytes(rgb, 2, 8, extra=chunk(b"tRNS", struct.pack(">HHH", *rgb[0, 0]))), "png"
    bad_text = struct.pack(">I", 3) + b"tEXt" + b"a\x00b" + b"\x00\x00\x00\x00"   # an ancillary chunk, bad CRC
    grey = rng.integers(0, 256, size=(9, 13, 1))
    yield "bad_ancillary_crc", png_bytes(grey, 0, 8, extra=bad_text), "png"
    yield "no_iend", png_bytes(grey, 0, 8)[:-12], "png"
    yield "trailing_bytes", png_bytes(grey, 0, 8) + b"not a chunk", "png"
    pixels = rng.integers(0, 256, size=(9, 13))
    yield "p5", b"P5\n# map_saver\n13 9\n255\n" + pixels.astype(np.uint8).tobytes(), "pgm"
    yield "p2", b"P2\n13 9\n255\n" + " ".join(map(str, pixels.reshape(-1))).encode() + b"\n", "pgm"
    low = rng.integers(0, 16, size=(9, 13))
    yield "p2_maxval_15", b"P2\n13 9\n15\n" + " ".join(map(str, low.reshape(-1))).encode() + b"\n", "pgm"
    yield "p5_maxval_100", b"P5\n13 9\n100\n" + pixels.astype(np.uint8).tobytes(), "pgm"   # samples above 100 too


@pytest.mark.parametrize("name, image, suffix", list(images()), ids=[name for name, _, _ in images()])
def test_both_readers_give_the_same_grid(tmp_path, name, image, suffix):
    for mode in ("trinary", "scale", "raw"):
        for negate in (0, 1):
            path = write_map(tmp_path, name, image, suffix, mode, negate)
            python = load_map(path).grid
            assert python.shape == (9, 13)
            np.testing.assert_array_equal(read_map_native(path), python, err_msg=f"{name}, {mode}, negate {negate}")


def test_equal_thresholds_give_what_map_server_gives(tmp_path):
    # scale mode, occupied_thresh = free_thresh = 0.2: a grey of occ 0.2 exactly (204) makes
    # map_server's ratio 0/0, which it stores as 0.
    path = write_map(tmp_path, "equal", b"P5\n3 1\n255\n\xcc\xcd\xcb", "pgm", "scale", occupied=0.2, free=0.2)
    assert load_map(path).grid.tolist() == [[FREE, FREE, OCCUPIED]]
    assert read_map_native(path).tolist() == [[FREE, FREE, OCCUPIED]]


def test_a_transparent_grey_becomes_an_alpha_channel(tmp_path):
    # libpng expands a grey image's tRNS to alpha (0 on that grey, 255 elsewhere), and map_server
    # averages the alpha in with the grey: black is no longer occupied, and the transparent grey
    # (205: occ 0.6) stays unknown at half its grey.
    samples = np.array([[[0], [205], [254]]])
    image = png_bytes(samples, 0, 8, extra=chunk(b"tRNS", struct.pack(">H", 205)))
    for reader in (lambda p: load_map(p).grid, read_map_native):
        assert reader(write_map(tmp_path, "trns", image, "png")).tolist() == [[UNKNOWN, UNKNOWN, FREE]]
        assert reader(write_map(tmp_path, "trns", image, "png", "raw")).tolist() == [[127, 102, 254 - 256]]


def idat_crc_flipped(image: bytes) -> bytes:
    at = image.index(b"IDAT")
    length = struct.unpack(">I", image[at - 4:at])[0]
    crc = at + 4 + length
    return image[:crc] + bytes([image[crc] ^ 1]) + image[crc + 1:]


BAD = {
    "bad_mode": (b"P5\n1 1\n255\n\x00", "pgm", {"mode": "bogus"},
                 "{yaml}: mode: 'bogus' is not one of trinary, scale, raw"),
    "sixteen_bit_pgm": (b"P5\n1 1\n65535\n\x00\x00", "pgm", {},
                        "{image}: PGM header: maxval 65535: map_server reads PGMs of 8 bits or fewer "
                        "(maxval 1 to 255)"),
    "jpeg": (b"\xff\xd8\xff\xe0 a JPEG", "pgm", {},
             "{image}: PGM header: not a PGM or PNG file (expected magic P5 or P2, or a PNG, found '\\xff\\xd8')"),
    "palette": (png_bytes(np.zeros((2, 2, 1), int), 3, 8, extra=chunk(b"PLTE", bytes(3))), "png", {},
                "{image}: PNG: a palette image; map_server reads its palette indices as grey values, not its "
                "colours: save the map as greyscale or RGB"),
    "bad_png_header": (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", 3, 3, 3, 0, 0, 0, 0))
                       + chunk(b"IDAT", zlib.compress(bytes(12))), "png", {}, "{image}: PNG: Invalid IHDR data"),
    "empty_pgm": (b"P5\n0 3\n255\n", "pgm", {}, "{image}: PGM header: width 0 out of range [1, 1048576]"),
    "idat_crc": (idat_crc_flipped(png_bytes(np.zeros((2, 2, 1), int), 0, 8)), "png", {},
                 "{image}: PNG: IDAT: CRC error"),
    "truncated": (png_bytes(np.zeros((20, 20, 1), int), 0, 8)[:50], "png", {}, "{image}: PNG: file truncated"),
    "too_large": (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", 30000, 30000, 1, 0, 0, 0, 0))
                  + chunk(b"IDAT", b"") + chunk(b"IEND", b""), "png", {},   # refused before its pixels
                  "{image}: PNG header: 30000 x 30000 = 900000000 cells, more than the 25000000 a map may have "
                  "(a 250 m square at 0.05 m)"),
}


@pytest.mark.parametrize("name", list(BAD))
def test_both_readers_refuse_a_bad_map_with_the_same_line(tmp_path, name):
    image, suffix, keys, expected = BAD[name]
    path = write_map(tmp_path, name, image, suffix, keys.get("mode", "trinary"))
    expected = expected.format(yaml=path, image=tmp_path / f"{name}.{suffix}")
    with pytest.raises(MapFileError) as python:
        load_map(path)
    with pytest.raises(MapFileError) as native:
        read_map_native(path)
    assert str(python.value) == str(native.value) == expected
