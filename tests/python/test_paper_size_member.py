"""bench/paper_size_member.py on progress written by hand: a resumed run's CPU restarts from zero
and is added to the CPU of the runs before it in full, and the exponent is the slope of log CPU
against log disks (CPU = A disks^p gives p)."""

import json
import os

import pytest

from script_module import load_script

HERE = os.path.dirname(os.path.abspath(__file__))
SCRIPT = os.path.join(HERE, "..", "..", "bench", "paper_size_member.py")
psm = load_script(SCRIPT)


def test_a_resumed_run_adds_to_the_runs_before_it():
    # Run 1 stops at 120 s; run 2 starts again from its checkpoint (fewer disks than run 1's
    # last sample) and its own CPU counts from zero.
    rows = [(1, 60.0, 1000), (1, 120.0, 1500), (2, 60.0, 1400), (2, 90.0, 1600)]
    assert psm.cumulative(rows) == [(60.0, 1000), (120.0, 1500), (180.0, 1400), (210.0, 1600)]


@pytest.mark.parametrize("p", [1.5, 3.0])
def test_the_exponent_of_a_power_law(p):
    points = [(2e-6 * d**p, d) for d in range(500, 17001, 500)]
    assert psm.exponent(points) == pytest.approx(p, rel=1e-12)


def test_too_few_samples_give_no_exponent():
    assert psm.exponent([(10.0, 1000), (20.0, 1010)]) is None
    assert psm.exponent([(10.0, 900), (20.0, 2000)]) is None  # below 1 000 disks


def test_the_summary_of_a_progress_file(tmp_path, capsys):
    path = tmp_path / "progress.tsv"
    lines = ["run\tepoch_s\tcpu_s\tdisks"]
    lines += [f"1\t{k}\t{1e-3 * d**2:.1f}\t{d}" for k, d in enumerate((600, 1000, 2000, 4000))]
    path.write_text("\n".join(lines) + "\n")
    psm.main(str(path))
    out = json.loads(capsys.readouterr().out)
    assert out["cpu_s"] == 16000.0 and out["disks"] == 4000 and out["runs"] == 1
    assert out["cpu_s_at_disks"] == [[600, 360.0], [1000, 1000.0], [2000, 4000.0], [4000, 16000.0]]
    assert out["exponent_from_1000_disks"] == pytest.approx(2.0, abs=0.01)
