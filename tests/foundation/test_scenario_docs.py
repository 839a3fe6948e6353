"""docs/scenarios.md, generated from the schema, names the kinds of kind-tagged tables."""

from pathlib import Path

from mpsfem.scenario.docs import scenario_docs

DOCS = Path(__file__).resolve().parents[2] / "docs" / "scenarios.md"


def test_tagged_tables_show_their_kinds():
    text = scenario_docs()
    assert "table \\| table" not in text
    assert '| `time` | table by `kind`: "step" \\| "ramp" \\| "harmonic" \\| "table" |' in text
    assert 'table by `kind`: "constant" \\| "aitken" \\| "iqn-ils"' in text


def test_committed_docs_are_the_generated_ones():
    assert DOCS.read_text() == scenario_docs(), "run `mpsfem docs` to regenerate docs/scenarios.md"
