"""[structure] schema: strict tables, and messages that say what is allowed."""

import copy

import pytest
from pydantic import ValidationError
from structure_cases import BEAM, PLATE, section


def errors(members, **kw):
    with pytest.raises(ValidationError) as exc:
        section(members, **kw)
    return str(exc.value)


def test_valid_sections():
    s = section([BEAM])
    assert s.dim == 2 and s.gravity_vector == [0.0, -9.81]
    m = s.members[0]
    assert m.edge_bcs == ["clamped", "simply_supported"] and m.fluid_thickness == 0.04
    p = section([PLATE]).members[0]
    assert p.edge_bcs == ["clamped"] * 4 and p.fluid_thickness == 0.015
    assert section([PLATE]).gravity_vector == [0.0, 0.0, -9.81]


@pytest.mark.parametrize(
    "patch, message",
    [
        ({"bc": "pinned"}, "'clamped', 'simply_supported' or 'free'"),
        ({"bc": ["clamped"]}, "exactly 2 entries"),
        ({"thickness": 0.0}, "greater than 0"),
        ({"elements": 0}, "greater than or equal to 1"),
        ({"end": [0.0, 0.0]}, "distinct"),
        ({"name": "9lives"}, "should match pattern"),
        ({"rayleigh_a2": -1.0}, "greater than or equal to 0"),
        ({"plate_strip": True}, "poisson_ratio"),
        ({"colour": "red"}, "Extra inputs are not permitted"),
        ({"type": "shell"}, "'beam', 'plate'"),
    ],
)
def test_beam_errors(patch, message):
    bad = dict(copy.deepcopy(BEAM), **patch)
    assert message in errors([bad])


@pytest.mark.parametrize(
    "patch, message",
    [
        ({"element": "argyris"}, "'bfs' or 'morley'"),
        ({"material": {"youngs_modulus": 1.0, "density": 1.0}}, "poisson_ratio"),
        ({"axis_v": [1.0, 1.0, 0.0]}, "perpendicular"),
        ({"divisions": None}, "exactly one of `mesh_size` or `divisions`"),
        ({"mesh_size": 0.01}, "exactly one of `mesh_size` or `divisions`"),
        ({"bc": ["clamped", "free"]}, "one entry per edge (4"),
        ({"shape": "polygon"}, "needs `outline"),
        (
            {"shape": "polygon", "size": None, "outline": [[0, 0], [1, 0], [0, 1]]},
            'needs element = "morley"',
        ),
        (
            {"shape": "polygon", "size": None, "element": "morley", "divisions": None,
             "mesh_size": 0.1, "outline": [[0, 0], [0, 1], [1, 0]]},
            "anticlockwise",
        ),
    ],
)  # fmt: skip
def test_plate_errors(patch, message):
    bad = dict(copy.deepcopy(PLATE), **patch)
    assert message in errors([bad])


def test_section_errors():
    assert "unique" in errors([BEAM, BEAM])
    assert "all beams (2D scene) or all plates" in errors([BEAM, PLATE])
    assert "`gravity` needs 2 components" in errors([BEAM], gravity=[0, 0, -9.81])
    assert "not one of ['wall']" in errors(
        [BEAM], loads=[{"kind": "pressure", "member": "roof", "value": 1.0}]
    )
    off = [{"kind": "point_force", "member": "wall", "position": [0.1, 0.1], "force": [1.0, 0.0]}]
    assert "off member 'wall'" in errors([BEAM], loads=off)
    beyond = [{"kind": "point_force", "member": "wall", "position": [0.0, 0.3], "force": [1, 0]}]
    assert "beyond the ends" in errors([BEAM], loads=beyond)
    outside = [
        {
            "kind": "point_force",
            "member": "deck",
            "position": [0.5, 0.1, 0.1254],
            "force": [0, 0, 1],
        }
    ]
    assert "outside the planform" in errors([PLATE], loads=outside)
    assert "newmark_gamma" in errors([BEAM], time={"dt": 1e-4, "newmark_gamma": 0.4})
    assert "exactly one of `file`" in errors(
        [BEAM],
        loads=[{"kind": "pressure", "member": "wall", "value": 1.0, "time": {"kind": "table"}}],
    )
    assert "strictly increasing" in errors(
        [BEAM],
        loads=[
            {"kind": "pressure", "member": "wall", "value": 1.0,
             "time": {"kind": "table", "points": [[0.0, 0.0], [0.0, 1.0]]}}
        ],
    )  # fmt: skip


def test_every_field_has_a_description():
    from pydantic import BaseModel

    import mpsfem.scenario.structure as mod

    seen = 0
    for obj in vars(mod).values():
        if isinstance(obj, type) and issubclass(obj, BaseModel) and obj.__module__ == mod.__name__:
            for name, field in obj.model_fields.items():
                assert field.description, f"{obj.__name__}.{name} has no description"
                seen += 1
    assert seen > 40


def test_assignment_is_validated():
    """--set style assignment goes through the same checks."""
    s = section([BEAM])
    with pytest.raises(ValidationError):
        s.time.dt = -1.0
