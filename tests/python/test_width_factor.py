"""bench/width_factor.py: the ratio of the curvature of a wide box to a 40 R box's at each height,
their weighted mean and the power of H in them, from width pairs' records (compare.py --json)."""
import json
import math
import os

import pytest

from script_module import load_script

HERE = os.path.dirname(os.path.abspath(__file__))
wf = load_script(os.path.join(HERE, "..", "..", "bench", "width_factor.py"))


def point(width, height, members, bond=1000):
    return (f"protocol A, bond_number {bond}, width {width}, height {height}, capture_radius 1, "
            f"members {members}")


def record(height, c_wide, c_narrow, wide_members=8, narrow_members=16, width=100, text=False):
    """A compare.py line of a wide box (A) against a 40 R box (B), relative errors 5 % and 4 %."""
    rows = []
    for q in wf.CURVATURES:
        row = {"quantity": q, "a": f"{c_wide:.6g} +- {0.05 * c_wide:.6g}",
               "b": f"{c_narrow:.6g} +- {0.04 * c_narrow:.6g}"}
        if not text:  # the numbers, as compare.py has written them since 2026-12-02
            row.update(a_value=c_wide, a_error=0.05 * c_wide, b_value=c_narrow,
                       b_error=0.04 * c_narrow)
        rows.append(row)
    return {"a_point": point(width, height, wide_members),
            "b_point": point(40, height, narrow_members), "rows": rows}


def write(path, records):
    with open(path, "w") as f:
        for r in records:
            f.write(json.dumps(r) + "\n")
    return str(path)


def test_a_power_of_H_in_the_ratio_is_recovered(tmp_path):
    heights = (90, 120, 180, 240)
    path = write(tmp_path / "paper-width-A-x-2026-01-01.jsonl",
                 [record(h, 2.0 * h ** -1.2, 2.0 * h ** -1.0, text=(h == 90)) for h in heights])
    s = wf.series(wf.pairs([path]))[(1000.0, 100.0)]
    assert s["heights"] == list(heights)
    for q in wf.CURVATURES:
        for h, (r, e) in zip(heights, s["ratios"][q]):
            assert r == pytest.approx(h ** -0.2, rel=1e-5)
            assert e == pytest.approx(r * math.hypot(0.05, 0.04), rel=1e-5)
        _, _, chi2, dof, (power, error) = s["fits"][q]
        assert power == pytest.approx(-0.2, abs=1e-5) and dof == 3 and chi2 > 0
        # The slope's error of a weighted line through ln H, each point's error sigma/r.
        x = [math.log(h) for h in heights]
        sxx = sum((v - sum(x) / 4) ** 2 for v in x)
        assert error == pytest.approx(math.hypot(0.05, 0.04) / math.sqrt(sxx), rel=1e-4)


def test_a_constant_factor_has_no_power_and_no_chi2(tmp_path):
    path = write(tmp_path / "paper-width-A-y-2026-01-01.jsonl",
                 [record(h, 0.9 * h ** -1.0, h ** -1.0) for h in (120, 240)])
    mean, error, chi2, dof, (power, _) = wf.series(wf.pairs([path]))[(1000.0, 100.0)]["fits"][
        wf.CURVATURES[0]]
    assert mean == pytest.approx(0.9) and chi2 == pytest.approx(0.0, abs=1e-12) and dof == 1
    assert power == pytest.approx(0.0, abs=1e-9)
    assert error == pytest.approx(0.9 * math.hypot(0.05, 0.04) / math.sqrt(2))


def test_ratios_of_equal_relative_errors_weigh_alike(tmp_path):
    """Ratios 0.8 and 1.25 with the same relative error: their mean is the geometric one, 1.0
    (a linear mean weighted by 1/e^2 would give 0.88, favouring the lower ratio)."""
    path = write(tmp_path / "paper-width-A-z-2026-01-01.jsonl",
                 [record(120, 0.8, 1.0), record(240, 1.25, 1.0)])
    mean, error, _, _, _ = wf.series(wf.pairs([path]))[(1000.0, 100.0)]["fits"][wf.CURVATURES[0]]
    assert mean == pytest.approx(1.0)
    assert error == pytest.approx(math.hypot(0.05, 0.04) / math.sqrt(2))


def test_the_pair_of_most_members_is_taken_and_other_widths_kept_apart(tmp_path):
    old = write(tmp_path / "paper-width-A-H120-2026-01-01.jsonl",
                [record(120, 1.0, 1.0, wide_members=4), record(120, 2.0, 1.0, width=200)])
    new = write(tmp_path / "paper-width-A-H120-2026-01-02.jsonl",
                [record(120, 0.8, 1.0, wide_members=8), record(120, 0.5, 1.0, wide_members=2),
                 record(120, 3.0, 1.0, narrow_members=8, width=300)])
    by = wf.series(wf.pairs([old, new]))
    assert by[(1000.0, 100.0)]["ratios"][wf.CURVATURES[0]][0][0] == pytest.approx(0.8)
    assert by[(1000.0, 100.0)]["pairs"][0]["members"] == (8, 16)
    assert by[(1000.0, 200.0)]["ratios"][wf.CURVATURES[0]][0][0] == pytest.approx(2.0)
    assert by[(1000.0, 300.0)]["fits"][wf.CURVATURES[0]][4] is None  # one height: no power


def test_a_narrow_curvature_not_resolved_from_zero_leaves_its_height_out(tmp_path):
    flat = record(180, 1.0, 1.0)
    for row in flat["rows"]:
        row.update(b_value=0.01, b_error=0.04)  # the 40 R box's c within its error of 0
    path = write(tmp_path / "paper-width-A-z-2026-01-01.jsonl",
                 [record(120, 0.9, 1.0), flat, record(240, 0.9, 1.0)])
    assert wf.series(wf.pairs([path]))[(1000.0, 100.0)]["heights"] == [120, 240]
