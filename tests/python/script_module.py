"""A script of the repository (tools/*.py, bench/*.py) loaded as a module, for its tests."""
import importlib.util
import os


def load_script(path):
    """The module of the script at `path`, named after its file."""
    name = os.path.splitext(os.path.basename(path))[0]
    spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module
