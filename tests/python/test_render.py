"""tools/render_deposit.py: a deposit drawn by ParaView under xvfb-run, and ParaView started
again when it aborts (Debian's ParaView 5.11 now and then fails to open a display that is
there; on an 8-bit screen it always aborts)."""

import os
import shutil
import subprocess
import sys

import pytest

import loosepack
from script_module import load_script

TOOL = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "tools",
                    "render_deposit.py")
render_deposit = load_script(TOOL)
SCAN = {
    "scan": {"name": "render", "seed": 5, "seeds": 1, "protocol": "A"},
    "system": {"width": 16.0, "height": 16.0, "bond_number": 1000},
}


@pytest.fixture(scope="module")
def deposit(tmp_path_factory):
    pytest.importorskip("paraview.simple",
                        reason="python3-paraview is not installed (scripts/install-deps.sh --test)")
    if shutil.which("xvfb-run") is None:
        pytest.skip("xvfb-run is not installed (scripts/install-deps.sh --test)")
    out = tmp_path_factory.mktemp("render") / "deposit.h5"
    return loosepack.run(SCAN, out, progress=False, args=["--snapshots"])


def render(deposit, png, depth):
    return subprocess.run(["xvfb-run", "-a", "-s", "-screen 0 640x480x%d" % depth, sys.executable,
                           TOOL, deposit.path, str(png), "--size", "200", "160"],
                          capture_output=True, text=True)


def test_the_deposit_is_drawn_on_a_white_background(deposit, tmp_path):
    import matplotlib.image
    png = tmp_path / "deposit.png"
    done = render(deposit, png, 24)
    if done.returncode != 0 and "ParaView aborted" in done.stderr:
        # Every ParaView process on one X server aborted (seen once on a machine busy with two
        # other tests): the picture is this test's subject, so once more on a fresh X server.
        print("first X server: " + done.stderr[:1500])
        done = render(deposit, png, 24)
    assert done.returncode == 0, done.stderr[-2000:]
    assert done.stdout.split()[-1] == str(png)
    image = matplotlib.image.imread(str(png))
    assert image.shape[:2] == (160, 200)
    rgb = image[:, :, :3]
    white = (rgb > 0.99).all(axis=2)
    # The corners are background; the disks (coloured by Delta y, the "Blues" map) and the
    # contact lines cover part of the rest.
    assert white[0, 0] and white[-1, 0]
    assert 0.05 < 1.0 - white.mean() < 0.95


def test_a_deposit_without_contacts_is_drawn(deposit, tmp_path):
    """A ballistic deposit (protocol B) stores no contact forces: its disks alone are drawn."""
    import matplotlib.image
    out = tmp_path / "ballistic.h5"
    scan = {"scan": {"name": "ballistic", "seed": 5, "seeds": 1, "protocol": "B"},
            "system": {"width": 16.0, "height": 16.0, "bond_number": 1000}}
    ballistic = loosepack.run(scan, out, progress=False, args=["--snapshots"])
    png = tmp_path / "ballistic.png"
    done = render(ballistic, png, 24)
    if done.returncode != 0 and "ParaView aborted" in done.stderr:
        done = render(ballistic, png, 24)  # as above: once more on a fresh X server
    assert done.returncode == 0, done.stderr[-2000:]
    rgb = matplotlib.image.imread(str(png))[:, :, :3]
    assert 0.05 < 1.0 - (rgb > 0.99).all(axis=2).mean() < 0.95


def test_paraview_is_started_again_when_it_aborts(deposit, tmp_path):
    """On an 8-bit screen every ParaView process aborts: the tool tries ATTEMPTS times, says
    so, and fails with the screen it needs named."""
    done = render(deposit, tmp_path / "never.png", 8)
    assert done.returncode == 1
    assert done.stderr.count("starting it again") == render_deposit.ATTEMPTS - 1
    assert (f"ParaView aborted {render_deposit.ATTEMPTS} times; it needs an X display of 24-bit "
            "colour") in done.stderr
    assert not (tmp_path / "never.png").exists()


@pytest.fixture(scope="module")
def failed(tmp_path_factory):
    """A run with --snapshots whose member 1 (seed 1) fails (LOOSEPACK_INJECT_NAN=1): its state
    is failure_1."""
    os.environ["LOOSEPACK_INJECT_NAN"] = "1"
    try:
        scan = {"scan": {"seeds": 2}, "system": {"width": 12.0, "height": 12.0, "bond_number": 30}}
        out = tmp_path_factory.mktemp("failed") / "fail.h5"
        return loosepack.run(scan, out, progress=False, args=["--snapshots"])
    finally:
        del os.environ["LOOSEPACK_INJECT_NAN"]


def test_a_failed_member_is_its_state_at_the_failure_not_its_snapshot(failed):
    """The tool draws the failed member's failure export, with the title and reason of a
    failure; the finished member's deposit, untitled."""
    xmf, title = render_deposit.member_file(failed.path, 0, 1)
    assert xmf.endswith("fail_p0000_s1_failure.xmf") and os.path.exists(xmf)
    assert title == ("FAILED member (point 0, seed 1): state at the failure",
                     "non-finite position or velocity (NaN or Inf)")
    xmf, title = render_deposit.member_file(failed.path, 0, 0)
    assert xmf.endswith("fail_p0000_s0.xmf") and title is None

