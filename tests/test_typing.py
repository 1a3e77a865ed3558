"""How much of the harness's typing says nothing: the share of annotations in validate/ that mention `Any`.

Read from the source with `ast` (nothing is imported). An annotation is a parameter's, a return's or an
annotated assignment's; it mentions `Any` when `Any` (or `typing.Any`) appears anywhere in it, so
`dict[str, Any]` counts. Issue 37 asks for under 10%; MAX_ANY_SHARE is where the harness stands now, and
may only go down.
"""

from __future__ import annotations

import ast
from collections.abc import Iterator
from pathlib import Path

VALIDATE = Path(__file__).resolve().parents[1] / "validate"
MAX_ANY_SHARE = 0.233  # 1552 of 6662 now (23.3%); 1687 of 6593 (25.6%) at issue 37's start


def annotations(tree: ast.AST) -> Iterator[ast.expr]:
    """Every annotation in `tree`: parameters (with *args and **kwargs), returns, annotated assignments."""
    for node in ast.walk(tree):
        if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
            a = node.args
            for arg in (*a.posonlyargs, *a.args, *a.kwonlyargs, a.vararg, a.kwarg):
                if arg is not None and arg.annotation is not None:
                    yield arg.annotation
            if node.returns is not None:
                yield node.returns
        elif isinstance(node, ast.AnnAssign):
            yield node.annotation


def mentions_any(annotation: ast.expr) -> bool:
    """`Any` appears in the annotation (a string annotation is parsed first)."""
    if isinstance(annotation, ast.Constant) and isinstance(annotation.value, str):
        annotation = ast.parse(annotation.value, mode="eval").body
    return any(
        (isinstance(n, ast.Name) and n.id == "Any") or (isinstance(n, ast.Attribute) and n.attr == "Any")
        for n in ast.walk(annotation)
    )


def any_counts() -> dict[str, tuple[int, int]]:
    """Per module of validate/: (annotations that mention Any, annotations)."""
    counts = {}
    for path in sorted(VALIDATE.rglob("*.py")):
        found = list(annotations(ast.parse(path.read_text(), filename=str(path))))
        counts[str(path.relative_to(VALIDATE))] = (sum(map(mentions_any, found)), len(found))
    return counts


def test_counter_sees_any() -> None:
    """The counter finds `Any` inside a parameter, a return, an assignment and a string annotation."""
    tree = ast.parse("def f(a: int, b: dict[str, Any], *c: 'list[typing.Any]') -> Any:\n    x: int = 1\n")
    assert [mentions_any(a) for a in annotations(tree)] == [False, True, True, True, False]


def test_any_share_stays_below_threshold() -> None:
    """At most MAX_ANY_SHARE of the annotations in validate/ mention Any (issue 37: under 10%)."""
    counts = any_counts()
    anys, total = sum(a for a, _ in counts.values()), sum(n for _, n in counts.values())
    worst = sorted(counts.items(), key=lambda kv: -kv[1][0])[:5]
    assert anys / total <= MAX_ANY_SHARE, (
        f"{anys} of {total} annotations ({anys / total:.1%}) mention Any, above {MAX_ANY_SHARE:.1%}; "
        f"most in {', '.join(f'{k} ({a})' for k, (a, _) in worst)}"
    )
