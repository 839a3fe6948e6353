"""The study scripts of validation/ are scripts, not a package: the tests that check their
analysis import them by file name through :func:`load`."""

import importlib.util
import sys
from pathlib import Path
from types import ModuleType

VALIDATION = Path(__file__).resolve().parents[2] / "validation"


def load(name: str) -> ModuleType:
    """validation/<name>.py as module ``name`` (registered in sys.modules: dataclasses look
    their module up there)."""
    spec = importlib.util.spec_from_file_location(name, VALIDATION / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    spec.loader.exec_module(module)
    return module
