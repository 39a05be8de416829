"""Any linear structure with contacts (M, C, K, B_u, W, H): its folder format (files.py), its truth
simulation (truth.py) and a realistic example, a clamped steel cantilever hitting a stop (beam.py)."""
from .beam import BeamSpec, FullInfo, assemble, closing_force, draw_beam, reduce
from .files import Structure, StructureError, load_structure, validate, write_structure
from .truth import BeamTruth, energy, simulate

__all__ = ["BeamSpec", "BeamTruth", "FullInfo", "Structure", "StructureError", "assemble", "closing_force",
           "draw_beam", "energy", "load_structure", "reduce", "simulate", "validate", "write_structure"]
