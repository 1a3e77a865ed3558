"""The shape of the package: validate/ is `lagrange_xval`, its rooms follow the data one way, no cycles, no
private names across modules, no module that no import reaches, the sources (and the model's reader) the
only code that calls MuJoCo, Pinocchio or Drake, and no function past a reader's screen.

Read from the source with `ast` (nothing is imported): every import, relative or absolute
(`lagrange_xval.x`), at any depth (inside functions too), so a violation names the file and line.
"""

from __future__ import annotations

import ast
from pathlib import Path

VALIDATE = Path(__file__).resolve().parents[1] / "validate"
# Modules every room may use: the foundations (errors, input checks, safe file creation, the executor, the
# guard, the tolerance numbers, the cache and where the package's files are), and the contract's helpers
# that equations modules import (forms).
FOUNDATION = {"core", "forms"}
# A module may import its own room and the rooms below its own (the data flows one way).
LAYER = {
    "core": 0,
    "forms": 0,
    "model": 1,
    "results": 1,
    "handwritten": 2,
    "systems": 3,
    "symbolic": 4,
    "sources": 5,
    "dynamics": 6,
    "audit": 6,
    "verdict": 7,
    "stages": 8,
    "studies": 8,
    "api": 8,
    "report": 9,
    "replay": 9,
    "cli": 10,
    "testing": 11,
    "": 11,  # the face, validate/__init__.py
}
# Readers of results: the report reads results only; the replay also reads the model (systems, and the
# module's forms) to place the bodies it draws at the recorded coordinates.
READERS = {"report": {"results"}, "replay": {"results", "systems", "handwritten"}}
ENGINE_LIBRARIES = {"mujoco", "pinocchio", "pydrake", "warp", "mujoco_warp"}
# Where the import graph starts: the face, the command line, the helpers people import, and the worker's
# side of a person's module (started by name in a process of its own: handwritten/worker.py BOOT).
ENTRY_POINTS = {"", "cli.__main__", "testing", "forms", "handwritten.child"}
MAX_FUNCTION_LINES = 100


def _modules() -> dict[str, Path]:
    out = {}
    for path in VALIDATE.rglob("*.py"):
        parts = list(path.relative_to(VALIDATE).with_suffix("").parts)
        if parts[-1] == "__init__":
            parts = parts[:-1]
        out[".".join(parts)] = path
    return out


MODULES = _modules()


def _resolve(name: str, path: Path, node: ast.ImportFrom) -> str | None:
    """The module an import reads from, relative to validate/ ('' the face); None outside the package."""
    if node.level:
        package = name.split(".") if path.name == "__init__.py" else name.split(".")[:-1]
        package = [p for p in package if p]
        assert node.level - 1 <= len(package), f"{path}:{node.lineno} imports above the package"
        base = package[: len(package) - (node.level - 1)]
        return ".".join([*base, *(node.module.split(".") if node.module else [])])
    module = node.module or ""
    if module == "lagrange_xval" or module.startswith("lagrange_xval."):
        return module.removeprefix("lagrange_xval").lstrip(".")
    return None


def _imports(name: str, path: Path) -> list[tuple[str, str, int]]:
    """(target module, imported name, line) of every import of a package module by `name`."""
    out = []
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            out += [
                (a.name.removeprefix("lagrange_xval").lstrip("."), "", node.lineno)
                for a in node.names
                if a.name == "lagrange_xval" or a.name.startswith("lagrange_xval.")
            ]
            continue
        if not isinstance(node, ast.ImportFrom) or (target := _resolve(name, path, node)) is None:
            continue
        for alias in node.names:
            full = f"{target}.{alias.name}".strip(".")
            out.append((full, "", node.lineno) if full in MODULES else (target, alias.name, node.lineno))
    return out


def _top(module: str) -> str:
    return module.split(".")[0]


def test_imports_follow_the_data_one_way():
    bad = []
    for name, path in MODULES.items():
        for target, _, line in _imports(name, path):
            if _top(target) in FOUNDATION or _top(target) == _top(name) or not target:
                continue
            if _top(name) in READERS:
                ok = _top(target) in READERS[_top(name)]
            else:
                ok = LAYER[_top(target)] < LAYER[_top(name)]
            if not ok:
                bad.append(f"validate/{path.relative_to(VALIDATE)}:{line} imports {target}")
    assert not bad, "\n".join(bad)


def test_no_import_cycle():
    graph = {
        name: {t for t, _, _ in _imports(name, path) if t in MODULES and t != name} for name, path in MODULES.items()
    }
    state: dict[str, int] = {}
    stack: list[str] = []

    def visit(u: str) -> list[str] | None:
        state[u] = 1
        stack.append(u)
        for v in sorted(graph[u]):
            if state.get(v) == 1:
                return [*stack[stack.index(v) :], v]
            if not state.get(v):
                found = visit(v)
                if found:
                    return found
        stack.pop()
        state[u] = 2
        return None

    for module in sorted(graph):
        if not state.get(module):
            cycle = visit(module)
            assert cycle is None, "import cycle: " + " -> ".join(cycle)


def test_no_private_name_imported_across_modules():
    bad = [
        f"validate/{path.relative_to(VALIDATE)}:{line} imports {target}.{imported}"
        for name, path in MODULES.items()
        for target, imported, line in _imports(name, path)
        if imported.startswith("_") and target != name
    ]
    assert not bad, "\n".join(bad)


def test_only_the_sources_and_the_model_reader_import_an_engine():
    """sources/ call the engines; model/ and systems/ compile the file and read the compiled model's numbers."""
    bad = []
    for name, path in MODULES.items():
        if _top(name) in {"sources", "model", "systems"}:
            continue
        for node in ast.walk(ast.parse(path.read_text())):
            names = (
                [a.name for a in node.names]
                if isinstance(node, ast.Import)
                else [node.module or ""]
                if isinstance(node, ast.ImportFrom) and not node.level
                else []
            )
            bad += [
                f"validate/{path.relative_to(VALIDATE)}:{node.lineno} imports {n}"
                for n in names
                if n.split(".")[0] in ENGINE_LIBRARIES
            ]
    assert not bad, "\n".join(bad)


def test_the_harness_never_imports_the_notes_derivations():
    """equations/ and models/ are data the registry reads by file, never code the harness imports."""
    bad = [
        f"validate/{path.relative_to(VALIDATE)}:{line} imports {target}"
        for name, path in MODULES.items()
        for target, _, line in _imports(name, path)
        if _top(target) in {"equations", "models"}
    ]
    assert not bad, "\n".join(bad)


def _reached() -> set[str]:
    """Every module an import reaches from the entry points (importing a module imports its packages)."""
    seen: set[str] = set()
    todo = list(ENTRY_POINTS)
    while todo:
        name = todo.pop()
        if name in seen or name not in MODULES:
            continue
        seen.add(name)
        parts = name.split(".")
        todo += [".".join(parts[:i]) for i in range(1, len(parts))]
        todo += [t for t, _, _ in _imports(name, MODULES[name])]
    return seen


def test_every_module_is_reached_by_an_import():
    """No harness module lies outside the import graph (dead code, or code that only a test reaches)."""
    unreached = sorted(set(MODULES) - _reached())
    assert not unreached, "no import reaches: " + ", ".join(
        f"validate/{MODULES[m].relative_to(VALIDATE)}" for m in unreached
    )


def _functions() -> list[tuple[str, int, int]]:
    out = []
    for path in VALIDATE.rglob("*.py"):
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
                out.append(
                    (
                        f"validate/{path.relative_to(VALIDATE)}:{node.lineno} {node.name}",
                        node.lineno,
                        node.end_lineno or 0,
                    )
                )
    return out


def test_no_function_past_a_screen():
    """Rooms are cut by meaning, not by a file's length; a function a reader holds in mind fits a screen."""
    long = [
        f"{where} ({end - start + 1} lines)"
        for where, start, end in _functions()
        if end - start + 1 > MAX_FUNCTION_LINES
    ]
    assert not long, "\n".join(long)


def test_every_package_names_its_entry_points():
    """Each room's __init__ says what it is for and what it offers (`__all__`); the face offers the API."""
    bad = []
    for path in sorted(VALIDATE.rglob("__init__.py")):
        tree = ast.parse(path.read_text())
        names = {t.id for n in tree.body if isinstance(n, ast.Assign) for t in n.targets if isinstance(t, ast.Name)}
        if not ast.get_docstring(tree) or "__all__" not in names:
            bad.append(f"validate/{path.relative_to(VALIDATE)}")
    assert not bad, "without a docstring or __all__: " + ", ".join(bad)


def test_the_layout_check_sees_every_room():
    """A guard on the test itself: the rooms it judges are the ones on disk, and it reads imports."""
    assert {_top(m) for m in MODULES} <= set(LAYER)
    assert {"core", "model", "handwritten", "systems", "sources", "verdict", "results", "report", "cli"} <= {
        _top(m) for m in MODULES
    }
    assert len(_imports("verdict.decide", MODULES["verdict.decide"])) > 5


# ----------------------------------------------------------------------------------------------
# The readers never write into the results they read (the records of validate/results/schema.py)

MUTATORS = {"update", "setdefault", "pop", "popitem", "clear", "append", "extend", "insert", "remove", "sort"}
VIEWS = {"get", "items", "values", "keys"}  # a view of a record is the record's


def _record_types() -> set[str]:
    """The names of the result records: every class of validate/results/schema.py."""
    tree = ast.parse((VALIDATE / "results" / "schema.py").read_text())
    return {n.name for n in tree.body if isinstance(n, ast.ClassDef)}


def _root(node: ast.expr) -> str | None:
    """The name a subscript, attribute or view (`.get`, `.items`, ...) chain starts from."""
    while True:
        if isinstance(node, ast.Subscript | ast.Attribute):
            node = node.value
        elif isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute) and node.func.attr in VIEWS:
            node = node.func.value
        else:
            return node.id if isinstance(node, ast.Name) else None


def _from_record(expr: ast.expr, held: set[str]) -> bool:
    """`expr` is (a part of) a record held in one of the names `held`, not a copy of it."""
    if isinstance(expr, ast.BoolOp):
        return any(_from_record(v, held) for v in expr.values)
    if isinstance(expr, ast.IfExp):
        return _from_record(expr.body, held) or _from_record(expr.orelse, held)
    if isinstance(expr, ast.Call) and not (isinstance(expr.func, ast.Attribute) and expr.func.attr in VIEWS):
        return False  # a function's result (dict(...), sorted(...), a computation) is the reader's own
    return _root(expr) in held


def _holding_records(fn: ast.FunctionDef | ast.AsyncFunctionDef, records: set[str]) -> set[str]:
    """The parameters annotated with a record type, and the locals and loop variables bound to their parts."""
    args = (*fn.args.posonlyargs, *fn.args.args, *fn.args.kwonlyargs)
    held = {
        a.arg
        for a in args
        if a.annotation is not None
        and records & {n.id for n in ast.walk(a.annotation) if isinstance(n, ast.Name)}
        | {c.value for c in ast.walk(a.annotation) if isinstance(c, ast.Constant) and isinstance(c.value, str)}
    }
    while True:
        more = set(held)
        for node in ast.walk(fn):
            if isinstance(node, ast.Assign) and _from_record(node.value, held):  # bound to a name, not stored
                more |= {
                    n.id
                    for t in node.targets
                    if isinstance(t, ast.Name | ast.Tuple)
                    for n in ast.walk(t)
                    if isinstance(n, ast.Name)
                }
            if isinstance(node, ast.For | ast.comprehension) and _from_record(node.iter, held):
                more |= {n.id for n in ast.walk(node.target) if isinstance(n, ast.Name)}
        if more == held:
            return held
        held = more


def _writes(fn: ast.FunctionDef | ast.AsyncFunctionDef, held: set[str]) -> list[tuple[int, str]]:
    """Item or attribute assignments, deletions and mutating calls on what `held` names."""
    out = []
    for node in ast.walk(fn):
        targets: list[ast.expr] = []
        if isinstance(node, ast.Assign | ast.Delete):
            targets = node.targets
        elif isinstance(node, ast.AugAssign | ast.AnnAssign):
            targets = [node.target]
        out += [
            (node.lineno, ast.unparse(t))
            for t in targets
            if isinstance(t, ast.Subscript | ast.Attribute) and _root(t) in held
        ]
        if isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute) and node.func.attr in MUTATORS:
            if _root(node.func.value) in held:
                out.append((node.lineno, ast.unparse(node.func)))
    return out


def record_writes(source: str, records: set[str]) -> list[tuple[int, str]]:
    """Every write into a result record in a module's source."""
    tree = ast.parse(source)
    functions = [n for n in ast.walk(tree) if isinstance(n, ast.FunctionDef | ast.AsyncFunctionDef)]
    return [w for fn in functions for w in _writes(fn, _holding_records(fn, records))]


def test_the_readers_never_write_into_the_records_they_read():
    """The result records are data once made: the report and the replay read them and never assign into
    them, delete from them or call a mutating method on them (or on a part of them held in a local)."""
    records = _record_types()
    bad = [
        f"validate/{path.relative_to(VALIDATE)}:{line}: {what}"
        for reader in READERS
        for path in sorted((VALIDATE / reader).rglob("*.py"))
        for line, what in record_writes(path.read_text(), records)
    ]
    assert not bad, "a reader writes into a result record:\n" + "\n".join(bad)


def test_the_record_writes_check_sees_a_write():
    """A write through a parameter, through a part of it held in a local, and through a loop variable."""
    source = (
        "def f(s: SystemResult, rows: list[ComparisonRow], other: dict) -> None:\n"
        "    s['passed'] = True\n"
        "    tr = s.get('trajectories') or {}\n"
        "    tr['t'].append(1)\n"
        "    for r in rows:\n"
        "        r.update(x=1)\n"
        "    mine = dict(s)\n"
        "    mine['x'] = 1\n"
        "    other['y'] = 2\n"
        "    kept = {}\n"
        "    kept[s['name']] = s\n"
    )
    lines = [line for line, _ in record_writes(source, {"SystemResult", "ComparisonRow"})]
    assert lines == [2, 4, 6]
