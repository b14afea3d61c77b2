"""Where compiled code lives, and whether to compile at all.

Compiled forms (the numba exact evaluator, the CasADi-generated C of the NLP) are built on first
use and cached on disk per configuration and package version, in the user's cache folder
(``platformdirs.user_cache_dir("dsmpepc_nlp")``, or ``$DSMPEPC_CACHE_DIR``). Setting
``DSMPEPC_NO_COMPILE=1`` (or having no compiler) keeps everything on the numpy / CasADi virtual
machine paths; the package says so once, in one warning line, and works, slower.
"""

from __future__ import annotations

import hashlib
import os
import warnings
from importlib import metadata
from pathlib import Path

_WARNED: set = set()


def package_version() -> str:
    """The installed version of dsmpepc_nlp ("0+unknown" when running from a bare checkout)."""
    try:
        return metadata.version("dsmpepc_nlp")
    except metadata.PackageNotFoundError:
        return "0+unknown"


def compile_enabled() -> bool:
    """False when ``DSMPEPC_NO_COMPILE`` is set to anything but "", "0" or "false"."""
    value = os.environ.get("DSMPEPC_NO_COMPILE", "").strip().lower()
    return value in ("", "0", "false", "no")


def cache_dir(kind: str) -> Path:
    """The folder for compiled artefacts of one ``kind`` (e.g. "numba", "casadi"), created.

    ``$DSMPEPC_CACHE_DIR`` overrides the user cache folder; the package version is part of the
    path so that an upgrade never loads stale code.
    """
    root = os.environ.get("DSMPEPC_CACHE_DIR")
    if not root:
        try:
            import platformdirs

            root = platformdirs.user_cache_dir("dsmpepc_nlp")
        except ImportError:  # platformdirs is a dependency; a bare checkout may lack it
            root = os.path.join(os.path.expanduser("~"), ".cache", "dsmpepc_nlp")
    path = Path(root) / package_version() / kind
    path.mkdir(parents=True, exist_ok=True)
    return path


def config_key(*parts) -> str:
    """A short stable hash of ``repr(parts)`` naming one configuration's compiled files."""
    return hashlib.sha1(repr(parts).encode()).hexdigest()[:16]


def warn_once(key: str, message: str) -> None:
    """One warning line per process and ``key`` (e.g. "no compiler: numpy path, slower")."""
    if key in _WARNED:
        return
    _WARNED.add(key)
    # warn_explicit with the package as the "file": shown as exactly one line (no source line).
    warnings.warn_explicit(message, RuntimeWarning, "dsmpepc_nlp", 0)
