"""Parser of the term language (a small recursive-descent grammar, no ``eval``).

Grammar (whitespace is ignored; ``**`` may be written for ``^``, as in Python: ``z**3`` is read as
``z^3``, and every output shows the canonical spelling it was read as)::

    term     := factor ( "*" factor )*
    factor   := atom ( "^" INTEGER )?
    atom     := "1"
              | VARIABLE                       z or v
              | "px" "(" "z" ")"               Eq. 10-11
              | "|" product "|"  |  "abs" "(" product ")"
              | "sign" "(" product ")"         ("sgn" is accepted too)
              | "exp" "(" "-" "|" VARIABLE "|" "/" NUMBER ")"
              | "exp" "(" "-" "(" VARIABLE "/" NUMBER ")" "^" "2" ")"
              | "tanh" "(" VARIABLE "/" NUMBER ")"
              | "gap" "(" VARIABLE "," NUMBER ")"          clearance d >= 0
              | "stop" "(" VARIABLE "," ["-"] NUMBER ")"    one-sided, engages beyond d
              | "(" product ")"
    memory   := "bouc_wen" "(" ["-"] NUMBER "," ["-"] NUMBER ")"
              | "dahl" "(" NUMBER ")"                        a term of its own
    product  := factor ( "*" factor )*

A model is a comma-separated list of terms (commas inside parentheses belong
to the term). Errors carry the position of the offending character
(:class:`nlid.errors.TermError`).

Limits: parentheses, ``|...|`` and function calls nest at most
:data:`MAX_DEPTH` levels (the parser recurses once per level), and the power
of every variable and factor *in the normal form* is at most
:data:`~nlid.model.terms.term.MAX_POWER`, however it is written (``z^16``,
``z*z*...*z`` sixteen times and ``(z^4)^4`` are refused alike).
"""

from __future__ import annotations

import math
import re
from collections import Counter
from dataclasses import dataclass

from ...errors import TermError, brief, excerpt
from .term import MAX_POWER, VARIABLES, Term, _special_name

__all__ = ["parse_term", "split_terms", "MAX_DEPTH"]

#: Deepest nesting of parentheses, bars and function calls in one term.
MAX_DEPTH = 32

_TOKEN = re.compile(
    r"\s*(?:(?P<number>\d+\.?\d*(?:[eE][+-]?\d+)?|\.\d+(?:[eE][+-]?\d+)?)"
    r"|(?P<name>[A-Za-z_][A-Za-z_0-9]*)"
    r"|(?P<op>\*\*|[*^|()/,+-]))"
)
_FUNCTIONS = ("sign", "sgn", "abs", "px", "exp", "tanh", "gap", "stop", "bouc_wen", "dahl")
_MEMORY = ("bouc_wen", "dahl")


@dataclass(frozen=True)
class _Tok:
    kind: str  # number | name | op | end
    text: str
    pos: int

    @property
    def shown(self) -> str:
        """The token as messages echo it: quoted, cut when long (``'qqq...'... (100002 characters)``)."""
        return "end of term" if self.kind == "end" else brief(self.text, 40)


def _tokenize(text: str) -> list[_Tok]:
    toks: list[_Tok] = []
    pos = 0
    while pos < len(text):
        if text[pos].isspace():
            pos += 1
            continue
        m = _TOKEN.match(text, pos)
        if m is None or m.end() == pos:
            raise TermError(f"unexpected character {text[pos]!r}", text, pos)
        kind = m.lastgroup or "op"
        start = m.start(kind)
        value = m.group(kind)
        if value == "**":
            value = "^"
        toks.append(_Tok(kind, value, start))
        pos = m.end()
    toks.append(_Tok("end", "", len(text)))
    return toks


class _Mono:
    """A product of parts under construction (multiplication and powers)."""

    __slots__ = ("parts", "special", "memory")

    def __init__(
        self,
        parts: dict[str, tuple[int, int]] | None = None,
        special: Counter | None = None,
        memory: tuple[str, tuple[float, ...]] | None = None,
    ):
        self.parts = dict(parts or {})
        self.special: Counter = Counter(special or {})
        self.memory = memory

    @property
    def trivial(self) -> bool:
        """True for the constant 1."""
        return not self.parts and not any(self.special.values()) and self.memory is None

    def mul(self, other: _Mono) -> _Mono:
        parts = dict(self.parts)
        for var, (p, s) in other.parts.items():
            p0, s0 = parts.get(var, (0, 0))
            parts[var] = (p0 + p, (s0 + s) % 2)
        return _Mono(parts, self.special + other.special)

    def power(self, n: int) -> _Mono:
        parts = {var: (p * n, (s * n) % 2) for var, (p, s) in self.parts.items()}
        return _Mono(parts, Counter({k: c * n for k, c in self.special.items()}))

    def absolute(self) -> _Mono | None:
        if any(k[0] in ("tanh", "gap", "stop") for k in self.special) or self.memory is not None:
            return None
        return _Mono({var: (p, 0) for var, (p, s) in self.parts.items()}, self.special)

    def too_high(self) -> str | None:
        """The first factor whose power exceeds :data:`MAX_POWER`, as ``"z^16"``, else ``None``."""
        for var in VARIABLES:
            p, _ = self.parts.get(var, (0, 0))
            if p > MAX_POWER:
                return f"{'px(z)' if var == 'px' else var}^{p}"
        for (kind, var, scale), mult in self.special.items():
            if mult > MAX_POWER:
                return _special_name((kind, var, scale, mult))
        return None

    def to_term(self) -> Term:
        if self.memory is not None:
            return Term(memory=self.memory)
        kwargs = {}
        for var in VARIABLES:
            p, s = self.parts.get(var, (0, 0))
            if p == 0 and s == 0:
                continue
            kwargs[var] = (p, s)
        special = tuple(sorted((kind, var, scale, mult) for (kind, var, scale), mult in self.special.items() if mult))
        return Term(special=special, **kwargs)


class _Parser:
    def __init__(self, text: str):
        self.text = text
        self.toks = _tokenize(text)
        self.i = 0
        self.depth = 0

    # ---------------------------------------------------------------- helpers
    def peek(self) -> _Tok:
        return self.toks[self.i]

    def take(self) -> _Tok:
        tok = self.toks[self.i]
        self.i += 1
        return tok

    def fail(self, message: str, tok: _Tok | None = None) -> TermError:
        tok = tok or self.peek()
        return TermError(message, self.text, tok.pos)

    def expect(self, text: str, what: str | None = None) -> _Tok:
        tok = self.peek()
        if tok.text != text or tok.kind == "number":
            found = tok.shown
            raise self.fail(f"expected {what or repr(text)}, found {found}", tok)
        return self.take()

    def number(self, what: str) -> float:
        tok = self.peek()
        if tok.kind != "number":
            found = tok.shown
            raise self.fail(f"expected {what}, found {found}", tok)
        value = float(tok.text)
        if not math.isfinite(value):
            raise self.fail(f"the number {tok.shown} is too large", tok)
        self.take()
        return value

    def variable(self, allowed: tuple[str, ...] = ("z", "v")) -> str:
        tok = self.peek()
        if tok.kind == "name" and tok.text in allowed:
            self.take()
            return tok.text
        if tok.kind == "name":
            raise self.fail(f"unknown variable {tok.shown}: use z for displacement and v for velocity", tok)
        found = tok.shown
        raise self.fail(f"expected a variable (z or v), found {found}", tok)

    # ---------------------------------------------------------------- grammar
    def parse(self) -> Term:
        if self.peek().kind == "end":
            raise self.fail("empty term")
        mono = self.product(stop=("end",))
        tok = self.peek()
        if tok.kind != "end":
            raise self.fail(f"unexpected {tok.shown}", tok)
        high = mono.too_high()
        if high is not None:
            raise TermError(
                f"{excerpt(self.text.strip())} is {high} in normal form: powers above {MAX_POWER} are not allowed"
            )
        return mono.to_term()

    def nested(self, stop: tuple[str, ...], opener: _Tok) -> _Mono:
        """A product inside parentheses, bars or a function call (depth-limited)."""
        self.depth += 1
        if self.depth > MAX_DEPTH:
            raise self.fail(f"nested more than {MAX_DEPTH} levels deep", opener)
        try:
            return self.product(stop=stop)
        finally:
            self.depth -= 1

    def product(self, stop: tuple[str, ...]) -> _Mono:
        mono = self.factor()
        while True:
            tok = self.peek()
            if tok.text == "*":
                self.take()
                start = self.peek()
                other = self.factor()
                if (mono.memory is not None and not other.trivial) or (other.memory is not None and not mono.trivial):
                    raise self.fail(
                        "a memory term (bouc_wen, dahl) stands alone: it cannot be multiplied by other factors",
                        start if other.memory is not None else tok,
                    )
                mono = mono.mul(other) if mono.memory is None else mono
            elif tok.kind == "end" or tok.text in stop:
                return mono
            elif tok.text in ("+", "-"):
                raise self.fail(
                    f"{tok.shown} is not allowed inside a term: separate terms with commas "
                    "(each term gets its own coefficient)",
                    tok,
                )
            elif tok.text == "/":
                raise self.fail("division is only allowed as the scale inside exp(...) or tanh(...)", tok)
            else:
                raise self.fail(f"expected '*' between factors, found {tok.shown}", tok)

    def factor(self) -> _Mono:
        mono = self.atom()
        if self.peek().text == "^":
            self.take()
            tok = self.peek()
            if tok.kind != "number" or not re.fullmatch(r"\d+", tok.text):
                raise self.fail("expected a non-negative integer exponent", tok)
            self.take()
            digits = tok.text.lstrip("0") or "0"
            if len(digits) > 3:  # int() of a 5 000-digit exponent is refused by Python itself: never try it
                shown = digits if len(digits) <= 30 else f"{digits[:20]}... ({len(digits)} digits)"
                raise self.fail(f"exponent {shown} is larger than the maximum {MAX_POWER}", tok)
            n = int(digits)
            if n > MAX_POWER:
                raise self.fail(f"exponent {n} is larger than the maximum {MAX_POWER}", tok)
            if mono.memory is not None and n != 1:
                raise self.fail("a memory term (bouc_wen, dahl) cannot be raised to a power", tok)
            mono = mono.power(n) if mono.memory is None else mono
        return mono

    def atom(self) -> _Mono:
        tok = self.peek()
        if tok.kind == "number":
            if float(tok.text) != 1.0:
                raise self.fail(
                    f"a number ({tok.text if len(tok.text) <= 40 else tok.shown}) cannot be a factor: "
                    "coefficients are what nlid estimates; write the constant term as 1",
                    tok,
                )
            self.take()
            return _Mono()
        if tok.text == "|":
            self.take()
            inner = self.nested(("|",), tok)
            self.expect("|", "closing '|'")
            out = inner.absolute()
            if out is None:
                raise self.fail("|tanh(...)| is not supported", tok)
            return out
        if tok.text == "(":
            self.take()
            inner = self.nested((")",), tok)
            self.expect(")", "closing ')'")
            return inner
        if tok.kind == "name":
            name = tok.text
            if name in ("z", "v"):
                self.take()
                return _Mono({name: (1, 1)})
            if name not in _FUNCTIONS:
                hint = (
                    "use z for displacement and v for velocity"
                    if len(name) <= 2
                    else ("known functions: " + ", ".join(f for f in _FUNCTIONS if f != "sgn"))
                )
                raise self.fail(f"unknown name {tok.shown}: {hint}", tok)
            self.take()
            return getattr(self, "_fn_" + ("sign" if name == "sgn" else name))(tok)
        found = tok.shown
        raise self.fail(
            f"expected a factor (1, z, v, |...|, sign(...), px(z), exp(...), tanh(...)), found {found}", tok
        )

    # ---------------------------------------------------------------- functions
    def _fn_px(self, tok: _Tok) -> _Mono:
        self.expect("(")
        arg = self.peek()
        if arg.text != "z":
            raise self.fail("px takes the displacement: write px(z)", arg)
        self.take()
        self.expect(")", "closing ')'")
        return _Mono({"px": (1, 1)})

    def _fn_abs(self, tok: _Tok) -> _Mono:
        self.expect("(")
        inner = self.nested((")",), tok)
        self.expect(")", "closing ')'")
        out = inner.absolute()
        if out is None:
            raise self.fail("abs(tanh(...)) is not supported", tok)
        return out

    def _fn_sign(self, tok: _Tok) -> _Mono:
        self.expect("(")
        inner = self.nested((")",), tok)
        self.expect(")", "closing ')'")
        if inner.special or inner.memory is not None:
            raise self.fail("sign(...) of exp, tanh, gap, stop or a memory term is not supported", tok)
        # |x|^p > 0, so sign(|x|^p * sign(x)^s) = sign(x)^s
        return _Mono({var: (0, s) for var, (p, s) in inner.parts.items()})

    def _fn_exp(self, tok: _Tok) -> _Mono:
        self.expect("(")
        self.expect("-", "'-' (only decaying exponentials exp(-|v|/c) and exp(-(v/c)^2) are supported)")
        nxt = self.peek()
        if nxt.text == "|":
            self.take()
            var = self.variable()
            self.expect("|", "closing '|'")
            self.expect("/", "'/' followed by a positive scale")
            scale = self._scale()
            kind = "exp1"
        elif nxt.text == "(":
            self.take()
            var = self.variable()
            self.expect("/", "'/' followed by a positive scale")
            scale = self._scale()
            self.expect(")", "closing ')'")
            self.expect("^", "'^2'")
            two = self.peek()
            if two.text != "2":
                raise self.fail("only the Gaussian form exp(-(v/c)^2) is supported", two)
            self.take()
            kind = "exp2"
        else:
            raise self.fail("expected exp(-|v|/c) or exp(-(v/c)^2)", nxt)
        self.expect(")", "closing ')'")
        return _Mono(special=Counter({(kind, var, scale): 1}))

    def _fn_tanh(self, tok: _Tok) -> _Mono:
        self.expect("(")
        var = self.variable()
        self.expect("/", "'/' followed by a positive scale")
        scale = self._scale()
        self.expect(")", "closing ')'")
        return _Mono(special=Counter({("tanh", var, scale): 1}))

    def _fn_gap(self, tok: _Tok) -> _Mono:
        return self._kink("gap", signed=False)

    def _fn_stop(self, tok: _Tok) -> _Mono:
        return self._kink("stop", signed=True)

    def _kink(self, kind: str, signed: bool) -> _Mono:
        self.expect("(")
        var = self.variable()
        self.expect(",", f"',' then the {'position where it engages' if signed else 'clearance'} (m or m/s)")
        at = self.peek()
        value = self._signed_number("a clearance", signed)
        if not signed and value < 0:
            raise self.fail("a gap's clearance must not be negative (use stop(z, d) for a one-sided spring)", at)
        self.expect(")", "closing ')'")
        return _Mono(special=Counter({(kind, var, value): 1}))

    def _fn_bouc_wen(self, tok: _Tok) -> _Mono:
        self.expect("(")
        a = self._signed_number("the Bouc-Wen parameter a (1/m)", True)
        self.expect(",", "',' then the Bouc-Wen parameter b (1/m)")
        b = self._signed_number("the Bouc-Wen parameter b (1/m)", True)
        self.expect(")", "closing ')'")
        return _Mono(memory=("bouc_wen", (a, b)))

    def _fn_dahl(self, tok: _Tok) -> _Mono:
        self.expect("(")
        at = self.peek()
        rho = self._signed_number("the pre-sliding displacement rho (m)", False)
        if not rho > 0:
            raise self.fail("dahl's pre-sliding displacement rho must be positive", at)
        self.expect(")", "closing ')'")
        return _Mono(memory=("dahl", (rho,)))

    def _signed_number(self, what: str, signed: bool) -> float:
        negative = False
        if signed and self.peek().text == "-":
            self.take()
            negative = True
        value = self.number(what)
        return float(format(-value if negative else value, ".6g"))

    def _scale(self) -> float:
        tok = self.peek()
        value = self.number("a positive scale")
        if not value > 0:
            raise self.fail("the scale must be positive", tok)
        return float(format(value, ".6g"))


def parse_term(text: str) -> Term:
    """Parse one term, e.g. ``"sign(v)*|v|^2*|px(z)|"``.

    Parameters
    ----------
    text
        The term as written by a user.

    Returns
    -------
    Term
        The term in normal form; ``parse_term(t).name`` is the canonical
        spelling.

    Raises
    ------
    TermError
        With the position of the offending character.
    """
    if not isinstance(text, str):
        raise TermError(f"a term must be a string, got {type(text).__name__}")
    return _Parser(text).parse()


def split_terms(spec: str) -> list[tuple[str, int]]:
    """Split a comma-separated list of terms, keeping each term's offset.

    Empty items (``"z^3,,v"``) are an error.
    """
    out: list[tuple[str, int]] = []
    start = 0
    depth = 0
    for i, ch in enumerate(spec + ","):
        if ch == "(":
            depth += 1
        elif ch == ")":
            depth = max(0, depth - 1)
        elif ch == "," and depth > 0 and i < len(spec):
            continue  # a comma inside parentheses belongs to the term: gap(z, 0.01)
        if ch == ",":
            piece = spec[start:i]
            if not piece.strip():
                if spec.strip():
                    raise TermError("empty term in list", spec, start)
            else:
                out.append((piece, start))
            start = i + 1
    return out
