"""ROS ``map_server`` map files: YAML metadata and a PGM image, read and written; PNG (and the
other images Pillow reads) read as ``map_server`` reads them."""

from __future__ import annotations

import difflib
import warnings
from pathlib import Path

import numpy as np

from .errors import MAX_COORDINATE, RESOLUTION_RANGE, InputError, finite_vector, number_in
from .files import YamlError, atomic_write_bytes, load_yaml


def _read_pgm(path):
    """Read a binary (P5) or ascii (P2) PGM: (pixels (h, w) int, maxval); row 0 is the top."""
    try:
        data = Path(path).read_bytes()
    except OSError as exc:
        raise InputError(f"image {str(path)!r}: cannot read ({exc.strerror})") from None
    magic = data[:2]
    if magic not in (b"P5", b"P2"):
        raise InputError(
            f"image {str(path)!r}: not a PGM file (magic {magic!r}, expected P5 or P2)"
        )

    pos = 2
    header = []
    while len(header) < 3:
        while pos < len(data) and (data[pos : pos + 1].isspace() or data[pos : pos + 1] == b"#"):
            if data[pos : pos + 1] == b"#":
                end = data.find(b"\n", pos)
                pos = len(data) if end < 0 else end + 1
            else:
                pos += 1
        start = pos
        while pos < len(data) and not data[pos : pos + 1].isspace() and data[pos : pos + 1] != b"#":
            pos += 1
        token = data[start:pos]
        if not token.isdigit():
            raise InputError(
                f"image {str(path)!r}: truncated or malformed PGM header (got {token!r} where "
                "width, height and maxval are expected)"
            )
        header.append(int(token))
    width, height, maxval = header
    if width < 1 or height < 1 or not 1 <= maxval <= 65535:
        raise InputError(
            f"image {str(path)!r}: PGM header width={width}, height={height}, maxval={maxval}: "
            "expected width, height >= 1 and 1 <= maxval <= 65535"
        )

    count = width * height
    if magic == b"P5":
        pos += 1  # exactly one whitespace byte separates maxval from the raster
        dtype = np.dtype(">u2") if maxval > 255 else np.dtype(np.uint8)
        nbytes = count * dtype.itemsize
        if len(data) - pos < nbytes:
            raise InputError(
                f"image {str(path)!r}: truncated PGM raster ({len(data) - pos} bytes, "
                f"expected {nbytes} for {width}x{height})"
            )
        pixels = np.frombuffer(data, dtype=dtype, count=count, offset=pos).astype(np.int64)
    else:
        text = b"\n".join(line.split(b"#", 1)[0] for line in data[pos:].splitlines())
        tokens = text.split()
        if len(tokens) < count or not all(t.isdigit() for t in tokens[:count]):
            raise InputError(
                f"image {str(path)!r}: truncated or malformed ascii PGM raster "
                f"(expected {count} integers for {width}x{height})"
            )
        pixels = np.array([int(t) for t in tokens[:count]], dtype=np.int64)
    if np.any(pixels > maxval):
        raise InputError(f"image {str(path)!r}: pixel values exceed maxval={maxval}")
    return pixels.reshape(height, width), maxval


def _read_image(path):
    """Pixels (h, w) and their maximum value, as ``map_server`` sees an image: PGM read here;
    PNG, BMP, JPEG... through Pillow (matplotlib's dependency), colour channels averaged and
    an alpha channel left out of the average (``map_server``'s trinary and scale modes)."""
    if Path(path).read_bytes()[:2] in (b"P5", b"P2"):
        return _read_pgm(path)
    try:
        from PIL import Image, UnidentifiedImageError
    except ImportError:  # pragma: no cover - Pillow comes with matplotlib
        raise InputError(f"image {str(path)!r}: not a PGM, and Pillow (for PNG and other "
                         "images) is not installed: pip install pillow") from None
    try:
        with Image.open(path) as image:
            if image.mode in ("1", "P", "CMYK", "YCbCr", "LAB", "HSV"):
                alpha = image.mode == "P" and "transparency" in image.info
                image = image.convert("RGBA" if alpha else "RGB")
            pixels = np.asarray(image)
    except (UnidentifiedImageError, OSError) as exc:
        raise InputError(f"image {str(path)!r}: not a PGM, and not an image Pillow reads "
                         f"(PNG, BMP, JPEG...): {exc}") from None
    maxval = 65535 if pixels.dtype.itemsize > 1 else 255
    if pixels.ndim == 3:
        channels = pixels.shape[2]
        colour = pixels[:, :, :channels - 1] if channels in (2, 4) else pixels
        pixels = colour.astype(float).mean(axis=2)
    return pixels.astype(float), maxval


MAP_FIELDS = ("image", "resolution", "origin", "negate", "occupied_thresh", "free_thresh",
              "mode")
"""The fields of a ROS ``map_server`` YAML this reader knows."""


def _did_you_mean(key: str, candidates) -> str:
    close = difflib.get_close_matches(key, list(candidates), n=1, cutoff=0.6)
    return f" (did you mean to write {key!r} for {close[0]!r}?)" if close else ""


def read_map(path):
    """Read a ROS ``map_server`` map: ``(occupied[iy, ix], resolution, origin (x, y))``.

    From the YAML file and the image it names: a PGM, or a PNG (or any image Pillow reads) as
    ``map_server`` reads it (colour channels averaged, alpha left out of the average).

    Honoured fields: ``image`` (relative to the YAML's folder), ``resolution`` (m/cell, in
    ``RESOLUTION_RANGE``), ``origin`` [x, y, yaw] (``|x|, |y| <= MAX_COORDINATE``; yaw must
    be 0), ``negate`` (0/1, default 0), ``occupied_thresh`` (default 0.65), ``free_thresh``
    (default 0.196), ``mode`` ("trinary" default, or "scale").

    A pixel p of a PGM with maximum value M has occupancy ``(M - p) / M`` (``p / M`` when
    negated), i.e. ``(255 - p) / 255`` for 8-bit images; it is occupied when that exceeds
    ``occupied_thresh``. Unknown cells (between ``free_thresh`` and ``occupied_thresh``) count
    as FREE for planning. Image row 0 is the top of the map (largest y).

    Raises
    ------
    ValueError
        Naming the file and the field for unreadable YAML, missing or invalid fields, a
        missing image, or a truncated or non-PGM image.
    """
    path = Path(path)
    where = f"map file {str(path)!r}"
    try:
        meta = load_yaml(path.read_text())
    except OSError as exc:
        raise InputError(f"{where}: cannot read ({exc.strerror})") from None
    except YamlError as exc:
        raise InputError(f"{where}: invalid YAML ({exc})") from None
    if not isinstance(meta, dict):
        raise InputError(  # noqa: TRY004 - bad file content, not a bad argument
            f"{where}: expected a mapping with image, resolution, origin"
        )
    unknown = [str(k) for k in meta if k not in MAP_FIELDS]
    for key in ("image", "resolution", "origin"):
        if key not in meta:
            raise InputError(f"{where}: missing field {key!r}{_did_you_mean(key, unknown)}")
    for key in unknown:      # map_server ignores them too; a misspelt optional field is a typo
        close = difflib.get_close_matches(key, MAP_FIELDS, n=1, cutoff=0.6)
        warnings.warn(f"{where}: unknown field {key!r} ignored"
                      + (f"; did you mean {close[0]!r}?" if close else
                         f" (fields: {', '.join(MAP_FIELDS)})"), stacklevel=2)

    def field(fn, key, *args):
        try:
            return fn(key, meta[key], *args)
        except ValueError as exc:
            raise InputError(f"{where}: {exc}") from None

    resolution = field(number_in, "resolution", *RESOLUTION_RANGE)
    origin = meta["origin"]
    if not isinstance(origin, (list, tuple)) or len(origin) != 3:
        raise InputError(f"{where}: origin={origin!r}: expected [x, y, yaw]")
    origin = field(finite_vector, "origin", 3, MAX_COORDINATE)
    if origin[2] != 0.0:
        raise InputError(f"{where}: origin yaw={float(origin[2])!r}: only 0 is supported")
    negate = meta.get("negate", 0)
    if negate not in (0, 1):
        raise InputError(f"{where}: negate={negate!r}: expected 0 or 1")
    thresholds = {}
    for key, default in (("occupied_thresh", 0.65), ("free_thresh", 0.196)):
        value = meta.get(key, default)
        number = isinstance(value, (int, float)) and not isinstance(value, bool)
        if not number or not 0 <= value <= 1:
            raise InputError(f"{where}: {key}={value!r}: expected a number in [0, 1]")
        thresholds[key] = float(value)
    if thresholds["free_thresh"] > thresholds["occupied_thresh"]:
        raise InputError(
            f"{where}: free_thresh={thresholds['free_thresh']} > occupied_thresh="
            f"{thresholds['occupied_thresh']}: expected free_thresh <= occupied_thresh"
        )
    mode = meta.get("mode", "trinary")
    if mode not in ("trinary", "scale"):
        raise InputError(f"{where}: mode={mode!r}: expected 'trinary' or 'scale'")
    image = meta["image"]
    if not isinstance(image, str) or not image:
        raise InputError(f"{where}: image={image!r}: expected a file name")
    image_path = path.parent / image
    if not image_path.is_file():
        raise InputError(f"{where}: image file {str(image_path)!r} (field 'image') not found")

    pixels, maxval = _read_image(image_path)
    lightness = pixels / maxval
    occupancy = lightness if negate else 1.0 - lightness
    occupied = occupancy > thresholds["occupied_thresh"]
    return occupied[::-1].copy(), resolution, origin[:2]


def write_map(path, occupied, resolution, origin, image_name=None) -> None:
    """Write a ROS ``map_server`` YAML file and a binary PGM next to it.

    Occupied cells are written black (0), free cells 254; ``negate`` 0, ``occupied_thresh``
    0.65, ``free_thresh`` 0.196. Both files are replaced atomically.

    Parameters
    ----------
    path : str or Path
        YAML file to write.
    image_name : str, optional
        Image file name, in the YAML's folder; default: the YAML's stem + ".pgm".
    """
    path = Path(path)
    if image_name is None:
        image_name = path.stem + ".pgm"
    if not isinstance(image_name, str) or not image_name or Path(image_name).name != image_name:
        raise InputError(f"image_name={image_name!r}: expected a plain file name")
    ny, nx = occupied.shape
    raster = np.where(occupied[::-1], 0, 254).astype(np.uint8)
    header = f"P5\n{nx} {ny}\n255\n".encode()
    atomic_write_bytes(path.parent / image_name, header + raster.tobytes())
    meta = {
        "image": image_name,
        "resolution": float(resolution),
        "origin": [float(origin[0]), float(origin[1]), 0.0],
        "negate": 0,
        "occupied_thresh": 0.65,
        "free_thresh": 0.196,
        "mode": "trinary",
    }
    import yaml

    atomic_write_bytes(path, yaml.safe_dump(meta, sort_keys=False).encode())
