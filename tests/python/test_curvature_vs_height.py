"""bench/curvature_vs_height.py: fig. 7's curvatures against H, the 40 R series and the width
pairs' points, with lines of c ~ 1/H."""
import os

import pytest

from script_module import load_script
from test_width_factor import write  # records as JSON lines, the path back

HERE = os.path.dirname(os.path.abspath(__file__))
cvh = load_script(os.path.join(HERE, "..", "..", "bench", "curvature_vs_height.py"))


def record(height, width, c_wide, c_narrow, narrow_members=16, bond=1000):
    """A compare.py line of a wide box (A, 2 members) against a 40 R box (B): c of both profiles
    the same, errors a tenth of it."""
    point = lambda w, n: (f"protocol A, bond_number {bond}, width {w}, height {height}, "
                          f"capture_radius 1, members {n}")
    rows = [{"quantity": q, "a_value": c_wide, "a_error": 0.1 * c_wide, "b_value": c_narrow,
             "b_error": 0.1 * c_narrow} for q in cvh.CURVATURES]
    return {"a_point": point(width, 2), "b_point": point(40, narrow_members), "rows": rows}


def test_pairs_give_each_ensemble_once_in_units_of_1e_4(tmp_path):
    # A 40 R ensemble that partners a 100 R and a 200 R box at H = 120 is one point; the H = 200
    # pair's narrow ensemble another.
    paths = [write(tmp_path / "paper-width-A-H120-2026-01-01.jsonl",
                   [record(120, 100, 1.1e-3, 1.4e-3), record(120, 200, 1.0e-3, 1.4e-3)]),
             write(tmp_path / "paper-width-A-H200-2026-01-02.jsonl",
                   [record(200, 100, 0.9e-3, 0.8e-3, narrow_members=8)])]
    points = cvh.pair_points(paths)
    key = lambda p: (p["width"], p["height"])
    assert sorted(map(key, points)) == [(40.0, 120.0), (40.0, 200.0), (100.0, 120.0),
                                        (100.0, 200.0), (200.0, 120.0)]
    by_key = {key(p): p for p in points}
    for q in cvh.CURVATURES:
        assert by_key[(40.0, 120.0)][q] == pytest.approx((14.0, 1.4))
        assert by_key[(200.0, 120.0)][q] == pytest.approx((10.0, 1.0))
        assert by_key[(100.0, 200.0)][q] == pytest.approx((9.0, 0.9))
    assert by_key[(40.0, 200.0)]["members"] == 8 and by_key[(100.0, 120.0)]["members"] == 2


def test_one_over_h_passes_through_its_anchor_and_halves_at_twice_the_height():
    line = cvh.one_over_h([400.0, 800.0, 1600.0], 800.0, 4.0)
    assert line == pytest.approx([8.0, 4.0, 2.0])


def test_the_records_draw(tmp_path):
    # Every width pair on record gives its wide point, and every 40 R series a value with its
    # error at each of its heights; the figure is written.
    paths = sorted(
        os.path.join(cvh.width_factor.RESULTS, name)
        for name in os.listdir(cvh.width_factor.RESULTS) if name.startswith("paper-width-A-"))
    pairs = cvh.width_factor.pairs(paths)
    points = cvh.pair_points(paths)
    for bond, wide, height in pairs:
        assert any(p["bond"] == bond and p["width"] == wide and p["height"] == height
                   for p in points)
    narrow = cvh.narrow_series()
    for s in narrow:
        for values, errors in s["values"].values():
            assert len(values) == len(errors) == len(s["heights"])
            assert all(v > 0 and 0 < e < v for v, e in zip(values, errors))
    out = tmp_path / "c.png"
    cvh.draw(str(out), narrow, points)
    assert out.stat().st_size > 10_000
