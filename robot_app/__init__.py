"""robot_app: photo-model-based cloth recognition and pick-and-place with a PA10 arm."""

from importlib.metadata import PackageNotFoundError, version

try:
    __version__ = version("robot_app")
except PackageNotFoundError:  # running from a source tree that is not installed
    __version__ = "0.0.0+unknown"

__all__ = ["__version__"]
