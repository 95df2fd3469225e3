"""The results files' one format: a CSV whose first lines are '#' provenance lines.

Rules, each with its reason:
  * Every measurement kept in docs/results/ is a CSV (or JSON) that carries its own
    provenance: '# key: value' lines before the header (machine, commit, command, load,
    date), so the file says where its numbers come from wherever it is copied.
  * Readers skip those lines (read_csv) and can ask for them (provenance), so a tool
    that reads the table never trips over the comment, and a page never restates it.
"""
import csv
import pathlib


def read_csv(path: pathlib.Path) -> list:
    """The rows, as dicts of strings, of a CSV whose first lines may be '#' comments."""
    lines = [line for line in pathlib.Path(path).read_text().splitlines()
             if not line.startswith("#")]
    return list(csv.DictReader(lines))


def provenance(path: pathlib.Path) -> dict:
    """The '# key: value' lines before the header, as a dict."""
    found = {}
    for line in pathlib.Path(path).read_text().splitlines():
        if not line.startswith("#"):
            break
        key, _, value = line[1:].partition(":")
        if value:
            found[key.strip()] = value.strip()
    return found
