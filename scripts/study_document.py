#!/usr/bin/python3
"""The hand-written report's contract with the generated tables: blocks and citations.

A report kept by people (docs/REPORT.md) holds generated blocks and prose around them:

  <!-- generated:findings -->
  ...written by scripts/study.py --report, never by hand...
  <!-- /generated:findings -->

and a number in the prose names the generated table it comes from, in a comment
right after it, which a reader of the rendered page does not see:

  cpusap's frame is 152 ms<!-- cite report/sweep.csv total_mean scene=4 objects=3500 algo=cpusap -->
  the broadphase takes 2-5%<!-- cite report/stages.csv update_broadphase_pct max --> of it
  204 ms<!-- cite results/gpu/raw/async_cpusap/summary.json timings_ms.total_ms.median -->

A CSV citation names a column, then key=value filters that pick one row (or
min|max over the rows they pick; a value with spaces in quotes, key="a b"); a JSON citation names a dotted key; either may
end in /N or *N (a table in µs cited in ms: /1000).  Paths are relative to the
document.  The cited number is the last number before the
comment; it matches when it is the table's value rounded to the decimals typed.

Rules, each with its reason:
  * fill() replaces only what lies between a block's markers: the prose is the
    people's and is never rewritten; a marker naming no block the study writes is
    an error (the block it held has gone, and its prose must be moved or removed).
  * check() lists every citation whose number no longer matches its table, and every
    citation that names a file, column or row that is not there: regenerating the
    tables cannot leave a stale number in the prose unnoticed (ctest study.citations).

  scripts/study_document.py check docs/REPORT.md README.md     # exit 1 on a mismatch
  scripts/study_document.py words docs/REPORT.md              # prose and total words
"""
import json
import pathlib
import re
import shlex
import sys

from results_files import read_csv
from script_cli import BadInput, run

BLOCK = re.compile(r"<!-- generated:([\w-]+) -->\n(.*?)<!-- /generated:\1 -->", re.S)
OPENING = re.compile(r"<!-- generated:([\w-]+) -->")
CITE = re.compile(r"<!-- cite (.*?) -->", re.S)
NUMBER = re.compile(r"(?<![\d.])\d+(?:\.\d+)?")


def fill(text: str, blocks: dict) -> tuple:
    """(the text with each block's content replaced by blocks[name], problems)."""
    problems = [f"marker generated:{name} names no block the study writes (its blocks: "
                f"{', '.join(blocks)})" for name in OPENING.findall(text) if name not in blocks]
    closed = {m.group(1) for m in BLOCK.finditer(text)}
    problems += [f"marker generated:{name} is never closed (<!-- /generated:{name} -->)"
                 for name in OPENING.findall(text) if name not in closed]
    if problems:
        return text, problems
    filled = BLOCK.sub(lambda m: f"<!-- generated:{m.group(1)} -->\n"
                       + "\n".join(blocks[m.group(1)]).strip("\n") + "\n"
                       + f"<!-- /generated:{m.group(1)} -->", text)
    return filled, []


def prose(text: str) -> str:
    """The document without its generated blocks and its comments."""
    return re.sub(r"<!--.*?-->", " ", BLOCK.sub(" ", text), flags=re.S)


def json_value(data, key: str) -> float:
    for part in key.split("."):
        data = data[int(part)] if isinstance(data, list) else data[part]
    return float(data)


def matches(text: str, wanted: str) -> bool:
    try:
        return float(text) == float(wanted)
    except ValueError:
        return text == wanted


def aggregate(values: list, how: str, filters: list) -> float:
    if how:
        return min(values) if how == "min" else max(values)
    if len(values) > 1:
        raise LookupError(f"{len(values)} rows match {' '.join(filters)}: add a filter or "
                          "min|max")
    return values[0]


def csv_value(path: pathlib.Path, words: list) -> float:
    column, rest = words[0], words[1:]
    how = rest.pop() if rest and rest[-1] in ("min", "max") else None
    filters = [w.split("=", 1) for w in rest]
    rows = [r for r in read_csv(path) if all(matches(r.get(k, ""), v) for k, v in filters)]
    if not rows or column not in rows[0]:
        raise LookupError(f"no row {' '.join(rest) or '(any)'} with a column {column}")
    return aggregate([float(r[column]) for r in rows], how, rest)


def scale(words: list) -> tuple:
    """(the words less a last '/N' or '*N', the factor it names): a table in µs cited in ms."""
    if words and words[-1][:1] in "/*" and len(words[-1]) > 1:
        factor = float(words[-1][1:])
        return words[:-1], 1 / factor if words[-1][0] == "/" else factor
    return words, 1.0


def cited_value(folder: pathlib.Path, citation: str) -> float:
    words, factor = scale(shlex.split(citation))
    path = folder / words[0]
    if not path.is_file():
        raise LookupError(f"no file {words[0]}")
    if path.suffix == ".json":
        return factor * json_value(json.loads(read_text(path)), words[1])
    return factor * csv_value(path, words[1:])


def typed_number(before: str) -> str:
    found = NUMBER.findall(before)
    return found[-1] if found else None


def agrees(typed: str, value: float) -> bool:
    decimals = len(typed.split(".")[1]) if "." in typed else 0
    return abs(value - float(typed)) <= 0.5 * 10 ** -decimals + 1e-9 * max(1.0, abs(value))


def check_text(folder: pathlib.Path, text: str) -> list:
    """(line, problem) of each citation of the text (a comment may wrap over lines) that
    does not match, with what was typed and what is there."""
    problems, start = [], 0
    for m in CITE.finditer(text):
        line = text.count("\n", 0, m.start()) + 1
        typed = typed_number(text[start:m.start()])
        start = m.end()
        citation = " ".join(m.group(1).split())
        try:
            value = cited_value(folder, citation)
        except (LookupError, KeyError, IndexError, ValueError) as error:
            problems.append((line, f"cite {citation}: {error}"))
            continue
        if typed is None:
            problems.append((line, f"cite {citation}: no number before it"))
        elif not agrees(typed, value):
            problems.append((line, f"{typed} typed, the table has {value:g} (cite {citation})"))
    return problems


def read_text(path: pathlib.Path) -> str:
    """The file's text; BadInput naming it where it is not UTF-8."""
    try:
        return path.read_text(encoding="utf-8")
    except UnicodeDecodeError as error:
        raise BadInput(f"{path}: not UTF-8 text (at byte {error.start})")


def check(path: pathlib.Path) -> list:
    """Every citation of the document that does not match, as 'file:line: problem'."""
    path = pathlib.Path(path)
    return [f"{path}:{line}: {problem}"
            for line, problem in check_text(path.parent, read_text(path))]


def words(names: list) -> int:
    for name in names:
        text = read_text(pathlib.Path(name))
        print(f"{name}: {len(prose(text).split())} words of prose, "
              f"{len(text.split())} in all (wc -w)")
    return 0


def check_all(names: list) -> int:
    problems = [p for name in names for p in check(pathlib.Path(name))]
    for problem in problems:
        print(problem, file=sys.stderr)
    cited = sum(len(CITE.findall(read_text(pathlib.Path(n)))) for n in names)
    print(f"study_document: {cited} citations, {len(problems)} not matching their tables")
    return 1 if problems else 0


def main(argv: list) -> int:
    if len(argv) < 2 or argv[0] not in ("check", "words"):
        print(__doc__.split("\n\n")[-1], file=sys.stderr)
        return 2
    missing = [name for name in argv[1:] if not pathlib.Path(name).is_file()]
    if missing:
        print(f"study_document: no such file: {', '.join(missing)}", file=sys.stderr)
        return 2
    return (words if argv[0] == "words" else check_all)(argv[1:])


if __name__ == "__main__":
    sys.exit(run(lambda: main(sys.argv[1:]), "study_document"))
