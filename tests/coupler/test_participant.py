"""The participant protocol and the interface mesh."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from mpsfem.coupler import mock
from mpsfem.coupler.participant import InterfaceMesh, Participant, as_interface_mesh, energy_of
from mpsfem.coupler.registry import Registry


def test_interface_mesh_normalises_and_freezes():
    m = InterfaceMesh([[0, 0], [1, 0]], [[0, 1], [0, 1]], {"line": [[0, 1]]}, 0.01)
    assert m.points.dtype == np.float64 and m.cells["line"].dtype == np.int32
    assert m.thickness.shape == (2,) and m.dim == 2 and m.n_points == 2
    with pytest.raises(ValueError):
        m.points[0, 0] = 1.0  # read-only


@pytest.mark.parametrize(
    "kw, match",
    [
        ({"points": np.zeros((3, 4))}, r"expected \(n, 2\) or \(n, 3\)"),
        ({"normals": np.zeros((2, 2))}, "must be unit"),
        ({"cells": {"hexahedron": [[0, 1]]}}, "allowed"),
        ({"cells": {"line": [[0, 5]]}}, "outside"),
        ({"cells": {"triangle": [[0, 1]]}}, r"expected \(n, 3\)"),
        ({"thickness": -1.0}, ">= 0"),
        ({"points": [[0, np.nan], [1, 0]]}, "non-finite"),
    ],
)
def test_interface_mesh_rejects_bad_input(kw, match):
    base = {"points": [[0, 0], [1, 0]], "normals": [[0, 1], [0, 1]], "cells": {}, "thickness": 0.0}
    base.update(kw)
    with pytest.raises(ValueError, match=match):
        InterfaceMesh(**base)


def test_as_interface_mesh_from_cell_sequence():
    obj = SimpleNamespace(
        points=np.zeros((5, 3)) + np.arange(5)[:, None] * [1.0, 0.2, 0],
        normals=np.tile([0, 0, 1.0], (5, 1)),
        cells=(np.array([[0, 1, 2, 3]]), np.array([[1, 2, 4]]), np.zeros((0, 3), int)),
        geometric_thickness=np.full(5, 0.015),
        thickness=np.full(5, 0.001),
    )
    m = as_interface_mesh(obj)
    assert set(m.cells) == {"quad", "triangle"} and m.thickness[0] == 0.015


def test_mocks_satisfy_protocol():
    f, s = mock.pair(1.0)
    assert isinstance(f, Participant) and isinstance(s, Participant)
    assert energy_of(s) == 0.0 and np.isnan(energy_of(f))


def test_registry_errors_list_allowed_names():
    r = Registry("widget", {"a": "math:sqrt"})
    assert r.get("a")(4.0) == 2.0 and r.names() == ("a",) and "a" in r
    with pytest.raises(KeyError, match="unknown widget 'b'; allowed: 'a'"):
        r.get("b")
