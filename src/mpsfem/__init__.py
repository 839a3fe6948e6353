"""mpsfem: fluid-structure interaction with an MPS fluid and a scikit-fem structure."""

from importlib.metadata import PackageNotFoundError, version

from mpsfem.threading_layer import preload_tbb

preload_tbb()  # before any numba kernel starts its threads

try:
    __version__ = version("mpsfem")
except PackageNotFoundError:  # running from a source tree without installation
    __version__ = "0.0.0+unknown"

__all__ = ["__version__"]
