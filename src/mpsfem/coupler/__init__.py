"""Coupler: participant protocol, mappings, time windows, acceleration, schemes and transports.

Public entry points (each a submodule, imported on use):

* :mod:`~mpsfem.coupler.participant` — :class:`Participant` protocol, :class:`InterfaceMesh`;
* :mod:`~mpsfem.coupler.coupling_scheme` — :func:`create_scheme`, explicit / implicit schemes;
* :mod:`~mpsfem.coupler.mapping`, :mod:`~mpsfem.coupler.acceleration`,
  :mod:`~mpsfem.coupler.transport` — the component registries;
* :mod:`~mpsfem.coupler.remote` — :class:`RemoteParticipant` and :func:`serve`;
* :mod:`~mpsfem.coupler.launch` — glue for the CLI (roles, transports, the structure server).

The registries map scenario names to ``"module:attribute"`` and import on use.
"""

from mpsfem.coupler.registry import Registry

SCHEMES = Registry(
    "coupling scheme",
    {
        "explicit": "mpsfem.coupler.coupling_scheme:ExplicitScheme",
        "implicit": "mpsfem.coupler.coupling_scheme:ImplicitScheme",
    },
)

__all__ = ["SCHEMES", "Registry"]
