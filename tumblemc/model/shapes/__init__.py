"""Robot shapes in the body frame of MODEL.md ("Shapes").

Types (:mod:`.types`), profile geometry (:mod:`.profile`) and the library of the paper's
four shapes (:mod:`.library`).
"""

from tumblemc.model.shapes.library import SHAPES, cuboid, curved, get_shape, spiked, spiked_ends
from tumblemc.model.shapes.profile import extruded
from tumblemc.model.shapes.types import Constraint, Piece, Shape

__all__ = ["SHAPES", "Constraint", "Piece", "Shape", "cuboid", "curved", "extruded", "get_shape", "spiked", "spiked_ends"]
