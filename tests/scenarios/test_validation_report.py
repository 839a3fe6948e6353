"""docs/validation.md's generated section matches the committed result CSVs
(validation/report.py), so the summary cannot drift from the numbers."""

from pathlib import Path

from validation_script import load

ROOT = Path(__file__).resolve().parents[2]


def test_generated_summary_is_current():
    report = load("report")
    text = (ROOT / "docs" / "validation.md").read_text()
    assert report.BEGIN in text and report.END in text
    block = report.BEGIN + text.split(report.BEGIN, 1)[1].split(report.END, 1)[0] + report.END
    assert block + "\n" == report.summary(), "run: python validation/report.py"


def test_write_replaces_only_the_generated_block(tmp_path):
    report = load("report")
    doc = tmp_path / "validation.md"
    doc.write_text("# V\n\nhand-written\n")
    report.write(doc)
    report.write(doc)  # idempotent: one block, the hand-written text kept
    text = doc.read_text()
    assert text.startswith("# V\n\nhand-written\n") and text.count(report.BEGIN) == 1
