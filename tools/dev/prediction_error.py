"""How far a constant-velocity prediction of real pedestrians is off, by look-ahead.

For every pedestrian of the ETH/UCY recordings of the given scenes and every annotated step
that follows another one step earlier, the velocity is that last step's displacement over the
step time and the prediction moves the pedestrian on at it; the error at look-ahead ``tau`` is
the difference to the annotated position then. Printed per look-ahead: the RMS error per axis
(m) and that over ``tau`` (m/s), the slope a bell widening with the look-ahead would take
(``cost.sigma_dynamic_growth``, docs/method.md section 3.2)::

    python tools/dev/prediction_error.py --data DIR eth hotel
"""

from __future__ import annotations

import argparse

import numpy as np

from dsmpepc_nlp.bench.crowds import load_recording, scene_files


def errors(data, scene: str, horizon: float) -> dict:
    """``{tau: array (n, 2)}`` of prediction errors of ``scene``, tau up to ``horizon`` s."""
    found = {}
    for path in scene_files(data, scene):
        recording = load_recording(path)
        step = recording.step_time
        times = recording.time(recording.frame)
        for pid in np.unique(recording.ped):
            mine = recording.ped == pid
            order = np.argsort(times[mine])
            t, xy = times[mine][order], recording.xy[mine][order]
            for i in range(1, len(t)):
                if abs(t[i] - t[i - 1] - step) > 1e-6:
                    continue
                velocity = (xy[i] - xy[i - 1]) / step
                for j in range(i + 1, len(t)):
                    tau = t[j] - t[i]
                    if tau > horizon + 1e-6:
                        break
                    found.setdefault(round(tau, 1), []).append(xy[j] - (xy[i] + velocity * tau))
    return {tau: np.array(e) for tau, e in sorted(found.items())}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", required=True, help="the ETH/UCY folder (one folder a scene)")
    parser.add_argument("--horizon", type=float, default=5.0, help="longest look-ahead, s")
    parser.add_argument("scenes", nargs="+")
    args = parser.parse_args()
    for scene in args.scenes:
        print(scene)
        for tau, error in errors(args.data, scene, args.horizon).items():
            rms = float(np.sqrt(np.mean(error ** 2)))
            print(f"  {tau:4.1f} s  {len(error):7d} predictions  RMS per axis {rms:5.2f} m"
                  f"  ({rms / tau:.3f} m/s)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
