"""Column names separated by single spaces, told apart by the units row (docs/contract.md section 10).

A whitespace-delimited export (MTS 793 "plain" data files, MTS TestSuite text
exports) may put single spaces inside names and between them alike:
``Ch 1 Displacement Ch 1 Force Time`` over ``mm kN Sec`` over rows of 3 numbers.
The header's W words are then split into the n names the data's cell count
asks for: among the C(W-1, n-1) ways of cutting the words into n contiguous
groups, the one scoring highest, lexicographically, on

1. groups holding a word that names the quantity of the unit below them
   (``Force`` over ``kN``, ``Displacement`` over ``mm``, ``Time`` over ``Sec``);
2. groups not starting with a number (the ``1`` of ``Ch 1`` never starts a name);
3. groups ending in that word (English puts the head noun last: ``Axial Force``,
   not ``Time Axial`` + ``Force``);
4. occurrences of a repeated word that start a group (the channel prefix ``Ch``
   starts every name it occurs in).

A tie of the best score is ambiguous: no names are guessed. Without a units
row, words ending in a bracketed unit (``Time [s] Axial Force [N]``) end names.
"""

from __future__ import annotations

import math
import re
from collections import Counter
from itertools import combinations

#: Largest number of cuttings tried (a longer header is not resolved).
MAX_CUTS = 20_000
#: Words that name a quantity (head nouns, not qualifiers like "Rotary", "Tip", "Elapsed"), by the
#: quantity kind of the unit under them (lowercase).
QUANTITY_WORDS: dict[str, frozenset[str]] = {
    "time": frozenset({"time", "sec", "seconds"}),
    # what the machine moves, and what the specimen does
    "length": frozenset({"displacement", "disp", "position", "crosshead", "stroke", "travel", "lvdt"})
    | {"extension", "elongation", "deflection", "extensometer", "length", "deformation"},
    "force": frozenset({"force", "load"}),
    "angle": frozenset({"angle", "rotation", "twist"}),
    "torque": frozenset({"torque", "moment"}),
    "strain": frozenset({"strain"}),
    "field": frozenset({"field", "flux", "induction"}),
}
#: A name followed by its bracketed unit, which may hold spaces (``Torque [N m]``).
_BRACKETED = re.compile(r"\S[^\[\]()]*?[\[(][^\[\]()]*[\])]")
_NUMBER = re.compile(r"^[+-]?(\d+\.?\d*|\.\d+)([eE][+-]?\d+)?$")


def kinds_of(unit: str) -> frozenset[str]:
    """The quantity kinds a unit text can be (empty when matid does not know it)."""
    from matid.units import UnitError, si_factor

    found = set()
    for kind in QUANTITY_WORDS:
        try:
            si_factor(unit.strip("()[] "), kind)
        except UnitError:
            continue
        found.add(kind)
    return frozenset(found)


def spaced_names(words: list[str], n: int, units: list[str] | None) -> list[str] | None:
    """The n names of a header of ``words`` (module docstring); None when they cannot be told apart."""
    if len(words) == n:
        return list(words)
    if len(words) < n or n < 1:
        return None
    if units is None or len(units) != n:
        found = _BRACKETED.findall(" ".join(words))
        same = "".join(found).replace(" ", "") == "".join(words)
        return [f.strip() for f in found] if len(found) == n and same else None
    if math.comb(len(words) - 1, n - 1) > MAX_CUTS:
        return None
    kinds = [kinds_of(u) for u in units]
    repeated = {w for w, c in Counter(words).items() if c > 1}
    scored: dict[tuple[int, ...], list[list[str]]] = {}
    for cuts in combinations(range(1, len(words)), n - 1):
        groups = [words[a:b] for a, b in zip((0, *cuts), (*cuts, len(words)), strict=True)]
        score = _score(groups, kinds, repeated)
        scored.setdefault(score, []).append([" ".join(g) for g in groups])
    best = scored[max(scored)]
    return best[0] if len(best) == 1 else None


def _names(word: str, kinds: frozenset[str]) -> bool:
    """Whether ``word`` names a quantity of one of ``kinds``."""
    return any(word.casefold().strip("()[]:") in QUANTITY_WORDS[k] for k in kinds)


def _score(groups: list[list[str]], kinds: list[frozenset[str]], repeated: set[str]) -> tuple[int, ...]:
    pairs = list(zip(groups, kinds, strict=True))
    named = sum(any(_names(w, ks) for w in g) for g, ks in pairs)
    unnumbered = sum(not _NUMBER.match(g[0]) for g in groups)
    headed = sum(_names(g[-1], ks) for g, ks in pairs)
    prefixed = sum(g[0] in repeated for g in groups)
    return named, unnumbered, headed, prefixed
