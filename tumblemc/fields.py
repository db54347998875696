"""Field programs (an alias of :mod:`tumblemc.model.fields`): ``Static``, ``Rotating``, ``Sequence``."""

from tumblemc.model.fields import Field, Rotating, Sequence, Static, compile_program, describe, field_at

__all__ = ["Field", "Rotating", "Sequence", "Static", "compile_program", "describe", "field_at"]
