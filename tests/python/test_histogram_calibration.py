"""bench/histogram_calibration.py: its synthetic members have the shapes they claim, disk by disk
(the mean |Delta y| of each shape's formula, within the members' scatter), and the study's
rejection rates are the tests' design rate for a right shape."""
import math
import os

import numpy as np
from scipy.special import ndtr

from rates import binomial_quantile
from script_module import load_script

HERE = os.path.dirname(os.path.abspath(__file__))
calibration = load_script(os.path.join(HERE, "..", "..", "bench", "histogram_calibration.py"))


def test_members_have_the_shapes_mean():
    rng = np.random.default_rng(5)
    centre = 0.5 * (calibration.EDGES[1:] + calibration.EDGES[:-1])
    a = -calibration.MEAN / calibration.WIDTH
    phi = math.exp(-0.5 * a * a) / math.sqrt(2 * math.pi)
    expected = {"exponential": calibration.DECAY,
                "gaussian": calibration.MEAN + calibration.WIDTH * phi / (1 - ndtr(a))}
    for shape, mean in expected.items():
        for sizes in ("light", "heavy"):
            rows = np.array([calibration.member_row(rng, shape, sizes) for _ in range(40)])
            means = rows @ centre / rows.sum(axis=1)
            error = means.std(ddof=1) / math.sqrt(len(means))
            # the bins' centres move a mean by under 0.01 R (an exponential's of 3 R to
            # 0.5 e^(-1/6) / (1 - e^(-1/6)) + 0.25 = 3.007 R); the errors are 0.05-0.2 R
            assert abs(means.mean() - mean) < 4 * error + 0.03, (shape, sizes, means.mean(), mean)


def test_a_right_shape_is_rejected_at_the_terms_rate_and_a_wrong_one_mostly():
    """100 ensembles of 8 members: the true shape's next two terms reject it at their design
    rate, 1 % (at most the binomial's 99.9 % quantile of 100 draws); the exponential's terms
    reject it for a Gaussian more often than not (the study's power with light avalanches)."""
    bound = binomial_quantile(100, 0.01) / 100
    by_terms, _, _ = calibration.rejections(8, "exponential", "light", 100,
                                            np.random.default_rng(1))
    assert by_terms <= bound
    by_terms, _, exponential_rejected = calibration.rejections(8, "gaussian", "light", 100,
                                                               np.random.default_rng(2))
    assert by_terms <= bound and exponential_rejected > 0.5
