"""The text form's expressions, read into sympy with bounds: nothing is evaluated, nothing grows unbounded.

A small parser of its own (precedence climbing), not Python's: Python's parser builds a sum of 3,000
terms as a tree 3,000 deep (RecursionError) and 100,000 unary minus signs as one 100,000 deep
(MemoryError). Here sums and products are read in loops and a run of signs is counted, so only
parentheses, calls and exponents nest, and they are bounded:

    sum     := product (("+" | "-") product)*
    product := unary (("*" | "/") unary)*
    unary   := ("+" | "-")* power
    power   := atom [("^" | "**") unary]               right-associative: 2^3^2 is 2^9
    atom    := number | name | function "(" sum ["," sum] ")" | "(" sum ")"

Bounds: MAX_CHARS characters, MAX_TERMS numbers, names and operations, MAX_DEPTH nested levels of
parentheses, calls and exponents. Numbers combine only while they stay finite doubles: a power of two
numbers is judged by the size of its result (its log10) before it is computed, so `9^9^9` is named,
never computed. A division by zero (`m/0`) and any other constant that is not a finite real number
(`log(0)`, `sqrt(-1)`, `1e400`) is named with the part that makes it. Names are NFKC-normalised
(as Python reads identifiers: the micro sign µ is μ, ℓ is l), so the caller normalises its declared
names the same way (`normalized`).
"""

from __future__ import annotations

import keyword
import math
import re
import unicodedata
from collections.abc import Mapping
from types import FunctionType
from typing import TYPE_CHECKING

from ..core.errors import HarnessError, shown

if TYPE_CHECKING:
    import sympy as sp

MAX_CHARS = 200_000  # characters of one expression (a 3,000-term V of a 6-link arm is about 120,000)
MAX_TERMS = 100_000  # numbers, names and operations of one expression
MAX_DEPTH = 100  # nested parentheses, calls and exponents
MAX_DIGITS = 308  # an integer literal of more digits is beyond a double
MAX_EXPONENT = 1024  # of a power of a symbol: x^1025 overflows a double for any |x| > 2
FUNCTIONS = {  # the name in the file -> sympy's
    "sin": "sin",
    "cos": "cos",
    "tan": "tan",
    "sqrt": "sqrt",
    "exp": "exp",
    "log": "log",
    "asin": "asin",
    "acos": "acos",
    "atan": "atan",
    "atan2": "atan2",
    "sinh": "sinh",
    "cosh": "cosh",
    "tanh": "tanh",
    "abs": "Abs",
}
CONSTANTS = ("pi",)
_TOKEN = re.compile(
    r"(?P<space>\s+)|(?P<number>(?:\d+(?:\.\d*)?|\.\d+)(?:[eE][-+]?\d+)?)|(?P<name>[^\W\d]\w*)"
    r"|(?P<op>\*\*|[-+*/^(),])|(?P<other>.)",
    re.DOTALL,
)
_CLOSE = {"(": ")", "[": "]"}


def normalized(name: str) -> str:
    """A name as the expressions read it: NFKC (Python's rule for identifiers)."""
    return unicodedata.normalize("NFKC", name)


def to_sympy(text: str, names: Mapping[str, sp.Expr], what: str) -> sp.Expr:
    """The sympy expression of `text` in the declared `names` (already `normalized`); a HarnessError
    naming `what`, the part and what is valid for anything else."""
    return _Parser(text, names, what).expression()


class _Parser:
    def __init__(self, text: str, names: Mapping[str, sp.Expr], what: str) -> None:
        self.text, self.names, self.what = text, names, what
        if len(text) > MAX_CHARS:
            raise self.error(f"has {len(text):,} characters; at most {MAX_CHARS:,}")
        self.tokens = [(m.lastgroup or "", m.group(), m.start()) for m in _TOKEN.finditer(text)]
        self.tokens = [t for t in self.tokens if t[0] != "space"]
        self.i = self.depth = self.terms = 0

    # ---- messages -------------------------------------------------------------------------------
    def error(self, why: str) -> HarnessError:
        return HarnessError(f'{self.what} = "{shown(self.text)}": {why}.')

    def named(self, why: str) -> HarnessError:
        """`cp.toml: V divides by zero: ...`: what the expression does, then the expression."""
        return HarnessError(f'{self.what} {why} (in "{shown(self.text)}").')

    def refuse(self, part: str, why: str) -> HarnessError:
        valid = (
            f"numbers, {', '.join(self.names) or '(no names)'}, + - * / ^, unary -, {', '.join(CONSTANTS)}, "
            f"and {', '.join(FUNCTIONS)}"
        )
        return self.error(f"{shown(part, 100)!r} {why}; valid: {shown(valid)}")

    def span(self, start: int) -> str:
        """The text from token `start` to the last token read."""
        end = self.tokens[self.i - 1]
        return self.text[self.tokens[start][2] : end[2] + len(end[1])]

    def chain(self, start: int) -> str:
        """The text of a postfix chain from offset `start`: a name or group followed by calls,
        indexing and attributes (`__import__('os').system('x')`), for the message refusing it."""
        j, depth, text = start, 0, self.text
        while j < len(text):
            c = text[j]
            if c in "([":
                depth += 1
            elif c in ")]":
                depth -= 1
                if depth < 0:
                    break
            elif depth == 0 and not (c.isalnum() or c in "_." or (c == "(" or c == "[")):
                break
            j += 1
        return text[start:j].strip()

    # ---- tokens ---------------------------------------------------------------------------------
    def peek(self) -> tuple[str, str, int]:
        return self.tokens[self.i] if self.i < len(self.tokens) else ("end", "", len(self.text))

    def take(self, *ops: str) -> str | None:
        kind, value, _ = self.peek()
        if kind == "op" and value in ops:
            self.i += 1
            return value
        return None

    def count(self, value: sp.Expr) -> sp.Expr:
        self.terms += 1
        if self.terms > MAX_TERMS:
            raise self.error(f"has more than {MAX_TERMS:,} numbers, names and operations; at most {MAX_TERMS:,}")
        return value

    def nest(self) -> None:
        self.depth += 1
        if self.depth > MAX_DEPTH:
            raise self.error(f"nests parentheses, calls and exponents deeper than {MAX_DEPTH} levels")

    # ---- grammar --------------------------------------------------------------------------------
    def expression(self) -> sp.Expr:
        value = self.sum()
        kind, token, offset = self.peek()
        if kind != "end":
            if token in (")", ","):
                raise self.refuse(token, f"at character {offset + 1} has no opening parenthesis or call")
            missing = " (an operator is missing before it)" if kind != "other" else ""
            raise self.refuse(self.chain(offset) or token, f"is not allowed{missing}")
        return value

    def sum(self) -> sp.Expr:
        import sympy as sp

        start, terms = self.i, [self.product()]
        while (op := self.take("+", "-")) is not None:
            term = self.product()
            terms.append(self.count(term if op == "+" else -term))
        return terms[0] if len(terms) == 1 else self.checked(sp.Add(*terms), start)

    def product(self) -> sp.Expr:
        import sympy as sp

        start, factors = self.i, [self.unary()]
        while (op := self.take("*", "/")) is not None:
            at = self.i
            factor = self.unary()
            if op == "/":
                if factor.is_number and factor == 0:
                    raise self.named(
                        f"divides by zero: {shown(self.span(start), 100)!r} divides by {shown(self.span(at), 100)!r}"
                    )
                factor = sp.Pow(factor, -1)
            factors.append(self.count(factor))
        return factors[0] if len(factors) == 1 else self.checked(sp.Mul(*factors), start)

    def unary(self) -> sp.Expr:
        negative = False
        while (op := self.take("+", "-")) is not None:  # a loop, not a recursion: 100,000 signs are one
            negative ^= op == "-"
        value = self.power()
        return self.count(-value) if negative else value

    def power(self) -> sp.Expr:
        start = self.i
        base = self.atom()
        if self.take("^", "**") is None:
            return base
        self.nest()
        exponent = self.unary()
        self.depth -= 1
        return self.checked(self.pow(base, exponent, start), start)

    def pow(self, base: sp.Expr, exponent: sp.Expr, start: int) -> sp.Expr:
        """base^exponent; of two numbers, only once its size is known to fit a double."""
        import sympy as sp

        if base.is_number and exponent.is_number:
            b, e = self.real(base, start), self.real(exponent, start)
            if b == 0 and e < 0:
                raise self.named(f"divides by zero: {shown(self.span(start), 100)!r} is zero to a negative power")
            size = e * math.log10(abs(b)) if b != 0 else 0.0
            if abs(size) > MAX_DIGITS:
                raise self.named(
                    f"is not finite: {shown(self.span(start), 100)!r} is about 10^{size:.3g}, beyond double "
                    "precision (|x| from 1e-308 to 1e308)"
                )
        elif exponent.is_number and abs(self.real(exponent, start)) > MAX_EXPONENT:
            raise self.named(
                f"is not finite: {shown(self.span(start), 100)!r} raises to a power of {float(exponent):.3g}; "
                f"an exponent is at most {MAX_EXPONENT} in size (past it a double overflows or vanishes)"
            )
        return self.count(sp.Pow(base, exponent))

    def atom(self) -> sp.Expr:
        kind, token, offset = self.peek()
        if kind == "number":
            self.i += 1
            return self.count(self.number(token))
        if kind == "name":
            return self.count(self.name(normalized(token), offset))
        if self.take("("):
            self.nest()
            value = self.sum()
            self.close(offset)
            self.depth -= 1
            self.after(offset)
            return value
        if kind == "end":
            raise self.error("ends where a number, a name or a parenthesis is expected")
        raise self.refuse(self.chain(offset) if token in "[" else token, "is not allowed")

    def close(self, offset: int) -> None:
        if self.take(")") is None:
            kind, token, at = self.peek()
            where = "the end" if kind == "end" else f"{token!r} at character {at + 1}"
            raise self.refuse(self.text[offset : offset + 1], f"at character {offset + 1} is not closed before {where}")

    def after(self, offset: int) -> None:
        """Nothing may follow an atom but an operator: a call, an index or an attribute is refused."""
        kind, token, _ = self.peek()
        if (kind == "op" and token == "(") or (kind == "other" and token in ".["):
            raise self.refuse(self.chain(offset), "is not allowed")

    def name(self, name: str, offset: int) -> sp.Expr:
        import sympy as sp

        self.i += 1
        kind, token, _ = self.peek()
        if name in FUNCTIONS and kind == "op" and token == "(":
            return self.call(name, offset)
        self.after(offset)
        if keyword.iskeyword(name):
            raise self.refuse(self.chain(offset), "is not allowed")
        if name in self.names:
            return self.names[name]
        if name in CONSTANTS:
            return sp.pi
        raise self.refuse(name, "is not a declared symbol, coordinate or velocity")

    def call(self, name: str, offset: int) -> sp.Expr:
        import sympy as sp

        start = self.i - 1
        self.take("(")
        self.nest()
        args = [self.sum()]
        while self.take(","):
            args.append(self.sum())
        self.close(offset)
        self.depth -= 1
        arity = 2 if name == "atan2" else 1
        if len(args) != arity:
            raise self.refuse(self.span(start), f"must have {arity} argument(s)")
        self.after(offset)
        return self.checked(getattr(sp, FUNCTIONS[name])(*args), start)

    # ---- numbers --------------------------------------------------------------------------------
    def number(self, token: str) -> sp.Expr:
        import sympy as sp

        if token.isdigit():
            if len(token.lstrip("0")) > MAX_DIGITS:
                raise self.refuse(token, f"has more than {MAX_DIGITS} digits, beyond double precision")
            return sp.Integer(int(token))
        value = float(token)
        if not math.isfinite(value) or (value == 0 and any(c in "123456789" for c in token.split("e")[0].lower())):
            raise self.refuse(token, "is not a double (|x| from 5e-324 to 1.8e308)")
        return sp.Float(value)

    def real(self, value: sp.Expr, start: int) -> float:
        """A constant as a finite double, or the message naming the part that is not one."""
        try:
            x = float(value)
        except TypeError:
            raise self.named(f"is not real: {shown(self.span(start), 100)!r} is {shown(value, 60)}") from None
        except OverflowError:
            x = math.inf
        if not math.isfinite(x):
            raise self.named(
                f"is not finite: {shown(self.span(start), 100)!r} is beyond double precision (|x| up to 1.8e308)"
            )
        return x

    def checked(self, value: sp.Expr, start: int) -> sp.Expr:
        """`value`, made of the tokens from `start`, if it is finite: a child was checked already, so
        only the new node and its own arguments can hold an infinity (sympy's zoo: `log(0)`)."""
        import sympy as sp

        bad = (sp.zoo, sp.oo, -sp.oo, sp.nan)
        if value in bad or any(a in bad for a in value.args):
            what = "complex infinity (zoo)" if value.has(sp.zoo) else str(value)
            raise self.named(f"is not finite: {shown(self.span(start), 100)!r} is {what}")
        if value.is_number:
            self.real(value, start)
        for a in value.args:  # sympy folds numbers into one coefficient: 1e200*1e200*m is 1e400*m
            if a.is_Number:
                self.real(a, start)
        return value


CHUNK = 64  # the most terms of one sum or product in one line of generated code


def lambdified(
    args: list[sp.Symbol], exprs: list[sp.Expr], *, common: bool = True
) -> FunctionType:  # lambdify's generated function: a list of floats or arrays out
    """`sympy.lambdify(args, exprs)` in numpy, with common subexpressions (`common`) and every sum or
    product of more than CHUNK terms computed in parts of CHUNK, each a line of its own: Python compiles
    `a + b + c + ...` as a tree as deep as it has terms, and 3,000 terms pass its recursion limit."""
    import functools

    import sympy as sp

    return sp.lambdify(args, exprs, modules="numpy", dummify=True, cse=functools.partial(_split_cse, common=common))


def _split_cse(exprs: list[sp.Expr], *, common: bool) -> tuple[list[tuple[sp.Symbol, sp.Expr]], list[sp.Expr]]:
    """sympy's cse (with `common`), then every long sum or product split (the `cse` argument of lambdify)."""
    import sympy as sp

    replacements, reduced = sp.cse(exprs) if common else ([], list(exprs))
    out: list[tuple[sp.Symbol, sp.Expr]] = []
    for symbol, value in replacements:
        out.append((symbol, _split(value, out)))
    return out, [_split(e, out) for e in reduced]


def _split(expr: sp.Expr, out: list[tuple[sp.Symbol, sp.Expr]]) -> sp.Expr:
    """`expr` with every Add or Mul of more than CHUNK arguments made a sum (product) of parts, each
    part a new symbol whose definition is appended to `out` (before the line that uses it)."""
    import sympy as sp

    if not isinstance(expr, sp.Basic) or not expr.args:
        return expr
    args = [_split(a, out) for a in expr.args]
    if (expr.is_Add or expr.is_Mul) and len(args) > CHUNK:
        while len(args) > CHUNK:
            parts = []
            for i in range(0, len(args), CHUNK):
                part = sp.Dummy()
                out.append((part, expr.func(*args[i : i + CHUNK], evaluate=False)))
                parts.append(part)
            args = parts
        return expr.func(*args, evaluate=False)
    return expr.func(*args) if any(a is not b for a, b in zip(args, expr.args, strict=True)) else expr
