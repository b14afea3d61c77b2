"""Where compiled code lives, and whether to compile at all.

Compiled forms (the numba exact evaluator, the CasADi-generated C of the NLP) are built on first
use and cached on disk per configuration and package version, in the user's cache folder
(``platformdirs.user_cache_dir("dsmpepc_nlp")``, or ``$DSMPEPC_CACHE_DIR``). Setting
``DSMPEPC_NO_COMPILE=1`` (or having no compiler) keeps everything on the numpy / CasADi virtual
machine paths; the package says so once, in one warning line, and works, slower.
"""

from __future__ import annotations

import ast
import contextlib
import functools
import hashlib
import importlib
import json
import os
import shutil
import time
import warnings
from pathlib import Path

from .._version import __version__

_WARNED: set = set()


def package_version() -> str:
    """The version of dsmpepc_nlp (``dsmpepc_nlp._version``; read without importing
    ``importlib.metadata``, which a fresh process's first plan would pay ~10 ms for)."""
    return __version__


def compile_enabled() -> bool:
    """False when ``DSMPEPC_NO_COMPILE`` is set to anything but "", "0" or "false"."""
    value = os.environ.get("DSMPEPC_NO_COMPILE", "").strip().lower()
    return value in ("", "0", "false", "no")


def cache_dir(kind: str) -> Path:
    """The folder for compiled artefacts of one ``kind`` (e.g. "numba", "casadi"), created.

    ``$DSMPEPC_CACHE_DIR`` overrides the user cache folder; the package version is part of the
    path so that an upgrade never loads stale code.
    """
    path = cache_root() / package_version() / kind
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


# --- what a compiled artefact depends on -------------------------------------------------------

_PACKAGE = Path(__file__).resolve().parent.parent


def _module_file(name: str) -> Path | None:
    """The source file of the package's module ``name`` (dotted), or None outside the package."""
    parts = name.split(".")
    if parts[0] != _PACKAGE.name:
        return None
    base = _PACKAGE.joinpath(*parts[1:])
    for path in (base.with_suffix(".py"), base / "__init__.py"):
        if path.is_file():
            return path
    return None


def source_closure(*modules: str) -> list:
    """The package's source files that ``modules`` (dotted names) are made of: each module and,
    transitively, every module of the package it imports (at the top or inside a function; a
    package's ``__init__`` only where it is imported itself). Derived from the code, so a new
    import is covered without a hand-kept list."""
    seen, stack = {}, list(modules)
    while stack:
        name = stack.pop()
        path = _module_file(name)
        if path is None or name in seen:
            continue
        seen[name] = path
        package = name if path.name == "__init__.py" else name.rpartition(".")[0]
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.Import):
                stack.extend(alias.name for alias in node.names)
            elif isinstance(node, ast.ImportFrom):
                if node.level:
                    anchor = package.rsplit(".", node.level - 1)[0] if node.level > 1 else package
                    base = f"{anchor}.{node.module}" if node.module else anchor
                else:
                    base = node.module or ""
                if node.module:
                    stack.append(base)
                # ``from package import module``: the module is a dependency too.
                stack.extend(f"{base}.{alias.name}" for alias in node.names
                             if _module_file(f"{base}.{alias.name}") is not None)
    return sorted(set(seen.values()))


def _signature(paths) -> list:
    return [[str(p), p.stat().st_size, p.stat().st_mtime_ns] for p in paths]


def sources_hash(*modules: str) -> str:
    """Hash of :func:`source_closure` (paths relative to the package, and contents).

    Parsing the closure takes ~50 ms, so the result is remembered on disk with the closure's
    file sizes and modification times: while none of those files changes (a closure grows only
    through an edit of one of its files), a process reads the hash back in well under 1 ms.
    """
    return _closure_memo(*modules)["hash"]


def sources_stamp(*modules: str) -> str:
    """A short hash of where :func:`source_closure`'s files are and of their sizes and
    modification times: what numba keys its own cache index by (the source file's folder and
    its stamp), so two checkouts, or two installs of one version, never read each other's
    index as their own."""
    return config_key(str(_PACKAGE), _closure_memo(*modules)["files"])


def _closure_memo(*modules: str) -> dict:
    """``{"hash": ..., "files": [[path, size, mtime_ns], ...]}`` of the closure of
    ``modules``, read back from disk while no file of it changed."""
    # One memo per package folder: two checkouts sharing a cache must not read each other's.
    memo_path = cache_dir("sources") / (config_key(str(_PACKAGE), *modules) + ".json")
    try:
        memo = json.loads(memo_path.read_text())
        if all(Path(p).stat().st_size == size and Path(p).stat().st_mtime_ns == mtime
               for p, size, mtime in memo["files"]) and isinstance(memo["hash"], str):
            return memo
    except (OSError, ValueError, KeyError, TypeError):
        pass
    paths = source_closure(*modules)
    digest = hashlib.sha1()
    for path in paths:
        digest.update(str(path.relative_to(_PACKAGE)).encode() + b"\0" + path.read_bytes())
    memo = {"hash": digest.hexdigest()[:16], "files": _signature(paths)}
    try:
        temporary = memo_path.with_name(memo_path.name + f".{os.getpid()}.tmp")
        temporary.write_text(json.dumps(memo))
        os.replace(temporary, memo_path)
    except OSError:
        pass
    return memo


# --- a lock between processes that build the same artefact -------------------------------------


@contextlib.contextmanager
def build_lock(path: Path, timeout_s: float = 600.0):
    """Hold an exclusive lock named after ``path`` (``path`` + ``.lock``) while building it, so
    that concurrent processes that need the same artefact build it once: the others wait, then
    find it built. Without ``fcntl`` (not POSIX) there is no lock, only the atomic rename."""
    try:
        import fcntl
    except ImportError:  # pragma: no cover - Windows
        yield
        return
    lock = path.with_name(path.name + ".lock")
    with open(lock, "a+") as handle:
        deadline = time.monotonic() + timeout_s
        while True:
            try:
                fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
                break
            except OSError:
                if time.monotonic() > deadline:
                    raise TimeoutError(f"{lock}: still locked after {timeout_s:g} s") from None
                time.sleep(0.05)
        try:
            yield
        finally:
            fcntl.flock(handle, fcntl.LOCK_UN)


# --- what is cached, and keeping it bounded ----------------------------------------------------

MAX_CACHE_BYTES = 200 * 2**20
"""The cache's size bound: past it, the least recently used entries go first."""

MAX_IDLE_DAYS = 30.0
"""Entries unused for longer than this are pruned."""


def cache_root() -> Path:
    """The cache's root folder (every package version below it); not created."""
    root = os.environ.get("DSMPEPC_CACHE_DIR")
    if root:
        return Path(root)
    try:
        import platformdirs

        return Path(platformdirs.user_cache_dir("dsmpepc_nlp"))
    except ImportError:  # platformdirs is a dependency; a bare checkout may lack it
        return Path(os.path.expanduser("~")) / ".cache" / "dsmpepc_nlp"


def touch(path: Path) -> None:
    """Mark a cache entry as used now (its modification time is its last use)."""
    try:
        os.utime(path)
    except OSError:
        pass


def _size(path: Path) -> int:
    if path.is_file():
        return path.stat().st_size
    return sum(p.stat().st_size for p in path.rglob("*") if p.is_file())


def entries() -> list:
    """Every cache entry: dicts with ``path``, ``version`` (of the package that made it),
    ``kind`` (``casadi``: a compiled NLP library; ``numba``: a compiled kernel folder),
    ``bytes`` and ``last_used`` (seconds since the epoch), oldest use first."""
    root, found = cache_root(), []
    if not root.is_dir():
        return found
    for version in sorted(p for p in root.iterdir() if p.is_dir()):
        for kind in sorted(p for p in version.iterdir() if p.is_dir()):
            for entry in kind.iterdir():
                if entry.name.endswith((".lock", ".tmp")) or entry.name.startswith("tmp"):
                    continue
                found.append({"path": entry, "version": version.name, "kind": kind.name,
                              "bytes": _size(entry), "last_used": entry.stat().st_mtime})
    return sorted(found, key=lambda e: e["last_used"])


def _remove(path: Path) -> None:
    if path.is_dir():
        shutil.rmtree(path, ignore_errors=True)
    else:
        path.unlink(missing_ok=True)
    path.with_name(path.name + ".lock").unlink(missing_ok=True)


def prune(max_bytes: int = MAX_CACHE_BYTES, max_idle_days: float = MAX_IDLE_DAYS,
          keep: tuple = ()) -> list:
    """Remove the entries of other package versions, those unused for ``max_idle_days``, and
    then the least recently used until the cache holds at most ``max_bytes``; ``keep`` (paths)
    are never removed. Returns the removed entries."""
    now, removed = time.time(), []
    listed = entries()
    kept = {Path(k).resolve() for k in keep}
    total = sum(e["bytes"] for e in listed)
    for entry in listed:
        if entry["path"].resolve() in kept:
            continue
        stale = (entry["version"] != package_version()
                 or now - entry["last_used"] > max_idle_days * 86400.0)
        if stale or total > max_bytes:
            _remove(entry["path"])
            total -= entry["bytes"]
            removed.append(entry)
    root = cache_root()
    if root.is_dir():
        for version in root.iterdir():
            if version.is_dir() and version.name != package_version():
                shutil.rmtree(version, ignore_errors=True)
    return removed


def clear() -> int:
    """Empty the cache (every package version); returns the bytes freed."""
    freed = sum(e["bytes"] for e in entries())
    root = cache_root()
    if root.is_dir():
        shutil.rmtree(root, ignore_errors=True)
    return freed


def numba_folder(module: str) -> Path:
    """The cache folder of the numba module ``module`` (dotted, in this package): keyed by its
    :func:`source_closure` (numba freezes imported constants, e.g. the parameter layout of
    ``cycle.PARAMETERS``, into the compiled code), numba's version and :func:`sources_stamp`
    (numba's index is valid only for the source path and stamp it was written for: a folder
    compiled from another checkout would look compiled and still compile in the first plan);
    created and marked used."""
    from importlib import metadata

    try:
        numba_version = metadata.version("numba")
    except metadata.PackageNotFoundError:
        numba_version = "none"
    short = module.rpartition(".")[2].strip("_")
    path = (cache_dir("numba")
            / f"{short}-{sources_hash(module)}-{numba_version}-{sources_stamp(module)[:8]}")
    path.mkdir(parents=True, exist_ok=True)
    touch(path)
    return path


def import_numba_module(name: str, folder: Path):
    """Import the numba module ``name`` (dotted, absolute) with numba's cache in ``folder``
    (raises ImportError without numba, OSError when the folder is not writable)."""
    import numba

    # numba's simple thread pool unless the user chose one: OpenMP's wake-up and barrier cost
    # milliseconds per call on a busy machine, which small batches (a plan's verdicts) cannot
    # afford. Set in the environment too: numba re-reads its configuration from there.
    os.environ.setdefault("NUMBA_THREADING_LAYER", "workqueue")
    numba.config.THREADING_LAYER = os.environ["NUMBA_THREADING_LAYER"]
    previous = numba.config.CACHE_DIR
    numba.config.CACHE_DIR = str(folder)
    try:  # numba picks the cache folder when the kernel is decorated, i.e. on import
        return importlib.import_module(name)
    finally:
        numba.config.CACHE_DIR = previous


@functools.lru_cache(maxsize=None)
def _loaded(name: str):
    try:
        return import_numba_module(name, numba_folder(name))
    except (ImportError, OSError):
        return None


def optional_numba_module(name: str):
    """The numba module ``name`` (dotted, absolute) with its cache in :func:`numba_folder`, or
    None when compiling is off (``DSMPEPC_NO_COMPILE``, read on every call), numba is missing
    or the cache is not writable: the caller then runs its numpy path."""
    return _loaded(name) if compile_enabled() else None
