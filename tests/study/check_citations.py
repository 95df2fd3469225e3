"""Every number the hand-written docs cite matches the generated table it cites.

First the committed documents (the README's findings, docs/REPORT.md's prose, the
pages of docs/results/): scripts/study_document.py check must find every citation
matching.  Then the check must catch a stale number: a copy of a cited line beside
its table with the number changed, a citation of a column that is not there, and a
citation that picks more than one row must each be reported, naming the line.
"""
import pathlib
import sys
import tempfile

REPO = pathlib.Path(__file__).resolve().parents[2]
sys.path.insert(0, str(REPO / "scripts"))
import study_document  # noqa: E402

DOCUMENTS = [REPO / "README.md", REPO / "docs" / "REPORT.md",
             *sorted((REPO / "docs" / "results").rglob("*.md"))]
TABLE = "scene,algo,total\n4,cpusap,152.4\n4,sap,167.0\n1,cpusap,23.1\n"


def fail(message: str) -> None:
    sys.exit("FAIL: " + message)


def main() -> int:
    problems = [p for doc in DOCUMENTS for p in study_document.check(doc)]
    if problems:
        fail("the committed docs cite numbers their tables no longer hold:\n"
             + "\n".join(problems))
    cited = sum(len(study_document.CITE.findall(doc.read_text())) for doc in DOCUMENTS)
    if cited == 0:
        fail("no document cites a table: the check checks nothing")
    with tempfile.TemporaryDirectory() as folder:
        root = pathlib.Path(folder)
        (root / "t.csv").write_text("# machine: a test's\n" + TABLE)
        doc = root / "doc.md"
        doc.write_text("cpusap takes 152 ms<!-- cite t.csv total scene=4 algo=cpusap -->.\n"
                       "At most 167.0<!-- cite t.csv total max -->, at least 23<!-- cite "
                       "t.csv total min -->.\n")
        if study_document.check(doc):
            fail(f"matching citations reported: {study_document.check(doc)}")
        doc.write_text("x\ncpusap takes 150 ms<!-- cite t.csv total scene=4 algo=cpusap -->\n"
                       "y 3<!-- cite t.csv seconds scene=4 algo=sap -->\n"
                       "z 152<!-- cite t.csv total scene=4 -->\n")
        found = study_document.check(doc)
        lines = [p.split(":")[1] for p in found]
        if lines != ["2", "3", "4"] or "152.4" not in found[0]:
            fail(f"a stale number, a missing column and an ambiguous row: {found}")
    print(f"study.citations: {cited} citations in {len(DOCUMENTS)} documents match; "
          "stale ones are caught")
    return 0


if __name__ == "__main__":
    sys.exit(main())
