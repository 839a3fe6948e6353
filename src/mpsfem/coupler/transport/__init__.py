"""Transports between the fluid and the structure processes, chosen by
``[coupling.transport] kind`` (or ``--transport``); adding one is a module with a
:class:`Transport` subclass plus one line below."""

from mpsfem.coupler.registry import Registry
from mpsfem.coupler.transport.base import ROLES, Message, Transport, decode, encode, other_role

TRANSPORTS = Registry(
    "transport",
    {
        "inproc": "mpsfem.coupler.transport.inproc:InprocTransport",
        "mpi": "mpsfem.coupler.transport.mpi:MPITransport",
        "zenoh": "mpsfem.coupler.transport.zenoh:ZenohTransport",
    },
)


def open_transport(config, role: str | None = None) -> Transport:
    """A connected transport of kind ``config.kind`` for this process's ``role`` ("fluid" or
    "structure"; for mpi, None takes it from the rank: 0 fluid, 1 structure)."""
    t = TRANSPORTS.get(config.kind).from_config(role, config)
    t.connect()
    return t


__all__ = [
    "ROLES",
    "TRANSPORTS",
    "Message",
    "Transport",
    "decode",
    "encode",
    "open_transport",
    "other_role",
]
