"""The report's hand-written analysis, kept apart from the generated text.

docs/report_notes/KEY.md holds the prose for the report section KEY; the
generator splices it in after that section's tables, so regenerating the
report never loses a word, and the report stays a pure function of the
results and the notes (regenerated twice, byte-identical).  A note whose
KEY names no section of the report is an error, not silently dropped: the
section it spoke of has gone, and its words must be moved or removed.
"""
import pathlib


class Notes:
    def __init__(self, folder: pathlib.Path):
        self.folder = folder
        self.offered = []  # the section keys the report asked for, in order
        self.found = {p.stem: p for p in sorted(folder.glob("*.md"))} if folder.is_dir() else {}

    def take(self, key: str) -> list:
        """The note for section `key` as report lines (empty when there is none)."""
        self.offered.append(key)
        path = self.found.get(key)
        if path is None:
            return []
        return path.read_text().rstrip("\n").split("\n") + [""]

    def failures(self) -> list:
        """One message per note whose section the report no longer has."""
        return [f"note {path}: the report has no section '{key}' (its sections: "
                f"{', '.join(self.offered)}); move or remove the note"
                for key, path in self.found.items() if key not in self.offered]
