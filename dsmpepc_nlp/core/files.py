"""Atomic file writes (a temporary file in the same folder, then ``os.replace``), and the YAML
reader of scenario and map files."""

from __future__ import annotations

import functools
import io
import os
import re
import tempfile
from pathlib import Path


def atomic_write_bytes(path, payload: bytes) -> Path:
    """Write ``payload`` to ``path`` through a temporary file in the same folder + ``os.replace``.

    On any exception the temporary file is removed and ``path`` is left as it was: nothing is
    ever half-written.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    handle = tempfile.NamedTemporaryFile(dir=path.parent, prefix=f".{path.name}.",
                                         suffix=".tmp", delete=False)
    try:
        with handle:
            handle.write(payload)
            handle.flush()
            os.fsync(handle.fileno())
        # mkstemp creates 0600; give the file the permissions a plain open() would have.
        os.chmod(handle.name, 0o666 & ~_umask())
        os.replace(handle.name, path)
    except BaseException:
        Path(handle.name).unlink(missing_ok=True)
        raise
    return path


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def atomic_write_text(path, text: str) -> Path:
    """:func:`atomic_write_bytes` of UTF-8 text."""
    return atomic_write_bytes(path, text.encode("utf-8"))


def atomic_savefig(fig, path, **kwargs) -> Path:
    """Save a matplotlib figure atomically (format from the suffix of ``path``)."""
    path = Path(path)
    buffer = io.BytesIO()
    fig.savefig(buffer, format=path.suffix.lstrip(".") or "png", **kwargs)
    return atomic_write_bytes(path, buffer.getvalue())


@functools.cache
def _number_loader():
    """PyYAML's safe loader (YAML 1.1) that also reads ``1e9``, ``2E-3`` and ``.5e1`` as
    numbers, as YAML 1.2 does: YAML 1.1 wants a dot and a signed exponent (``1.0e+9``), and
    reads ``1e9`` as the string "1e9". Made on first use: PyYAML's import (~20 ms) is not
    paid by a process that plans without reading a file."""
    import yaml

    class NumberLoader(yaml.SafeLoader):
        pass

    NumberLoader.add_implicit_resolver(
        "tag:yaml.org,2002:float",
        re.compile(r"^[-+]?(?:[0-9][0-9_]*(?:\.[0-9_]*)?|\.[0-9_]+)[eE][-+]?[0-9]+$"),
        list("-+0123456789."))
    return NumberLoader


def load_yaml(text: str):
    """YAML text as Python objects: :func:`yaml.safe_load`, with ``1e9`` read as a number.
    Invalid YAML raises :class:`YamlError`."""
    import yaml

    try:
        return yaml.load(text, Loader=_number_loader())  # noqa: S506 - a SafeLoader subclass
    except yaml.YAMLError as exc:
        raise YamlError(str(exc)) from exc


class YamlError(ValueError):
    """Text that is not valid YAML (PyYAML's ``YAMLError``, without importing PyYAML)."""
