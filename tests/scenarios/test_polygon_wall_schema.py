"""Schema of polygon walls (fluid.walls[].shape = 'polygon'): accepted outlines and the named
errors for bad ones."""

import pytest

from mpsfem.scenario.base import ScenarioError
from mpsfem.scenario.loader import load_scenario_text

BASE = """
[run]
end_time = 0.1
[fluid]
dim = {dim}
spacing = 0.01
gravity = {gravity}
[[fluid.blocks]]
lower = {lower}
upper = {upper}
[[fluid.walls]]
name = "body"
{wall}
"""


def _load(wall: str, dim: int = 2):
    if dim == 2:
        fmt = {"gravity": "[0.0, -9.81]", "lower": "[0.0, 0.0]", "upper": "[1.0, 0.5]"}
    else:
        fmt = {"gravity": "[0.0, 0.0, -9.81]", "lower": "[0.0, 0.0, 0.0]", "upper": "[1, 1, 1]"}
    return load_scenario_text(BASE.format(dim=dim, wall=wall, **fmt)).scenario


WEDGE = 'shape = "polygon"\nvertices = [[0.4, 0.6], [0.6, 0.7], [0.6, 0.8], [0.2, 0.8], [0.2, 0.7]]'


def test_polygon_gets_its_bounding_box():
    w = _load(WEDGE).fluid.walls[0]
    assert w.lower == [0.2, 0.6] and w.upper == [0.6, 0.8]
    assert len(w.vertices) == 5


def test_clockwise_outline_is_accepted():
    text = (
        'shape = "polygon"\nvertices = [[0.2, 0.7], [0.2, 0.8], [0.6, 0.8], [0.6, 0.7], [0.4, 0.6]]'
    )
    assert _load(text).fluid.walls[0].lower == [0.2, 0.6]


@pytest.mark.parametrize(
    "vertices, key, words",
    [
        ("[[0, 0], [1, 0]]", "fluid.walls[0].vertices", "at least 3 vertices"),
        ("[[0, 0], [1, 0], [1, 0], [0, 1]]", "fluid.walls[0].vertices[2]", "repeats vertex 1"),
        ("[[0, 0], [1, 0], [0, 1], [0, 0]]", "fluid.walls[0].vertices[0]", "repeats vertex 3"),
        ("[[0, 0], [1, 0], [2, 0]]", "fluid.walls[0].vertices", "zero area"),
        ("[[0, 0], [2, 0], [0, 1], [1, 2]]", "fluid.walls[0].vertices", "edge 1"),
        ("[[0, 0, 0], [1, 0, 0], [0, 1, 0]]", "fluid.walls[0].vertices[0]", "2 entries"),
        ("[[0, 0], [1, 0], [0, inf]]", "fluid.walls[0].vertices[2][1]", "finite"),
    ],
    ids=["two", "repeat", "closed-twice", "collinear", "self-intersecting", "3d-vertex", "inf"],
)
def test_bad_outline_is_named(vertices, key, words):
    with pytest.raises(ScenarioError) as err:
        _load(f'shape = "polygon"\nvertices = {vertices}')
    text = str(err.value)
    assert key in text and words in text


def test_polygon_refuses_lower_upper_and_needs_vertices():
    with pytest.raises(ScenarioError, match=r"fluid.walls\[0\].lower.*not used by shape"):
        _load(WEDGE + "\nlower = [0.0, 0.0]")
    with pytest.raises(ScenarioError, match=r"fluid.walls\[0\].vertices.*needs vertices"):
        _load('shape = "polygon"')


def test_box_refuses_vertices_and_needs_corners():
    with pytest.raises(ScenarioError, match=r"fluid.walls\[0\].vertices.*only used by shape"):
        _load(
            'shape = "box"\nlower = [0.2, 0.6]\nupper = [0.4, 0.8]\nvertices = [[0, 0], [1, 0], [0, 1]]'
        )
    with pytest.raises(ScenarioError, match=r"fluid.walls\[0\].upper.*needs upper"):
        _load('shape = "box"\nlower = [0.2, 0.6]')


def test_polygon_is_2d_only():
    wall = 'shape = "polygon"\nvertices = [[0.2, 0.6], [0.6, 0.6], [0.4, 0.8]]'
    with pytest.raises(ScenarioError, match=r"fluid.walls\[0\].shape.*2D only"):
        _load(wall, dim=3)


def test_wedge_scenario_validates(scenarios_dir):
    from mpsfem.scenario.loader import load_scenario

    sc = load_scenario(scenarios_dir / "wedge_entry_2d.toml").scenario
    assert sc.fluid.walls[1].shape == "polygon"
