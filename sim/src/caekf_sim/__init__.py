"""caekf-sim: the Python side of the caekf project (see README.md)."""

__version__ = "0.1.0"
