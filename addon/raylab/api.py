"""The Python API over the native module. Placeholder until the core bindings land."""
from . import _raylab  # noqa: F401
