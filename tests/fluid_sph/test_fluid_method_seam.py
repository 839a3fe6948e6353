"""The fluid-method seam: registry, schema refusals, solver construction by name."""

from __future__ import annotations

import typing

import pytest
from pydantic import ValidationError

from mpsfem.fluid_methods import FLUID_METHODS, METHOD_TABLES, FluidMethod, create_fluid_solver
from mpsfem.scenario.fluid import FluidSection

TANK = {
    "spacing": 0.02,
    "blocks": [{"lower": [0.0, 0.0], "upper": [0.2, 0.1]}],
    "walls": [{"shape": "tank", "lower": [0.0, 0.0], "upper": [0.2, 0.2], "name": "tank"}],
}


def test_schema_names_are_the_registry():
    field = FluidSection.model_fields["method"]
    assert typing.get_args(field.annotation) == FLUID_METHODS.names()
    assert set(METHOD_TABLES) == set(FLUID_METHODS.names())


@pytest.mark.parametrize(
    ("method", "key", "value"),
    [
        ("delta-sph", "pressure", {"tol": 1e-5}),
        ("delta-sph", "collision", {"enabled": False}),
        ("delta-sph", "kernel", {"re_density": 2.2}),
        ("mps", "sph", {"smoothing_ratio": 2.0}),
    ],
)
def test_a_table_of_the_other_method_is_refused(method, key, value):
    with pytest.raises(ValidationError) as err:
        FluidSection(**TANK, method=method, **{key: value})
    msg = str(err.value)
    assert f"{key} = " in msg and "belongs to fluid.method" in msg


def test_delta_sph_gets_its_default_table_and_takes_the_exchange_force():
    """δ-SPH reports its walls' pair exchange with boundary_force = "momentum_exchange" (its
    pressure pairs are antisymmetric: MPS's gradient requirement does not apply); MPS still
    refuses it with a non-antisymmetric gradient, and an unknown structure_load is refused
    naming the key and the allowed values."""
    spec = FluidSection(**TANK, method="delta-sph")
    assert spec.sph is not None and spec.sph.smoothing_ratio == 1.3
    ex = FluidSection(**TANK, method="delta-sph", boundary_force="momentum_exchange")
    assert ex.boundary_force == "momentum_exchange"
    with pytest.raises(ValidationError, match="momentum_exchange"):
        FluidSection(**TANK, boundary_force="momentum_exchange")  # MPS, corrected_pmin
    assert FluidSection(**TANK, method="delta-sph", momentum_budget=True).momentum_budget
    with pytest.raises(ValidationError) as err:
        FluidSection(**TANK, method="delta-sph", sph={"structure_load": "tangential"})
    msg = str(err.value)
    assert "structure_load" in msg and "normal_pairs" in msg


def test_mps_has_no_sph_table():
    assert FluidSection(**TANK).sph is None


@pytest.mark.parametrize("method", ["mps", "delta-sph"])
def test_each_method_builds_behind_the_protocol(method):
    solver = create_fluid_solver(FluidSection(**TANK, method=method))
    assert isinstance(solver, FluidMethod)
    assert type(solver) is FLUID_METHODS.get(method)
    assert solver.n_fluid == 50 and solver.pos.shape == (solver.n, 2)
