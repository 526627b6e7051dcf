"""loosepack result files in Python.

    import loosepack
    res = loosepack.load("out/default.h5")
    res.points                      # one row per scan point: parameters, scalars and errors
    res.nu(1)                       # nu(y) of point 1 as an xarray Dataset (members too)
    res.avalanche(1, by="y_e")      # Delta y binned by y_e
    res = loosepack.run({"scan": {...}, "system": {...}}, "out/my.h5")   # runs the program

Pure Python over h5py, numpy, pandas and xarray (Debian: python3-h5py, python3-pandas,
python3-xarray). The file layout is docs/OUTPUT.md of the repository.
"""

from .results import Results, load
from .runner import LoosepackError, find_program, run, summary, to_toml

__all__ = ["Results", "load", "run", "summary", "to_toml", "find_program", "LoosepackError"]
__version__ = "0.1.0"
