"""Any linear structure with contacts (M, C, K, B_u, W, H): its folder format (files.py) and a realistic
example, a clamped steel cantilever hitting a stop, with its truth simulation (beam.py)."""
from .files import Structure, StructureError, load_structure, validate, write_structure

__all__ = ["Structure", "StructureError", "load_structure", "validate", "write_structure"]
