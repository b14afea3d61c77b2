"""IR-SIM itself: importing it quietly, and building an environment from a world file.

IR-SIM is an optional dependency (``pip install "dsmpepc_nlp[irsim]"``); nothing here imports it
at module level. Its import prints backend messages on stdout and picks a matplotlib backend
for the whole process, and its logger writes to stdout; :func:`require_irsim` and
:func:`load_env` keep all of that on stderr and restore the backend, so ``--json`` output stays
one clean object. IR-SIM looks up a map image relative to the running script and the current
folder, not to the world file; :func:`load_env` resolves it against the world file's folder.
"""

from __future__ import annotations

import contextlib
import sys
import tempfile
from pathlib import Path

import yaml

from ..core.errors import InputError, MissingExtra

INSTALL_HINT = 'the IR-SIM adapter needs IR-SIM: pip install "dsmpepc_nlp[irsim]"'
"""The message of the :class:`~dsmpepc_nlp.core.errors.MissingExtra` raised without IR-SIM."""
LOG_LEVEL = "WARNING"
"""IR-SIM's console log level (its collisions and clipped commands are warnings), on stderr."""


@contextlib.contextmanager
def _quiet_stdout():
    """Everything printed on stdout inside goes to stderr (IR-SIM's prints and log sink)."""
    with contextlib.redirect_stdout(sys.stderr):
        yield


def require_irsim():
    """The ``irsim`` module, imported with its messages on stderr and the process's matplotlib
    backend kept; :class:`~dsmpepc_nlp.core.errors.MissingExtra` when it is not installed."""
    if sys.modules.get("irsim") is not None:
        return sys.modules["irsim"]
    import matplotlib

    backend = matplotlib.get_backend()
    try:
        with _quiet_stdout():
            import irsim
    except ImportError as exc:
        raise MissingExtra(INSTALL_HINT) from exc
    with contextlib.suppress(Exception):      # IR-SIM switched the backend at import
        import matplotlib.pyplot as plt

        if not plt.get_fignums():
            matplotlib.use(backend)
    return irsim


def _map_path(world: dict) -> tuple:
    """``(container, key, path)`` of the world's ``obstacle_map`` image path, or Nones."""
    value = world.get("obstacle_map")
    if isinstance(value, str):
        return world, "obstacle_map", value
    if isinstance(value, dict) and value.get("name", "image") == "image" \
            and isinstance(value.get("path"), str):
        return value, "path", value["path"]
    return None, None, None


def resolved_config(path: Path) -> tuple[dict, bool]:
    """The parsed world file with a relative ``obstacle_map`` image path made absolute against
    the file's folder (when the image is there), and whether anything changed.

    Raises
    ------
    InputError
        The file is missing, unreadable, not YAML or not a mapping.
    """
    if not path.is_file():
        raise InputError(f"{path}: no such IR-SIM world file")
    try:
        parsed = yaml.safe_load(path.read_text())
    except (OSError, yaml.YAMLError) as exc:
        raise InputError(f"{path}: not a readable YAML world file: {exc}") from None
    if not isinstance(parsed, dict):
        raise InputError(f"{path}: expected a mapping with world, robot and obstacle blocks")
    blocks = parsed["irsim"] if isinstance(parsed.get("irsim"), dict) else parsed
    world = blocks.get("world") if isinstance(blocks.get("world"), dict) else {}
    container, key, image = _map_path(world)
    if image is None or Path(image).is_absolute():
        return parsed, False
    beside = (path.parent / image).resolve()
    if beside.is_file():
        container[key] = str(beside)
        return parsed, True
    return parsed, False          # IR-SIM searches on (its folders); it says if it finds none


def load_env(path, *, seed: int | None = None, frames: bool = False, out=None):
    """An IR-SIM environment from the world file ``path``, without a window.

    Parameters
    ----------
    path : str or Path
        The world YAML. A relative ``world.obstacle_map`` image is looked up beside it first.
    seed : int, optional
        Seed of IR-SIM's own random generator (random placements, motion and sensor noise).
    frames : bool
        Keep a figure and save a frame per rendered step (for IR-SIM's animation, written by
        ``env.end()`` into ``out``); otherwise the environment is headless (no figure at all).
    out : str or Path, optional
        Folder of the animation and its frame buffer (default: the current folder).

    Raises
    ------
    InputError
        Naming the file: missing, not YAML, or rejected by IR-SIM (its message follows).
    """
    irsim = require_irsim()
    path = Path(path)
    parsed, changed = resolved_config(path)
    options = dict(display=False, headless=not frames, save_ani=frames, seed=seed,
                   log_level=LOG_LEVEL)
    with contextlib.ExitStack() as stack:
        stack.enter_context(_quiet_stdout())
        world_file = path
        if changed:     # a copy with the same name, so IR-SIM names the world as the file
            folder = Path(stack.enter_context(tempfile.TemporaryDirectory()))
            world_file = folder / path.name
            world_file.write_text(yaml.safe_dump(parsed, sort_keys=False))
        try:
            env = irsim.make(str(world_file), **options)
        except (KeyError, ValueError, TypeError, FileNotFoundError, NotImplementedError,
                AttributeError, AssertionError, ImportError) as exc:
            raise InputError(f"{path}: IR-SIM could not build this world: "
                             f"{type(exc).__name__}: {exc}") from None
    if frames:
        folder = str(Path(out if out is not None else ".").resolve())
        env.path_param.ani_path = folder
        env.path_param.ani_buffer_path = str(Path(folder) / f".{path.stem}-frames")
        env.path_param.fig_path = folder
    return env


def quiet(function, *args, **kwargs):
    """``function(*args, **kwargs)`` with stdout sent to stderr (an IR-SIM call that prints)."""
    with _quiet_stdout():
        return function(*args, **kwargs)
