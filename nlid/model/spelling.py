"""Spelling of terms on connections: indexed coordinates rewritten to the one-DOF grammar, and back.

:func:`rewrite` turns ``"sign(v2-v1)"`` into the one-DOF term ``sign(v)`` on
the connection ``(1, 2)`` with the sign ``-1`` (its orientation normalised by
parity, :mod:`nlid.model.elements`), calling :func:`nlid.model.terms.parse_term` on the
rewritten text (never ``eval``); :func:`render` writes a term on a connection
in its canonical spelling (``(z1-z2)^3``, ``sign(v1-v2)``, ``z3^3``).
"""

from __future__ import annotations

import re

from ..errors import TermError
from .terms import Term, parse_term

__all__ = ["rewrite", "render", "canonical", "coordinate", "Connection", "MAX_LENGTH"]

#: ``(i, j)``: DOF ``i`` and DOF ``j`` (1-based), ``j = 0`` the ground; canonical: ``i < j`` or ``j = 0``.
Connection = tuple[int, int]

#: Longest element text parsed (the one-DOF grammar has its own limits on what it is given).
MAX_LENGTH = 2000

# A parenthesised difference "(z1-z2)" not preceded by a name (so "px(z1-z2)" is a call), a bare
# difference "v2 - v1", a single indexed coordinate "z3", or a coordinate without its DOF number.
_COORD = re.compile(
    r"(?P<paren>(?<![A-Za-z_0-9])\(\s*(?P<pa>[A-Za-z_]\w*?)(?P<pi>\d+)\s*-\s*(?P<pb>[A-Za-z_]\w*?)(?P<pj>\d+)\s*\))"
    r"|(?P<diff>(?<![A-Za-z_0-9])(?P<da>[zv])(?P<di>\d+)\s*-\s*(?P<db>[A-Za-z_]\w*?)(?P<dj>\d+)(?![A-Za-z_0-9]))"
    r"|(?P<single>(?<![A-Za-z_0-9])(?P<sa>[zv])(?P<si>\d+)(?![A-Za-z_0-9]))"
    r"|(?P<bare>(?<![A-Za-z_0-9])[zv](?![A-Za-z_0-9]))"
)
_MEMORY = re.compile(r"\b(bouc_wen|dahl)\s*\(\s*")
_MEMORY_ARG = re.compile(r"\b(bouc_wen|dahl)\s*\(\s*([zv])\s*,\s*")
_VARIABLE = re.compile(r"(?<![A-Za-z_0-9])([zv])(?![A-Za-z_0-9])")


def canonical(i: int, j: int) -> Connection:
    """The connection ``{i, j}`` in canonical orientation (lower DOF first, ground last)."""
    if j == 0:
        return (i, 0)
    return (min(i, j), max(i, j))


def coordinate(letter: str, connection: Connection) -> str:
    """``z1-z2`` or ``z3``: the relative coordinate of a connection as written."""
    i, j = connection
    return f"{letter}{i}" if j == 0 else f"{letter}{i}-{letter}{j}"


# --------------------------------------------------------------------------- naming
def render(term: Term, connection: Connection) -> str:
    """The canonical spelling of ``term`` on ``connection``: the one-DOF name with indexed coordinates."""
    name = term.name
    if term.memory is not None:
        law, _, rest = name.partition("(")
        return f"{law}({coordinate('z', connection)}, {rest}"
    ground = connection[1] == 0
    out, last = [], 0
    for m in _VARIABLE.finditer(name):
        letter = m.group(1)
        before = name[: m.start()].rstrip()[-1:]
        after = name[m.end() :].lstrip()[:1]
        written = coordinate(letter, connection)
        if not ground and not (before in ("(", "|", ",") and after in (")", "|", ",")):
            written = f"({written})"
        out.append(name[last : m.start()] + written)
        last = m.end()
    out.append(name[last:])
    return "".join(out)


# --------------------------------------------------------------------------- parsing
def _flip(term: Term, flip_z: bool, flip_v: bool, text: str) -> tuple[Term, float]:
    """``term`` with its z and/or v argument negated, in normal form: ``(term', sign)`` with ``g(-x) = sign g'(x)``."""
    if not (flip_z or flip_v):
        return term, 1.0
    if term.memory is not None:  # both laws are odd: w(-x) = -w(x)
        return term, -1.0 if flip_z else 1.0
    sign = 1.0
    if flip_z and term.z[1]:
        sign = -sign
    if flip_v and term.v[1]:
        sign = -sign
    special = []
    for kind, var, scale, mult in term.special:
        flipped = flip_z if var == "z" else flip_v
        if flipped and kind in ("tanh", "gap") and mult % 2:
            sign = -sign
        elif flipped and kind == "stop":
            if scale == 0.0:
                raise TermError(
                    "stop(..., 0) on the reversed coordinate is min(x, 0), which has no spelling in the canonical "
                    "order (lower DOF first); write it with a small clearance, e.g. stop(..., -1e-9)",
                    text,
                )
            scale = -scale
            if mult % 2:
                sign = -sign
        special.append((kind, var, scale, mult))
    return Term(z=term.z, v=term.v, px=term.px, special=tuple(sorted(special))), sign


def _scan(text: str) -> tuple[str, list[int], list[tuple[str, int, int, int]]]:
    """Rewrite indexed coordinates to ``z``/``v``: ``(rewritten, position map, [(letter, i, j, position)])``."""
    pieces: list[str] = []
    where: list[int] = []
    found: list[tuple[str, int, int, int]] = []
    last = 0
    for m in _COORD.finditer(text):
        if m.group("bare"):
            raise TermError(
                "name the degree of freedom: write z1, v2 or a difference such as z1-z2 (DOFs are numbered from 1)",
                text,
                m.start(),
            )
        if m.group("paren"):
            a, i, b, j = m.group("pa", "pi", "pb", "pj")
        elif m.group("diff"):
            a, i, b, j = m.group("da", "di", "db", "dj")
        else:
            a, i, b, j = m.group("sa"), m.group("si"), m.group("sa"), "0"
        if a not in ("z", "v") or a != b:
            raise TermError(
                f"a relative coordinate is a difference of two displacements (z1-z2) or two velocities (v1-v2), "
                f"got {m.group(0).strip()!r}",
                text,
                m.start(),
            )
        first, second = int(i), int(j)
        if first == 0 or (m.group("single") is None and second == 0):
            raise TermError("DOFs are numbered from 1; a connection to the ground is written z3 or v3", text, m.start())
        if first == second:
            raise TermError(f"{m.group(0).strip()!r} is zero: a connection joins two different DOFs", text, m.start())
        pieces.append(text[last : m.start()])
        where.extend(range(last, m.start()))
        pieces.append(a)
        where.append(m.start())
        found.append((a, first, second, m.start()))
        last = m.end()
    pieces.append(text[last:])
    where.extend(range(last, len(text) + 1))
    return "".join(pieces), where, found


def rewrite(text: str) -> tuple[Term, Connection, float]:
    """``(term, connection, sign)`` of a term on a connection as written (see
    :func:`nlid.model.elements.parse_element`).

    Raises
    ------
    TermError
        As :func:`nlid.model.elements.parse_element`.
    """
    if not isinstance(text, str):
        raise TermError(f"a term must be a string, got {type(text).__name__}")
    if len(text) > MAX_LENGTH:
        raise TermError(f"a term of {len(text)} characters is longer than the {MAX_LENGTH} allowed")
    rewritten, where, found = _scan(text)
    law = _MEMORY.search(text)
    if not found and law is not None:
        raise TermError(
            f"a memory law on a connection takes its displacement first: {law.group(1)}(z1-z2, ...) or "
            f"{law.group(1)}(z3, ...)",
            text,
            law.end(),
        )
    if not found:
        raise TermError(
            f"{text.strip()!r} names no connection: write its coordinate, e.g. (z1-z2)^3 or z3^3 "
            "(static loads are the model's static force per DOF)",
            text,
        )
    memory = _MEMORY.search(rewritten)
    if memory is not None:
        arg = _MEMORY_ARG.match(rewritten, memory.start())
        if arg is None:
            raise TermError(
                f"a memory law on a connection takes its displacement first: {memory.group(1)}(z1-z2, ...)",
                text,
                where[memory.end()],
            )
        if arg.group(2) != "z":
            raise TermError(
                f"{memory.group(1)} follows the connection's displacement, not its velocity", text, where[arg.start(2)]
            )
        rewritten = rewritten[: memory.end()] + rewritten[arg.end() :]
        where = where[: memory.end()] + where[arg.end() :]
    try:
        term = parse_term(rewritten)
    except TermError as exc:
        pos = None if exc.position is None else where[min(exc.position, len(where) - 1)]
        raise TermError(exc.reason, text, pos) from None
    if term.is_constant:
        raise TermError(f"{text.strip()!r} is the constant 1, not a term on a connection", text)
    pairs = {canonical(i, j) for _, i, j, _ in found}
    if len(pairs) > 1:
        shown = " and ".join(coordinate("z", p) for p in sorted(pairs))
        raise TermError(f"one term acts on one connection, this one mixes {shown}", text, found[-1][3])
    connection = pairs.pop()
    flips: dict[str, set[bool]] = {}
    for letter, i, j, pos in found:
        flips.setdefault(letter, set()).add((i, j) != connection)
        if len(flips[letter]) > 1:
            raise TermError(
                f"write every {letter} of one term in the same order ({coordinate(letter, connection)})", text, pos
            )
    term, sign = _flip(term, True in flips.get("z", ()), True in flips.get("v", ()), text)
    return term, connection, sign
