# SPDX-License-Identifier: MIT
"""A small C preprocessor in pure Python, enough for defsim's public header.

cffi's ABI mode needs declarations without preprocessor directives. Rather than require a C
compiler (``cpp``) at import time, or ship a copy of the declarations that can drift from the
header, the package preprocesses ``defsim/defsim.h`` itself when it is imported. The header is
written to make this easy (see STYLE.md): object-like macros only, explicit enum values, no
inline functions.

Supported: comments, line continuations, ``#include "..."`` (searched in the including file's
directory, then the include path; ``<...>`` system headers are skipped: cffi knows the
``<stdint.h>``/``<stddef.h>`` types), object-like ``#define``/``#undef``, ``#if``/``#ifdef``/
``#ifndef``/``#elif``/``#else``/``#endif`` with ``defined``, ``!``, ``&&``, ``||``, comparisons
and integer arithmetic, ``#error``, and expansion of object-like macros in the code. Function-like
macros are rejected with an error, since the public header must not need them.
"""
from __future__ import annotations

import ast
import operator
import os
import re
from typing import Dict, List, Optional, Sequence, Tuple

__all__ = ["HeaderError", "preprocess", "eval_int"]


class HeaderError(Exception):
    """The header could not be found or uses something this preprocessor does not handle."""


_IDENT = re.compile(r"[A-Za-z_]\w*")
_DIRECTIVE = re.compile(r"^\s*#\s*(\w*)\s*(.*?)\s*$")
_TOKENS = re.compile(
    r'"(?:\\.|[^"\\])*"'       # string literal
    r"|'(?:\\.|[^'\\])*'"      # char literal
    r"|\.?\d[\w.]*"            # number (a pp-number: 0x1F, 10u, 1.5e3)
    r"|[A-Za-z_]\w*"           # identifier
    r"|\S"                     # anything else, one character at a time
)


def _strip_comments(text: str) -> str:
    """Removes /* */ and // comments (outside string literals) and joins continued lines."""
    text = text.replace("\\\n", "")
    out: List[str] = []
    i, n = 0, len(text)
    while i < n:
        c = text[i]
        if c == '"' or c == "'":
            j = i + 1
            while j < n and text[j] != c:
                j += 2 if text[j] == "\\" else 1
            out.append(text[i:j + 1])
            i = j + 1
        elif text.startswith("/*", i):
            j = text.find("*/", i + 2)
            if j < 0:
                raise HeaderError("unterminated /* comment")
            # Keep line numbers: a block comment becomes its newlines.
            out.append(" " + "\n" * text.count("\n", i, j))
            i = j + 2
        elif text.startswith("//", i):
            j = text.find("\n", i)
            i = n if j < 0 else j
        else:
            out.append(c)
            i += 1
    return "".join(out)


_BINOPS = {
    ast.Add: operator.add, ast.Sub: operator.sub, ast.Mult: operator.mul,
    ast.FloorDiv: operator.floordiv, ast.Mod: operator.mod, ast.LShift: operator.lshift,
    ast.RShift: operator.rshift, ast.BitOr: operator.or_, ast.BitAnd: operator.and_,
    ast.BitXor: operator.xor,
}
_CMPOPS = {
    ast.Eq: operator.eq, ast.NotEq: operator.ne, ast.Lt: operator.lt, ast.LtE: operator.le,
    ast.Gt: operator.gt, ast.GtE: operator.ge,
}


def _eval_node(node: ast.AST) -> int:
    if isinstance(node, ast.Expression):
        return _eval_node(node.body)
    if isinstance(node, ast.Constant) and isinstance(node.value, int):
        return int(node.value)
    if isinstance(node, ast.UnaryOp):
        v = _eval_node(node.operand)
        if isinstance(node.op, ast.Not):
            return int(not v)
        if isinstance(node.op, ast.USub):
            return -v
        if isinstance(node.op, ast.UAdd):
            return v
        if isinstance(node.op, ast.Invert):
            return ~v
    if isinstance(node, ast.BinOp) and type(node.op) in _BINOPS:
        return _BINOPS[type(node.op)](_eval_node(node.left), _eval_node(node.right))
    if isinstance(node, ast.BoolOp):
        vals = [_eval_node(v) for v in node.values]
        return int(all(vals) if isinstance(node.op, ast.And) else any(vals))
    if isinstance(node, ast.Compare):
        left = _eval_node(node.left)
        for op, right_node in zip(node.ops, node.comparators):
            right = _eval_node(right_node)
            if type(op) not in _CMPOPS or not _CMPOPS[type(op)](left, right):
                return 0
            left = right
        return 1
    raise HeaderError("unsupported construct in an integer expression")


def _c_int(literal: str) -> int:
    if literal[:2].lower() == "0x":
        return int(literal, 16)
    if len(literal) > 1 and literal[0] == "0":
        return int(literal, 8)
    return int(literal)


def eval_int(expr: str) -> int:
    """Evaluates a C integer constant expression (already macro-expanded) without eval()."""
    e = re.sub(r"\b(0[xX][0-9a-fA-F]+|\d+)[uUlL]*\b", lambda m: str(_c_int(m.group(1))), expr)
    e = e.replace("&&", " and ").replace("||", " or ").replace("/", "//")
    e = re.sub(r"!(?!=)", " not ", e)
    try:
        tree = ast.parse(e.strip(), mode="eval")
    except SyntaxError as exc:
        raise HeaderError(f"cannot evaluate #if expression {expr!r}") from exc
    return _eval_node(tree)


class _State:
    def __init__(self, include_path: Sequence[str], macros: Dict[str, str]) -> None:
        self.include_path = list(include_path)
        self.macros = dict(macros)
        self.out: List[str] = []
        self.files: List[str] = []

    def expand(self, text: str, active: Tuple[str, ...] = ()) -> str:
        def repl(m: "re.Match[str]") -> str:
            tok = m.group(0)
            if tok[0] in "\"'" or tok not in self.macros or tok in active:
                return tok
            return self.expand(self.macros[tok], active + (tok,))
        return _TOKENS.sub(repl, text)

    def eval_condition(self, expr: str) -> bool:
        # `defined X` and `defined(X)` first, then macros; unknown identifiers are 0 (C rule).
        expr = re.sub(r"\bdefined\s*\(\s*(\w+)\s*\)|\bdefined\s+(\w+)",
                      lambda m: "1" if (m.group(1) or m.group(2)) in self.macros else "0", expr)
        expr = self.expand(expr)
        expr = _TOKENS.sub(lambda m: "0" if _IDENT.fullmatch(m.group(0)) else m.group(0), expr)
        return bool(eval_int(expr))

    def find(self, name: str, here: Optional[str]) -> str:
        dirs = ([here] if here else []) + self.include_path
        for d in dirs:
            p = os.path.join(d, name)
            if os.path.isfile(p):
                return p
        raise HeaderError(f"#include \"{name}\": not found in {dirs}")

    def run(self, path: str) -> None:
        if len(self.files) > 32:
            raise HeaderError("#include nested too deeply")
        self.files.append(path)
        with open(path, encoding="utf-8") as f:
            lines = _strip_comments(f.read()).split("\n")
        # Stack of (this branch active, some branch of this group taken, parent active).
        stack: List[Tuple[bool, bool, bool]] = []
        active = True
        for lineno, line in enumerate(lines, 1):
            m = _DIRECTIVE.match(line)
            if not m:
                if active and line.strip():
                    self.out.append(self.expand(line))
                continue
            d, rest = m.group(1), m.group(2)
            where = f"{path}:{lineno}"
            if d in ("if", "ifdef", "ifndef"):
                if not active:
                    cond = False
                elif d == "if":
                    cond = self.eval_condition(rest)
                else:
                    cond = (rest.split()[0] in self.macros) == (d == "ifdef")
                stack.append((cond, cond, active))
                active = active and cond
            elif d in ("elif", "else"):
                if not stack:
                    raise HeaderError(f"{where}: #{d} without #if")
                _, taken, parent = stack.pop()
                cond = parent and not taken and (d == "else" or self.eval_condition(rest))
                stack.append((cond, taken or cond, parent))
                active = cond
            elif d == "endif":
                if not stack:
                    raise HeaderError(f"{where}: #endif without #if")
                active = stack.pop()[2]
            elif not active:
                continue
            elif d == "define":
                mm = re.match(r"([A-Za-z_]\w*)(\()?\s*(.*)$", rest)
                if not mm:
                    raise HeaderError(f"{where}: malformed #define")
                if mm.group(2):
                    raise HeaderError(f"{where}: function-like macro {mm.group(1)} is not supported")
                self.macros[mm.group(1)] = mm.group(3)
            elif d == "undef":
                self.macros.pop(rest.split()[0], None)
            elif d == "include":
                if rest.startswith("<"):
                    continue   # system headers: cffi knows the standard types
                mm = re.match(r'"([^"]+)"', rest)
                if not mm:
                    raise HeaderError(f"{where}: malformed #include {rest}")
                self.run(self.find(mm.group(1), os.path.dirname(path)))
            elif d == "error":
                raise HeaderError(f"{where}: #error {rest}")
            elif d in ("pragma", "line", ""):
                continue
            else:
                raise HeaderError(f"{where}: unsupported directive #{d}")
        if stack:
            raise HeaderError(f"{path}: unterminated #if")
        self.files.pop()


def preprocess(header: str, include_path: Sequence[str],
               predefined: Optional[Dict[str, str]] = None) -> Tuple[str, Dict[str, str]]:
    """Preprocesses `header` (a path; a bare name is searched in `include_path`).

    Returns the declarations as text and the object-like macros defined at the end (name to
    replacement text). `predefined` macros are defined first; none are by default, so code
    under ``__cplusplus``, ``_WIN32`` or ``__GNUC__`` is left out and attribute macros such as
    ``DEFSIM_API`` take their empty fallback. Raises HeaderError.
    """
    st = _State(include_path, predefined or {})
    path = header if os.path.isfile(header) else st.find(header, None)
    st.run(path)
    return "\n".join(st.out) + "\n", st.macros
