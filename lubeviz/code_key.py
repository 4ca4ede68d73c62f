"""What of a module's source a cache key holds: its code, not its wording.

Cached results (film tables, the independent records) are keyed by the source of the code that made them, so that
an edit to that code makes them again. Docstrings and comments do not change what the code computes, and they
change often; `code_text` is a module's syntax tree with every docstring taken out, so that a reworded docstring or
comment leaves every key as it was, while any change to a statement, a name or a constant changes it.
"""

from __future__ import annotations

import ast
import functools
from pathlib import Path

_DOCUMENTED = (ast.Module, ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef)


def _undocumented(tree: ast.AST) -> ast.AST:
    for node in ast.walk(tree):
        body = getattr(node, "body", None)
        if (isinstance(node, _DOCUMENTED) and body and isinstance(body[0], ast.Expr)
                and isinstance(body[0].value, ast.Constant) and isinstance(body[0].value.value, str)):
            node.body = body[1:] or [ast.Pass()]
    return tree


@functools.lru_cache(maxsize=512)
def _code_text(source: bytes) -> bytes:
    return ast.dump(_undocumented(ast.parse(source)), annotate_fields=False).encode()


def code_text(path: Path) -> bytes:
    """The code of the Python file at `path` without its docstrings and comments, as text (its syntax tree)."""
    return _code_text(Path(path).read_bytes())


def feed_code(h, root: Path, files) -> None:
    """Feed each of `files` (paths under `root`), its path relative to `root` and its code, into the hash `h`."""
    for f in files:
        h.update(Path(f).relative_to(root).as_posix().encode() + b"\0" + code_text(f) + b"\0")
