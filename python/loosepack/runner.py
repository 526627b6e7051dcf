"""Running the loosepack program from Python: a scan as a dict or a TOML file, progress shown,
the result loaded."""

import math
import os
import re
import shutil
import signal
import subprocess
import sys
import tempfile

from .results import load

# The exit codes of `loosepack run` (docs/OUTPUT.md, "Exit codes").
EXIT_REFUSED = 2  # invalid input or a run refused before anything is computed
EXIT_MEMBERS_FAILED = 3


class LoosepackError(RuntimeError):
    """The program refused the input or failed; `returncode` and `stderr` say why."""

    def __init__(self, message, returncode, stderr):
        super().__init__(message)
        self.returncode = returncode
        self.stderr = stderr


def find_program(program=None):
    """The loosepack executable: `program`, else $LOOSEPACK, else `loosepack` on the PATH, else
    the build of the checkout this package lies in (build/loosepack), else PREFIX/bin/loosepack
    where this package is installed under PREFIX (in PREFIX/share/loosepack/python by
    `cmake --install`; in PREFIX/lib/pythonX.Y/site-packages or lib/python3/dist-packages by
    pip)."""
    candidates = [program, os.environ.get("LOOSEPACK"), shutil.which("loosepack"),
                  os.path.join(os.path.dirname(__file__), "..", "..", "build", "loosepack"),
                  _installed_program()]
    for c in candidates:
        if c and os.path.isfile(c) and os.access(c, os.X_OK):
            return os.path.abspath(c)
    raise FileNotFoundError("no loosepack program: build it (./scripts/build.sh), put it on the "
                            "PATH, or set LOOSEPACK=/path/to/loosepack")


# A package installed under PREFIX: by `cmake --install` (PREFIX/share/loosepack/python) or by
# pip (PREFIX/lib/pythonX.Y/site-packages, Debian's PREFIX/lib/python3/dist-packages).
_INSTALLED = re.compile(r"(.*)/(share/loosepack/python|lib(64)?/python3(\.\d+)?/"
                        r"(site|dist)-packages)/loosepack")


def _installed_program():
    """PREFIX/bin/loosepack where this package lies installed under PREFIX, else None."""
    m = _INSTALLED.fullmatch(os.path.abspath(os.path.dirname(__file__)))
    return os.path.join(m.group(1) or "/", "bin", "loosepack") if m else None


def _toml_value(v):
    if type(v).__module__ == "numpy":  # a numpy scalar or array: as Python's own values
        v = v.tolist()
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, (int, float)):
        if isinstance(v, float) and math.isinf(v):
            return '"inf"' if v > 0 else '"-inf"'
        return repr(v)
    if isinstance(v, str):
        return '"' + v.replace("\\", "\\\\").replace('"', '\\"') + '"'
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    if isinstance(v, dict):  # an inline table: a range {from, to, points, log}
        return "{" + ", ".join("%s = %s" % (k, _toml_value(x)) for k, x in v.items()) + "}"
    raise TypeError("cannot write %r (%s) to a scan file" % (v, type(v).__name__))


def to_toml(scan):
    """A scan given as a dict of sections ({"scan": {...}, "system": {...}, "point": [{...}]})
    as the text of a scan file (docs/SCAN.md)."""
    lines = []
    for section, body in scan.items():
        if section == "point":
            for point in body:
                lines.append("[[point]]")
                lines += ["%s = %s" % (k, _toml_value(v)) for k, v in point.items()]
            continue
        if not isinstance(body, dict):
            raise TypeError("section [%s] must be a dict of keys, not %r" % (section, body))
        lines.append("[%s]" % section)
        for k, v in body.items():
            if isinstance(v, dict) and not {"from", "to"} <= set(v):
                for k2, v2 in v.items():  # [rest] speed as rest = {"speed": ...} is flattened
                    lines.append("%s.%s = %s" % (k, k2, _toml_value(v2)))
            else:
                lines.append("%s = %s" % (k, _toml_value(v)))
    return "\n".join(lines) + "\n"


_PROGRESS = re.compile(r"(\d+)/(\d+) members")


def _show(line, progress):
    """Progress lines of the program ("k/n members, ...") as a bar on stderr."""
    m = _PROGRESS.search(line)
    if not (progress and m):
        return
    done, total = int(m.group(1)), int(m.group(2))
    width = 30
    filled = width * done // max(total, 1)
    sys.stderr.write("\r[%s%s] %s" % ("#" * filled, "." * (width - filled), line.strip()[:60]))
    sys.stderr.flush()


def scan_file_for(out):
    """Where run() writes a scan given as a dict: beside the result, OUT.toml for OUT.h5."""
    root, _ = os.path.splitext(os.fspath(out))
    return root + ".toml"


def _refuse_invalid(exe, text, path, out):
    """Raises the program's LoosepackError where it refuses `text` as a scan, before `text` is
    written to the scan file `path` (an earlier scan there stays beside its result; none is left
    where there was none): a dry run of a copy beside it (a file of its own, removed after), its
    messages naming `path`."""
    check = _temporary_beside(path, text)
    try:
        done = subprocess.run([exe, "run", check, "-o", os.fspath(out), "--force", "--dry-run"],
                              capture_output=True, text=True)
    finally:
        os.remove(check)
    if done.returncode != 0:
        message = done.stderr.replace(check, path)
        kept = "kept its earlier scan" if os.path.exists(path) else "not written"
        raise LoosepackError("loosepack run exited with %d (%s %s):\n%s"
                             % (done.returncode, path, kept, message), done.returncode, message)


def run(scan, out, force=False, progress=True, program=None, args=()):
    """Run a scan and load its result.

    scan: a dict of sections (see to_toml) or the path of a scan file. A dict is written to
    OUT.toml beside the result (scan_file_for), the scan file the result names and the program's
    error messages point into; an OUT.toml of other text is replaced only with force. out: the
    result file. force: replace an existing `out` (and OUT.toml, once the program takes the new
    scan: where it refuses the run, the earlier OUT.toml is put back). args: more command-line
    arguments (["--snapshots"]). Raises LoosepackError when the program fails; when only members
    failed (exit 3) the file is written, a warning printed, and the result returned. Interrupted
    in Python, it stops the program (which saves its checkpoint) before the exception goes on."""
    exe = find_program(program)
    if isinstance(scan, dict):
        path = scan_file_for(out)
        if os.path.abspath(path) == os.path.abspath(os.fspath(out)):
            raise LoosepackError("out %s would be the scan file too: give it another suffix (.h5)"
                                 % os.fspath(out), 2, "")
        text = to_toml(scan)
        directory = os.path.dirname(os.path.abspath(path))
        if not os.path.isdir(directory):
            raise LoosepackError("the directory %s of out %s does not exist (make it first)"
                                 % (directory, os.fspath(out)), 2, "")
        other = True  # what the scan file holds, if anything, is not this scan
        if os.path.exists(path):
            with open(path) as f:
                other = f.read() != text
            if other and not force:
                raise LoosepackError("%s exists with another scan: the scan dict would "
                                     "replace it; pass force=True, or give another out" % path,
                                     2, "")
        if other:
            _refuse_invalid(exe, text, path, out)
            earlier = _replace_text(path, text)
    else:
        path = os.fspath(scan)
    cmd = [exe, "run", path, "-o", os.fspath(out)] + (["--force"] if force else []) + list(args)
    code, text = _follow(cmd, progress)
    if code == EXIT_MEMBERS_FAILED:
        sys.stderr.write("loosepack: members failed (the file is written):\n" + text)
    elif code != 0:
        if code == EXIT_REFUSED and isinstance(scan, dict) and other:
            # Refused where a dry run could not tell (a checkpoint of another run to resume, an
            # output another run writes): the scan file that run names is put back.
            _replace_text(path, earlier)
            text += "(%s %s)\n" % (path, "kept its earlier scan" if earlier is not None
                                    else "not written")
        raise LoosepackError("loosepack run exited with %d:\n%s" % (code, text), code, text)
    return load(out)


def _replace_text(path, text):
    """Writes `text` to `path` whole (None: removes it) and returns what was there (None)."""
    earlier = None
    if os.path.exists(path):
        with open(path) as f:
            earlier = f.read()
    if text is None:
        os.remove(path)
        return earlier
    os.replace(_temporary_beside(path, text), path)
    return earlier


def _temporary_beside(path, text):
    """A new file of `text` beside `path` (PATH.XXXX), readable as open() would make it (umask
    applied; mkstemp's own mode is 0600); its name."""
    fd, temporary = tempfile.mkstemp(dir=os.path.dirname(os.path.abspath(path)),
                                     prefix=os.path.basename(path) + ".")
    with os.fdopen(fd, "w") as f:
        f.write(text)
    umask = os.umask(0)
    os.umask(umask)
    os.chmod(temporary, 0o666 & ~umask)
    return temporary


def _follow(cmd, progress):
    """Runs `loosepack run` with its progress shown; (exit code, stderr). Where this process is
    interrupted meanwhile (a KeyboardInterrupt that reached Python alone), the program is told
    to stop by SIGUSR1, which saves its checkpoint, and is waited for before the exception goes
    on. Where a terminal's SIGINT reached the program too, SIGUSR1 is a repeat it ignores (a
    second SIGINT would end it unsaved), and where both are pending at once SIGINT, of the lower
    number, is taken first."""
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            bufsize=1)
    stderr = []
    try:
        for line in proc.stderr:
            stderr.append(line)
            _show(line, progress)
        proc.stdout.read()
        code = proc.wait()
    except BaseException:
        if proc.poll() is None:
            proc.send_signal(signal.SIGUSR1)
        _, rest = proc.communicate()  # read to the end: the pipes fill while it saves
        sys.stderr.write(("\n" if progress else "") + rest)  # its last words: how to resume
        raise
    if progress:
        sys.stderr.write("\n")
    return code, "".join(stderr)


def summary(path, program=None):
    """The table and fits `loosepack summary` prints for a result file, as text."""
    done = subprocess.run([find_program(program), "summary", os.fspath(path)],
                          capture_output=True, text=True)
    if done.returncode != 0:
        raise LoosepackError("loosepack summary exited with %d:\n%s" %
                             (done.returncode, done.stderr), done.returncode, done.stderr)
    return done.stdout
