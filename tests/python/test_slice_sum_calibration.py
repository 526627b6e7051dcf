"""bench/slice_sum_calibration.py: its synthetic disks scatter about the profile as it says (the
avalanche's shared offset and each disk's own jitter add their variances), and the study rejects
a right sum at its bound's rate."""
import math
import os

import numpy as np

from rates import binomial_quantile
from script_module import load_script

HERE = os.path.dirname(os.path.abspath(__file__))
calibration = load_script(os.path.join(HERE, "..", "..", "bench", "slice_sum_calibration.py"))


def test_disks_scatter_about_the_profile():
    rng = np.random.default_rng(3)
    for sizes in ("light", "heavy"):
        offsets, variances = [], []
        for _ in range(40):
            y, dy = calibration.member(rng, sizes)
            assert (y >= 0).all() and (y < calibration.H).all()
            r = dy - calibration.profile(y)
            offsets.append(r.mean())
            variances.append(r.var())
        expected = calibration.SHARED ** 2 + calibration.OWN ** 2
        # a member's mean offset scatters by SHARED over its avalanches' number, at least 1400/500
        assert abs(np.mean(offsets)) < 4 * np.std(offsets, ddof=1) / math.sqrt(len(offsets))
        assert abs(np.mean(variances) - expected) < 0.1 * expected, (sizes, np.mean(variances))


def test_a_right_sum_is_rejected_at_the_bounds_rate():
    """40 ensembles of 8 members: the right sum's cubic is beyond its 99 % bound in at most the
    binomial's 99.9 % quantile of 40 draws at 1 %; the arch's sum has a longer tail towards small
    |Delta y| (its cubic's mean t negative)."""
    trials, failed, sum_t = calibration.rejections(8, "light", 40, np.random.default_rng(1))
    assert trials == 40 and failed <= binomial_quantile(40, 0.01)
    assert sum_t < 0
