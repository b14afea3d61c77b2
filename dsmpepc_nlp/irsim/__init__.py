"""The IR-SIM adapter: the planner drives a robot of an IR-SIM world (docs/irsim.md).

IR-SIM (``pip install "dsmpepc_nlp[irsim]"``) is imported only when used; importing this
package does not need it.

- :mod:`.adapter`: :class:`IrsimAdapter`, from an IR-SIM environment to the planner's
  ``RobotConfig``, goal, ``RobotState`` and ``World``, and from a plan to IR-SIM's action.
- :mod:`.shapes`: IR-SIM bodies as circles (the robot's footprint, moving objects) and static
  shapes for the rasteriser; :mod:`.raster`: exact rasterisation into an ``OccupancyGrid``.
- :mod:`.inputs`: the oracle map, IR-SIM's lidar into the local map, noisy people into the
  tracker.
- :mod:`.loading`: importing IR-SIM quietly, building an environment from a world file.
- :mod:`.runner`, :mod:`.record`, :mod:`.episode`: a whole run under IR-SIM's judgement, its
  metrics, and the run as the product's Episode.
- :mod:`.benchmark`: ``dsmpepc benchmark irsim`` (worlds x seeds into a result table);
  :mod:`.export`: BARN worlds as IR-SIM world files; :mod:`.commands`: ``dsmpepc irsim``,
  ``dsmpepc benchmark irsim`` and ``dsmpepc irsim-export``. These three alone use the
  benchmarks' tables (``dsmpepc_nlp.bench``); the adapter itself never does.
"""

from .adapter import SENSING, IrsimAdapter
from .loading import load_env, require_irsim
from .raster import Lattice, rasterise

__all__ = ["SENSING", "IrsimAdapter", "Lattice", "load_env", "rasterise", "require_irsim"]
