"""The mutants of a module, each named by its code (never by its line).

One mutant per site, in a fixed order over the syntax tree:
- comparisons: < ↔ <=, > ↔ >=, == ↔ !=, in ↔ not in, is ↔ is not
- arithmetic: + ↔ −, * ↔ /, // → /, % → //
- integer constants ± 1; True ↔ False
- a unary minus dropped (`x[-1]` → `x[+1]`), a `not` dropped
- min ↔ max, any ↔ all; and ↔ or
- a call made for its effect (a statement `f(…)`) replaced by `None`
Not mutated: docstrings, f-strings (messages), annotations, imports.

A mutant's id is `SCOPE: BEFORE → AFTER`: the enclosing function or class (dotted) or
`<module>`, and the smallest enclosing code that says what changed (the statement when
it is short, else the largest enclosing expression of at most `CONTEXT_CHARS`
characters), unparsed before and after. The same id twice in one module gets ` [2]`,
` [3]`… in the order of the tree. Edits elsewhere in the file leave an id unchanged,
so a list of equivalent mutants keyed by id stays right when lines move.
"""

from __future__ import annotations

import ast
import functools
from collections.abc import Callable
from dataclasses import dataclass

CONTEXT_CHARS = 100

_CMP_SWAP: dict[type[ast.cmpop], type[ast.cmpop]] = {
    ast.Lt: ast.LtE, ast.LtE: ast.Lt, ast.Gt: ast.GtE, ast.GtE: ast.Gt,
    ast.Eq: ast.NotEq, ast.NotEq: ast.Eq, ast.In: ast.NotIn, ast.NotIn: ast.In,
    ast.Is: ast.IsNot, ast.IsNot: ast.Is,
}
_BIN_SWAP: dict[type[ast.operator], type[ast.operator]] = {
    ast.Add: ast.Sub, ast.Sub: ast.Add, ast.Mult: ast.Div, ast.Div: ast.Mult,
    ast.FloorDiv: ast.Div, ast.Mod: ast.FloorDiv,
}
_CALL_SWAP = {"min": "max", "max": "min", "any": "all", "all": "any"}

Undo = Callable[[], None]


@dataclass(frozen=True)
class Site:
    index: int
    line: int           # for people reading a report; never part of the id
    scope: str
    before: str
    after: str
    ordinal: int = 1

    @property
    def id(self) -> str:
        suffix = f" [{self.ordinal}]" if self.ordinal > 1 else ""
        return f"{self.scope}: {self.before} → {self.after}{suffix}"


def _set(obj: object, attr: str, value: object) -> Undo:
    old = getattr(obj, attr)
    setattr(obj, attr, value)
    return lambda: setattr(obj, attr, old)


def _replace(parent: ast.AST, old: ast.AST, new: ast.AST) -> Undo:
    """Put `new` where `parent` holds `old` (a field or an item of a list field)."""
    for name, value in ast.iter_fields(parent):
        if value is old:
            return _set(parent, name, new)
        if isinstance(value, list) and any(v is old for v in value):
            i = next(k for k, v in enumerate(value) if v is old)
            value[i] = new

            def undo(value: list[ast.AST] = value, i: int = i) -> None:
                value[i] = old
            return undo
    raise AssertionError("the node is not a child of its parent")


def _set_item(seq: list[ast.cmpop], i: int, value: ast.cmpop) -> Undo:
    old = seq[i]
    seq[i] = value

    def undo() -> None:
        seq[i] = old
    return undo


class _Mutator(ast.NodeVisitor):
    """Walks the tree in a fixed order. Listing (`target` None): records every site with
    its code before and after. Otherwise applies site `target` in place and nothing else."""

    def __init__(self, target: int | None) -> None:
        self.target = target
        self.sites: list[Site] = []
        self.stack: list[ast.AST] = []
        self.scopes: list[str] = []

    def visit(self, node: ast.AST) -> None:
        self.stack.append(node)
        try:
            super().visit(node)
        finally:
            self.stack.pop()

    # --- what is never mutated ---------------------------------------------------------
    def visit_JoinedStr(self, node: ast.JoinedStr) -> None:
        return None

    def visit_Import(self, node: ast.Import) -> None:
        return None

    def visit_ImportFrom(self, node: ast.ImportFrom) -> None:
        return None

    def visit_arg(self, node: ast.arg) -> None:
        return None  # an annotation

    def visit_AnnAssign(self, node: ast.AnnAssign) -> None:
        if node.value is not None:
            self.visit(node.value)

    def _scoped(self, node: ast.FunctionDef | ast.AsyncFunctionDef | ast.ClassDef) -> None:
        self.scopes.append(node.name)
        try:
            for d in node.decorator_list:
                self.visit(d)
            if not isinstance(node, ast.ClassDef):
                self.visit(node.args)
            else:
                for b in [*node.bases, *node.keywords]:
                    self.visit(b)
            for s in node.body:
                self.visit(s)
        finally:
            self.scopes.pop()

    visit_FunctionDef = _scoped
    visit_AsyncFunctionDef = _scoped
    visit_ClassDef = _scoped

    # --- the sites ---------------------------------------------------------------------
    def visit_Expr(self, node: ast.Expr) -> None:
        if isinstance(node.value, ast.Constant) and isinstance(node.value.value, str):
            return  # a docstring
        self.generic_visit(node)
        if isinstance(node.value, ast.Call):
            self._site(node, lambda: _set(node, "value", ast.Constant(None)))

    def visit_Compare(self, node: ast.Compare) -> None:
        self.generic_visit(node)
        for i, op in enumerate(node.ops):
            swap = _CMP_SWAP.get(type(op))
            if swap is not None:
                self._site(node, functools.partial(_set_item, node.ops, i, swap()))

    def visit_BinOp(self, node: ast.BinOp) -> None:
        self.generic_visit(node)
        swap = _BIN_SWAP.get(type(node.op))
        if swap is not None and not _is_text(node):
            self._site(node, lambda: _set(node, "op", swap()))

    def visit_UnaryOp(self, node: ast.UnaryOp) -> None:
        self.generic_visit(node)
        if isinstance(node.op, ast.USub):
            self._site(node, lambda: _set(node, "op", ast.UAdd()))
        elif isinstance(node.op, ast.Not):
            parent = self.stack[-2]
            self._site(node, lambda: _replace(parent, node, node.operand),
                       replaced_by=node.operand)

    def visit_Constant(self, node: ast.Constant) -> None:
        v = node.value
        if isinstance(v, bool):
            self._site(node, lambda: _set(node, "value", not v))
        elif isinstance(v, int):
            for delta in (1, -1):
                self._site(node, functools.partial(_set, node, "value", v + delta))

    def visit_Call(self, node: ast.Call) -> None:
        self.generic_visit(node)
        func = node.func
        if isinstance(func, ast.Name) and func.id in _CALL_SWAP:
            self._site(node, lambda: _set(func, "id", _CALL_SWAP[func.id]))

    def visit_BoolOp(self, node: ast.BoolOp) -> None:
        self.generic_visit(node)
        self._site(node, lambda: _set(node, "op", ast.Or() if isinstance(node.op, ast.And)
                                      else ast.And()))

    def _site(self, node: ast.AST, apply: Callable[[], Undo], *,
              replaced_by: ast.AST | None = None) -> None:
        index = len(self.sites)
        if self.target is not None:
            self.sites.append(Site(index, 0, "", "", ""))
            if index == self.target:
                apply()
            return
        context = _context(self.stack)
        before = ast.unparse(context)
        if replaced_by is not None:  # the context may be the node itself: edit its text
            after = before.replace(ast.unparse(node), ast.unparse(replaced_by), 1)
        else:
            undo = apply()
            after = ast.unparse(context)
            undo()
        scope = ".".join(self.scopes) or "<module>"
        self.sites.append(Site(index, getattr(node, "lineno", 0), scope, _one_line(before),
                               _one_line(after)))


def _is_text(node: ast.BinOp) -> bool:
    """`"…" % x` and `"a" + "b"` build messages: not mutated (like f-strings)."""
    return any(isinstance(side, ast.Constant) and isinstance(side.value, str | bytes)
               for side in (node.left, node.right))


def _one_line(text: str) -> str:
    return " ".join(text.split())


def _context(stack: list[ast.AST]) -> ast.AST:
    """The code that names a site: its statement when short and simple, else the largest
    enclosing expression within CONTEXT_CHARS (at least the mutated node)."""
    statement = max(i for i, n in enumerate(stack) if isinstance(n, ast.stmt))
    stmt = stack[statement]
    if not hasattr(stmt, "body") and len(ast.unparse(stmt)) <= CONTEXT_CHARS:
        return stmt
    best = stack[-1]
    for node in reversed(stack[statement + 1:]):
        if isinstance(node, ast.expr | ast.keyword | ast.comprehension):
            if len(ast.unparse(node)) > CONTEXT_CHARS:
                break
            best = node
    return best


def sites(source: str) -> list[Site]:
    """Every mutation site of `source`, each with its id (ordinals numbered here)."""
    m = _Mutator(None)
    m.visit(ast.parse(source))
    seen: dict[str, int] = {}
    out = []
    for s in m.sites:
        key = f"{s.scope}: {s.before} → {s.after}"
        seen[key] = seen.get(key, 0) + 1
        out.append(Site(s.index, s.line, s.scope, s.before, s.after, seen[key]))
    return out


def mutant(source: str, index: int) -> str:
    """The source with site `index` mutated."""
    tree = ast.parse(source)
    _Mutator(index).visit(tree)
    return ast.unparse(tree)
