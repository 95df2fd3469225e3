"""How the study's generated text writes numbers and tables (every section shares it).

Rules, each with its reason:
  * fmt() writes milliseconds and counts at a precision the measurements support,
    and "—" for a figure that was not measured (NaN), never 0.
  * Text that comes from a run rather than from the study (the machine's names, read
    from summary.json, perhaps an archive's from another machine) goes in as plain()
    makes it: one line of printable characters, at most 200 of them, every Markdown
    and HTML special character escaped, so it can never shape the page.
  * Algorithms are listed in the broadphase catalogue's order (overlap --list-algos),
    so every table and figure reads the same way.
"""
import broadphases


MARKDOWN_SPECIAL = set("\\`*_[]<>|~$")  # the rest are special only after these
PLAIN_LIMIT = 200


def plain(text: str) -> str:
    """`text` as literal Markdown: control characters dropped, at most PLAIN_LIMIT
    characters (the rest shown as "…"), '&' as an entity, every special escaped."""
    text = "".join(c for c in str(text) if c.isprintable())
    if len(text) > PLAIN_LIMIT:
        text = text[:PLAIN_LIMIT - 1] + "…"
    return "".join("&amp;" if c == "&" else "\\" + c if c in MARKDOWN_SPECIAL else c
                   for c in text)


def fmt(x: float) -> str:
    if x != x:  # NaN
        return "—"
    magnitude = abs(x)
    if magnitude >= 100:
        return f"{x:.0f}"
    if magnitude >= 10:
        return f"{x:.1f}"
    return f"{x:.2f}" if magnitude >= 0.1 else f"{x:.3g}"


def table(headers: list, rows: list) -> list:
    lines = ["| " + " | ".join(headers) + " |", "|" + "---|" * len(headers)]
    lines += ["| " + " | ".join(str(c) for c in row) + " |" for row in rows]
    return lines + [""]


def base_name(algo: str) -> str:
    """"gpubf (CUDA emulation)" is gpubf."""
    return algo.split(" ")[0]


def algo_order(algos) -> list:
    known = broadphases.names()
    return sorted(algos, key=lambda a: (known.index(base_name(a)) if base_name(a) in known
                                        else len(known), a))
