"""bench/height_exponents.py: the weighted power law through a series' values against H, and the
Bo = 1e2 series read from its records (bo1e2-heights-2026-12-06.jsonl, bo1e2-H400-regions)."""
import math
import os

import pytest

from script_module import load_script

HERE = os.path.dirname(os.path.abspath(__file__))
he = load_script(os.path.join(HERE, "..", "..", "bench", "height_exponents.py"))
SERIES = {"heights": (120, 180, 240, 400), "members": (8, 8, 8, 8)}


def test_an_exact_power_law_gives_its_exponent_and_no_chi2():
    values = [3.0 * h ** -1.1 for h in SERIES["heights"]]
    errors = [0.05 * v for v in values]
    p, e, reduced = he.exponent(SERIES, values, errors, 120, 400)
    assert p == pytest.approx(-1.1, abs=1e-12) and reduced == pytest.approx(0.0, abs=1e-20)
    # Two heights: the line through them, no degrees of freedom left; the error of the slope of
    # two points, each sigma/y widened by sqrt(7/5) for 8 members.
    p, e, reduced = he.exponent(SERIES, values, errors, 120, 180)
    sigma = 0.05 * math.sqrt(7 / 5)
    assert p == pytest.approx(-1.1, abs=1e-12) and reduced is None
    assert e == pytest.approx(sigma * math.sqrt(2) / math.log(180 / 120), rel=1e-9)


def test_a_scatter_beyond_the_errors_widens_the_error():
    values = [3.0 * h ** -1.1 * f for h, f in zip(SERIES["heights"], (1.0, 1.3, 0.8, 1.0))]
    errors = [0.01 * v for v in values]
    p, e, reduced = he.exponent(SERIES, values, errors, 120, 400)
    assert reduced > 1
    unscaled = he.exponent(SERIES, values, [x * math.sqrt(reduced) for x in errors], 120, 400)[1]
    assert e == pytest.approx(unscaled, rel=1e-9)


def test_a_point_of_three_members_or_fewer_is_not_widened_and_leaves_no_chi2():
    """As the program: a point of 3 or 2 members keeps its error (sqrt((n-1)/(n-3)) has no value
    there) and the fit reports no chi2 to judge; the others are widened as always."""
    few = {"heights": (120, 180, 240, 400), "members": (8, 3, 2, 8)}
    values = [3.0 * h ** -1.1 * f for h, f in zip(few["heights"], (1.0, 1.1, 0.9, 1.0))]
    errors = [0.05 * v for v in values]
    p, e, reduced = he.exponent(few, values, errors, 120, 400)
    assert reduced is None and -1.3 < p < -0.9
    p, e, reduced = he.exponent(few, values, errors, 120, 180)
    sigma = 0.05 * math.hypot(math.sqrt(7 / 5), 1.0)
    assert e == pytest.approx(sigma / math.log(180 / 120), rel=1e-9)


def test_the_bo1e2_series_is_read_from_its_records():
    table = he.SERIES["1e2"]["table"]()
    for name, (values, errors) in table.items():
        assert len(values) == len(errors) == len(he.SERIES["1e2"]["heights"]), name
        assert all(v > 0 and 0 < e < v for v, e in zip(values, errors)), (name, values, errors)
