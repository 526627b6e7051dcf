"""loosepack.find_program on a package installed under a prefix: the program installed beside it
(PREFIX/bin/loosepack) is found, after $LOOSEPACK."""

import os
import shutil
import subprocess
import sys

import pytest

PACKAGE = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "python",
                       "loosepack")
# Where `cmake --install` and pip put the package under a prefix.
LAYOUTS = ["share/loosepack/python", "lib/python3.11/site-packages", "lib/python3/dist-packages"]


def install(prefix, layout):
    """The package copied under `prefix` in `layout`, and an executable PREFIX/bin/loosepack."""
    shutil.copytree(PACKAGE, prefix / layout / "loosepack",
                    ignore=shutil.ignore_patterns("__pycache__"))
    program = prefix / "bin" / "loosepack"
    program.parent.mkdir()
    program.write_text("#!/bin/sh\n")
    program.chmod(0o755)
    return program


def found(prefix, layout, **env):
    """What find_program() says in a Python that imports the installed package, with no
    loosepack on the PATH and no $LOOSEPACK but those in `env`."""
    path = "/usr/bin:/bin"
    assert shutil.which("loosepack", path=path) is None
    environ = {k: v for k, v in os.environ.items() if k not in ("LOOSEPACK", "PYTHONPATH")}
    environ.update(PATH=path, PYTHONPATH=str(prefix / layout), **env)
    done = subprocess.run([sys.executable, "-c",
                           "import loosepack; print(loosepack.find_program())"],
                          capture_output=True, text=True, env=environ, cwd=prefix)
    assert done.returncode == 0, done.stderr[-2000:]
    return done.stdout.strip()


@pytest.mark.parametrize("layout", LAYOUTS)
def test_the_program_installed_beside_the_package_is_found(tmp_path, layout):
    program = install(tmp_path, layout)
    assert found(tmp_path, layout) == str(program)


def test_loosepack_in_the_environment_comes_first(tmp_path):
    install(tmp_path, LAYOUTS[0])
    other = tmp_path / "other"
    other.write_text("#!/bin/sh\n")
    other.chmod(0o755)
    assert found(tmp_path, LAYOUTS[0], LOOSEPACK=str(other)) == str(other)
