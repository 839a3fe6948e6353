"""Mappings between the fluid's interface points and the structure's interface mesh.

Chosen by ``[coupling.mapping] kind``; adding one is a module with a :class:`Mapping` subclass
(and its ``Params`` section) plus one line below.
"""

from mpsfem.coupler.mapping.base import Mapping, MappingCoverageError, point_spacing
from mpsfem.coupler.registry import Registry

MAPPINGS = Registry(
    "mapping",
    {
        "kfbi": "mpsfem.coupler.mapping.kernel:KFBIMapping",
        "conservative-kernel": "mpsfem.coupler.mapping.kernel:ConservativeKernelMapping",
        "shape-function": "mpsfem.coupler.mapping.shape_function:ShapeFunctionMapping",
    },
)


def create_mapping(params) -> Mapping:
    """The mapping named by ``params.kind``, configured by ``params``."""
    return MAPPINGS.create(params.kind, params)


__all__ = ["MAPPINGS", "Mapping", "MappingCoverageError", "create_mapping", "point_spacing"]
