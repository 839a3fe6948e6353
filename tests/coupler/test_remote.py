"""The remote participant protocol: a structure served over a transport behaves like the local
one, and its failures reach the fluid side as PeerError with the remote message."""

from __future__ import annotations

import threading

import numpy as np
import pytest

from mpsfem.coupler import mock
from mpsfem.coupler.errors import PeerError
from mpsfem.coupler.remote import RemoteParticipant, serve
from mpsfem.coupler.transport.inproc import InprocTransport


def served(participant):
    a, b = InprocTransport.pair(timeout_s=5.0)
    errors = []

    def run():
        b.connect()
        try:
            serve(participant, b)
        except Exception as exc:  # noqa: BLE001 - collected for the test
            errors.append(exc)

    th = threading.Thread(target=run, daemon=True)
    th.start()
    a.connect()
    return RemoteParticipant(a), th, errors


def test_remote_matches_local():
    local = mock.SpringMassStructure()
    twin = mock.SpringMassStructure()
    remote, th, errors = served(twin)
    m1, m2 = local.interface(), remote.interface()
    assert m1.points.tobytes() == m2.points.tobytes()
    assert m1.cells["line"].tobytes() == m2.cells["line"].tobytes()
    assert remote.max_dt() == local.max_dt()
    F = np.zeros((local.n, 2))
    F[:, 1] = np.linspace(-1, 1, local.n)
    for p in (local, remote):
        p.write("forces", F)
        p.checkpoint()
        for _ in range(3):
            p.advance(1e-3)
        p.restore()
        assert p.advance(1e-3) == 1e-3
    for name in ("displacement", "velocity"):
        assert local.read(name).tobytes() == remote.read(name).tobytes()
    assert remote.energy() == sum(local.energy())
    remote.finalize()
    th.join(timeout=5)
    assert not errors


def test_remote_error_reaches_the_client():
    remote, th, errors = served(mock.SpringMassStructure())
    remote.write("forces", np.zeros((3, 2)))  # wrong shape: one-way, reported with next answer
    with pytest.raises(PeerError, match=r"failed in 'write': ValueError: forces of shape \(3, 2\)"):
        remote.max_dt()
    th.join(timeout=5)
    assert isinstance(errors[0], ValueError)
