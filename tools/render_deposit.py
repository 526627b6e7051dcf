#!/usr/bin/env python3
"""Render one deposit of a result file with ParaView: the disks as circles coloured by how far
each fell during the deposition (Delta y = y_e - y_i), and the contacts as lines coloured by
their normal force (force chains; tension, which cohesion allows, blue). Reads the XDMF files
`loosepack export` writes.

    loosepack run examples/render.toml -o out/render.h5 --snapshots
    xvfb-run -a -s "-screen 0 1280x1024x24" /usr/bin/python3 tools/render_deposit.py \
        out/render.h5 docs/figures/deposit_bo1e3.png

Needs Debian's python3-paraview and an X display of 24-bit colour: on a machine without one,
xvfb-run with the screen above (Debian's default; ParaView aborts on an 8-bit screen, the
default of some other xvfb-run).
ParaView renders in a process of its own, started again up to ATTEMPTS times when it aborts:
Debian's ParaView 5.11 now and then fails to open a display that is there (on a busy machine),
and a second process renders.

A failed member (members/failure not 0) left no deposit: its state at the failure is drawn
(failure_K, the export's `_sK_failure.xmf`), with the title "FAILED member ...: state at the failure" and the reason in the
picture, and a line on stderr that says so."""

import argparse
import os
import subprocess
import sys

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "python"))
import loosepack  # noqa: E402


def label(bar, title):
    """A colour legend's title, in black on the white background."""
    bar.Title = title
    bar.ComponentTitle = ""
    bar.TitleColor = [0, 0, 0]
    bar.LabelColor = [0, 0, 0]


ATTEMPTS = 8
ABORTED = (-6, 134)  # SIGABRT, as the process or as a shell reports it


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("result", help="result file written with --snapshots")
    ap.add_argument("png", help="picture to write")
    ap.add_argument("--point", type=int, default=0)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--size", type=int, nargs=2, default=[900, 900], help="pixels")
    ap.add_argument("--xmf", help=argparse.SUPPRESS)  # the ParaView process: render this file
    ap.add_argument("--title", help=argparse.SUPPRESS)  # ... with this title
    args = ap.parse_args()
    if args.xmf:
        render(args.xmf, args.png, args.size, args.title)
        return

    xmf, title = member_file(args.result, args.point, args.seed)
    command = [sys.executable, os.path.abspath(__file__), args.result, args.png, "--xmf", xmf,
               "--size", str(args.size[0]), str(args.size[1])]
    if title:
        print("render_deposit.py: %s: point %d, seed %d failed (%s): drawing its state at the "
              "failure (failure_%d), not a deposit" % (args.result, args.point, args.seed,
                                                        title[1], args.seed), file=sys.stderr)
        command += ["--title", "\n".join(title)]
    for attempt in range(1, ATTEMPTS + 1):
        run = subprocess.run(command, capture_output=True, text=True)
        if run.returncode not in ABORTED:
            sys.stdout.write(run.stdout)
            sys.stderr.write(run.stderr)
            if run.returncode < 0:  # no display at all: ParaView dies of a segmentation fault
                sys.exit("render_deposit.py: ParaView died of signal %d; is there an X display "
                         "(DISPLAY, or xvfb-run)?" % -run.returncode)
            sys.exit(run.returncode)
        if attempt < ATTEMPTS:
            print("render_deposit.py: ParaView aborted (attempt %d of %d), starting it again"
                  % (attempt, ATTEMPTS), file=sys.stderr)
    sys.stderr.write(run.stderr)
    sys.exit("render_deposit.py: ParaView aborted %d times; it needs an X display of 24-bit colour "
             "(xvfb-run -s \"-screen 0 1280x1024x24\")" % ATTEMPTS)


def member_file(result, point, seed):
    """The XDMF file `loosepack export` writes of one member of the result file, and None for a
    finished member's deposit or, for a failed member's state at the failure, the picture's title
    as two lines (what it is, and the reason). Exits with the export's message, or with what it
    wrote where it wrote no file of that state."""
    files = subprocess.run([loosepack.find_program(), "export", result, "--point", str(point),
                            "--seed", str(seed)], capture_output=True, text=True)
    if files.returncode != 0:
        sys.exit(files.stderr.strip())
    failure = failure_reason(result, point, seed)
    ending = "_s%d_failure.xmf" % seed if failure is not None else "_s%d.xmf" % seed
    # One path a line, which may hold spaces.
    xmf = [f for f in files.stdout.splitlines() if f.endswith(ending)]
    if not xmf:
        wrote = ", ".join(files.stdout.splitlines()) or "nothing"
        sys.exit("render_deposit.py: %s: no %s of point %d, seed %d to draw (export wrote: %s)"
                 % (result, "state at the failure" if failure is not None else "snapshot", point,
                    seed, wrote))
    if failure is None:
        return xmf[0], None
    return xmf[0], ("FAILED member (point %d, seed %d): state at the failure" % (point, seed),
                    failure)


def failure_reason(result, point, seed):
    """The reason member `seed` of point `point` failed (members/failure not 0), or None when it
    finished; "unknown reason" where the file holds no failure_K to name it."""
    res = loosepack.load(result)
    members = res.members(point)
    if not (members["failure"][members["seed_index"] == seed] != 0).any():
        return None
    try:
        return str(res.failure(point, seed).attrs.get("failure", "unknown reason"))
    except KeyError:
        return "unknown reason"


def render(xmf, png, size, title=None):
    """The picture of one snapshot's XDMF file, written to png at size pixels, with `title` (a
    failed member's) at its top left."""
    from paraview import simple as pv
    reader = pv.XDMFReader(FileNames=[xmf])
    view = pv.CreateRenderView()
    view.ViewSize = size
    view.OrientationAxesVisibility = 0
    view.Background = [1, 1, 1]
    try:
        view.UseColorPaletteForBackground = 0
    except AttributeError:
        pass
    disks = pv.ExtractBlock(Input=reader, Selectors=["/Root/disks"])
    contacts = pv.ExtractBlock(Input=reader, Selectors=["/Root/contacts"])
    circles = pv.Glyph(Input=disks, GlyphType="2D Glyph")
    circles.GlyphType.GlyphType = "Circle"
    circles.GlyphType.Filled = 1
    circles.ScaleArray = ["POINTS", "radius"]
    circles.ScaleFactor = 2.0
    circles.GlyphMode = "All Points"
    shown = pv.Show(circles, view)
    pv.ColorBy(shown, ("POINTS", "delta_y"))
    lut = pv.GetColorTransferFunction("delta_y")
    lut.ApplyPreset("Blues", True)
    lut.InvertTransferFunction()
    shown.SetScalarBarVisibility(view, True)
    label(pv.GetScalarBar(lut, view), "Delta y [R]")
    if contacts.CellData["normal"] is not None:  # none in a snapshot without contacts (B)
        show_contacts(pv, contacts, view)
    if title:
        text = pv.Show(pv.Text(Text=title), view)
        text.WindowLocation = "Upper Left Corner"
        text.Color = [0.8, 0, 0]
        text.FontSize = 12
    view.InteractionMode = "2D"
    pv.ResetCamera(view)
    pv.SaveScreenshot(png, view, ImageResolution=size)
    print(png)


def show_contacts(pv, contacts, view):
    """The contacts as lines coloured by their normal force, about zero."""
    lines = pv.Show(contacts, view)
    pv.ColorBy(lines, ("CELLS", "normal"))
    forces = pv.GetColorTransferFunction("normal")
    forces.ApplyPreset("Cool to Warm", True)  # tension (cohesion) blue, compression red
    low, high = contacts.CellData["normal"].GetRange()
    bound = max(abs(low), abs(high))
    forces.RescaleTransferFunction(-bound, bound)
    lines.LineWidth = 2.0
    lines.SetScalarBarVisibility(view, True)
    label(pv.GetScalarBar(forces, view), "normal force [m g]")


if __name__ == "__main__":
    main()
