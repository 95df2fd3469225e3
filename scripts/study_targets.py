"""A section's targets and the verdict they give its claim.

Rules, each with its reason:
  * A section states each of its targets once, as a Target: what is asked, what was
    measured, and whether it was met (None: not run).  The section's own table and the
    findings' verdict are both made from that one list, so no verdict can contradict
    its section.
  * A claim holds when every target that ran was met, and does not hold when one was
    missed; a claim none of whose targets ran has no verdict at all (never "does not
    hold" for "not run", never "holds in 0 of 2 cells").
"""
import dataclasses

HOLDS, FAILS, NO_VERDICT = "holds", "does not hold", ""


@dataclasses.dataclass
class Target:
    name: str     # what is asked, as the section's table states it
    figure: str   # what was measured ("not run" when nothing was)
    met: object   # True, False, or None when not run

    def status(self) -> str:
        return {True: "met", False: "missed", None: "not run"}[self.met]


def not_run(name: str, why: str = "not run") -> Target:
    return Target(name, why, None)


def verdict(targets: list) -> str:
    ran = [t for t in targets if t.met is not None]
    if not ran:
        return NO_VERDICT
    return HOLDS if all(t.met for t in ran) else FAILS


def lines(targets: list, table) -> list:
    """The section's targets as its table: target, measured, met."""
    if not targets:
        return []
    return table(["target", "measured", "met"], [[t.name, t.figure, t.status()] for t in targets])
