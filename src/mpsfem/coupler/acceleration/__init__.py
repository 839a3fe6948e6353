"""Accelerators of implicit coupling (preCICE's acceleration), chosen by
``[coupling.acceleration] kind``; adding one is a module with an :class:`Acceleration` subclass
(and its ``Params`` section) plus one line below."""

from mpsfem.coupler.acceleration.base import Acceleration
from mpsfem.coupler.registry import Registry

ACCELERATIONS = Registry(
    "acceleration",
    {
        "constant": "mpsfem.coupler.acceleration.constant:ConstantRelaxation",
        "aitken": "mpsfem.coupler.acceleration.aitken:Aitken",
        "iqn-ils": "mpsfem.coupler.acceleration.iqn_ils:IQNILS",
        "iqn-imvj": "mpsfem.coupler.acceleration.iqn_imvj:IQNIMVJ",
    },
)


def create_acceleration(params) -> Acceleration:
    """The accelerator named by ``params.kind``, configured by ``params``."""
    return ACCELERATIONS.create(params.kind, params)


__all__ = ["ACCELERATIONS", "Acceleration", "create_acceleration"]
