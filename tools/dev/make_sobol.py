"""Writes dsmpepc_nlp/solve/optimize/sobol4.npy: the first 4096 points of scipy's scrambled
4-D Sobol sequence for seeds 0 and 1, shape (2, 4096, 4). Shipped with the package so that a fresh
process's first plan neither imports scipy.stats (~0.35 s) nor draws them; any prefix of a
seed's points is what ``qmc.Sobol(d=4, scramble=True, rng=default_rng(seed)).random(n)``
returns (tests/test_sampling_data.py checks both against the installed scipy).

    python tools/dev/make_sobol.py
"""

from pathlib import Path

import numpy as np
from scipy.stats import qmc

POINTS, SEEDS = 4096, (0, 1)

if __name__ == "__main__":
    data = np.stack([qmc.Sobol(d=4, scramble=True, rng=np.random.default_rng(seed)).random(POINTS)
                     for seed in SEEDS])
    path = (Path(__file__).resolve().parents[2]            # the checkout: this is tools/dev/
            / "dsmpepc_nlp" / "solve" / "optimize" / "sobol4.npy")
    np.save(path, data)
    import scipy

    print(f"{path}: {data.shape}; set starts.SHIPPED_SOBOL_SCIPY = {scipy.__version__!r}")
