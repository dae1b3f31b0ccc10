"""Names of a package loaded on first use (PEP 562): the package and the command line start
without the libraries their modules need (numba, laspy, h5py, ...)."""
import importlib
import sys


def lazy_names(package, exports):
    """The ``__getattr__`` and ``__dir__`` of the package named ``package``: a name of
    ``exports`` (name -> the module of the package that defines it) is imported from its module
    when first used, and kept; any other name is tried as a submodule."""
    module = sys.modules[package]

    def __getattr__(name):
        if name in exports:
            value = getattr(importlib.import_module(f".{exports[name]}", package), name)
            setattr(module, name, value)
            return value
        try:  # a submodule, e.g. lidar_sig.scales
            return importlib.import_module(f".{name}", package)
        except ModuleNotFoundError as exc:
            if exc.name != f"{package}.{name}":
                raise
            raise AttributeError(f"module {package!r} has no attribute {name!r}") from None

    def __dir__():
        return sorted(set(vars(module)) | set(exports))

    return __getattr__, __dir__
