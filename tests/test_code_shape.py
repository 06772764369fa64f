"""The shape the architecture promises (docs/architecture.md): short functions in the product
packages and compiled kernels that take named bundles, not long positional argument lists."""

from __future__ import annotations

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("beamsim", "analysis")
MAX_LINES = 120  # whole function, docstring included
MAX_KERNEL_PARAMS = 12


def _functions():
    for pkg in PACKAGES:
        for f in sorted((ROOT / pkg).rglob("*.py")):
            for node in ast.walk(ast.parse(f.read_text())):
                if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                    yield f.relative_to(ROOT), node


def _is_kernel(node) -> bool:
    return any("njit" in ast.unparse(d) or "jit(" in ast.unparse(d) for d in node.decorator_list)


def test_no_long_function():
    long = [f"{f}:{n.lineno} {n.name} ({n.end_lineno - n.lineno + 1} lines)" for f, n in _functions()
            if n.end_lineno - n.lineno + 1 > MAX_LINES]
    assert not long, long


def test_kernels_take_bundles():
    wide = []
    for f, n in _functions():
        a = n.args
        count = len(a.posonlyargs) + len(a.args) + len(a.kwonlyargs)
        if _is_kernel(n) and count > MAX_KERNEL_PARAMS:
            wide.append(f"{f}:{n.lineno} {n.name} ({count} parameters)")
    assert not wide, wide


def test_the_checks_see_the_kernels():
    """Guard against a vacuous pass: the walk finds the compiled kernels of both packages."""
    kernels = {str(f).split("/")[0] for f, n in _functions() if _is_kernel(n)}
    assert kernels == set(PACKAGES)
