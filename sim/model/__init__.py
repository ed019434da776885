"""The model: the immutable lattice (``Model``), its mutable ``State``, the checks every outside value
passes (schema), the boundary registry, the driver and absorbing layer's description, and sources
and barriers."""


from sim.model.lattice import MAX_SIDE, Model, ModelError, read_only

__all__ = ["MAX_SIDE", "Model", "ModelError", "read_only"]
