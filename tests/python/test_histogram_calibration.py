"""bench/histogram_calibration.py: its synthetic members have the shapes they claim, disk by disk
(the mean |Delta y| of each shape's formula, within the members' scatter), and a short run of the
study gives shares of ensembles."""
import math
import os

import numpy as np
from scipy.special import ndtr

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


def test_a_short_study_gives_shares():
    shares = calibration.rejections(4, "gaussian", "light", 3, np.random.default_rng(1))
    assert all(0.0 <= s <= 1.0 for s in shares) and len(shares) == 3
