"""Names of a package loaded on first use (PEP 562): the package and the command line start
without the libraries their modules need (numba, laspy, h5py, ...); and a library imported whole
or not at all when Ctrl-C comes during its import (:func:`import_whole`)."""
import importlib
import signal
import sys
import threading


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


def import_whole(name):
    """The module ``name``, imported with SIGINT and SIGTERM held until the import is done, then
    acted on as if they came just after it. A signal that lands inside a library's import may
    be swallowed by the library, or turned by a compiled module's initialisation into
    ``ImportError: initialization failed`` (pyemd -> POT -> scipy.optimize's pybind11 modules),
    leaving it half loaded and the run going on or failing with a traceback. Held in the main
    thread only, which alone runs Python's signal handlers."""
    if name in sys.modules or threading.current_thread() is not threading.main_thread():
        return importlib.import_module(name)
    received = []
    previous = {}
    for s in (signal.SIGINT, signal.SIGTERM):
        if signal.getsignal(s) not in (None, signal.SIG_IGN):  # None: a handler set outside Python, kept
            previous[s] = signal.signal(s, lambda signum, frame: received.append(signum))
    try:
        return importlib.import_module(name)
    finally:
        for s, handler in previous.items():
            signal.signal(s, handler)
        if received:
            signal.raise_signal(received[0])  # to the handler of the run (KeyboardInterrupt, Interrupted)
