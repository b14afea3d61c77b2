"""The shipped Sobol points are scipy's, so the sampler's z are the same with or without them."""

import numpy as np
import pytest

from dsmpepc_nlp.solve.optimize import starts


@pytest.mark.parametrize("seed", [0, 1])
@pytest.mark.parametrize("count", [4, 256, 4096])
def test_the_shipped_points_are_scipys_scrambled_sobol(seed, count):
    qmc = pytest.importorskip("scipy.stats.qmc")
    import scipy

    if scipy.__version__ != starts.SHIPPED_SOBOL_SCIPY:
        pytest.skip(f"drawn with scipy {starts.SHIPPED_SOBOL_SCIPY}, this is {scipy.__version__}")
    drawn = qmc.Sobol(d=4, scramble=True, rng=np.random.default_rng(seed)).random(count)
    starts._unit_sobol.cache_clear()
    assert np.array_equal(starts._unit_sobol(count, seed), drawn)


def test_other_seeds_and_counts_are_drawn_and_kept_in_the_cache(tmp_path, monkeypatch):
    pytest.importorskip("scipy.stats.qmc")
    monkeypatch.setenv("DSMPEPC_CACHE_DIR", str(tmp_path))
    starts._unit_sobol.cache_clear()
    points = starts._unit_sobol(8, 7)
    assert points.shape == (8, 4) and np.all((points >= 0) & (points < 1))
    assert len(list(tmp_path.rglob("sobol4-8-7-*.npy"))) == 1
