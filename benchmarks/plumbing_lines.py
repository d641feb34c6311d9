"""How much of the package is plumbing: lines of code per layer, and the guard lines in each (an
``if`` whose body only raises or warns, with its condition and message), so that a refactoring can
say by how much the plumbing fell.

Usage::

    python benchmarks/plumbing_lines.py [--root .] [--rev REV]

``--rev`` measures a git revision instead of the work tree (``git show REV:path`` for each file),
so that one run prints the table before and after: ``python benchmarks/plumbing_lines.py --rev
HEAD~10`` beside ``python benchmarks/plumbing_lines.py``. Lines of code exclude blank lines,
comments and docstrings.
"""

from __future__ import annotations

import argparse
import ast
import io
import os
import subprocess
import tokenize

LAYERS = ("base", "core", "identification", "analysis", "cli", "report", "convert", "datasets", "export")


def _code_lines(source) -> set:
    """The line numbers that hold code: not blank, not only a comment, not a docstring."""
    lines = set()
    for tok in tokenize.generate_tokens(io.StringIO(source).readline):
        if tok.type not in (tokenize.COMMENT, tokenize.NL, tokenize.NEWLINE, tokenize.INDENT, tokenize.DEDENT,
                            tokenize.ENDMARKER):
            lines.update(range(tok.start[0], tok.end[0] + 1))
    tree = ast.parse(source)
    for node in ast.walk(tree):
        if isinstance(node, (ast.Module, ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef)) and node.body:
            first = node.body[0]
            if isinstance(first, ast.Expr) and isinstance(first.value, ast.Constant) and isinstance(first.value.value, str):
                lines.difference_update(range(first.lineno, first.end_lineno + 1))
    return lines


def _is_guard(node) -> bool:
    """An ``if`` (without ``else``) whose body only raises, warns or does both."""
    if not isinstance(node, ast.If) or node.orelse:
        return False
    for stmt in node.body:
        if isinstance(stmt, ast.Raise):
            continue
        if isinstance(stmt, ast.Expr) and isinstance(stmt.value, ast.Call):
            func = stmt.value.func
            name = func.attr if isinstance(func, ast.Attribute) else getattr(func, "id", "")
            if "warn" in name:
                continue
        return False
    return True


def measure(source) -> tuple:
    """(lines of code, guard lines) of one module's source."""
    code = _code_lines(source)
    guards = set()
    for node in ast.walk(ast.parse(source)):
        if _is_guard(node):
            guards.update(range(node.lineno, node.end_lineno + 1))
    return len(code), len(guards & code)


def _files(root, rev):
    if rev:
        names = subprocess.run(["git", "-C", root, "ls-tree", "-r", "--name-only", rev, "granalytics"],
                               capture_output=True, text=True, check=True).stdout.split()
        for name in names:
            if name.endswith(".py"):
                yield name, subprocess.run(["git", "-C", root, "show", f"{rev}:{name}"], capture_output=True,
                                           text=True, check=True).stdout
        return
    for folder, _, files in os.walk(os.path.join(root, "granalytics")):
        for name in files:
            if name.endswith(".py"):
                path = os.path.join(folder, name)
                with open(path) as f:
                    yield os.path.relpath(path, root), f.read()


def _layer(name) -> str:
    parts = name.split("/")
    if len(parts) > 2 and parts[1] in LAYERS:
        return parts[1]
    stem = parts[-1][:-3]
    return {"plot": "report", "outputs": "report"}.get(stem, "top level")


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--root", default=".")
    parser.add_argument("--rev", default=None)
    args = parser.parse_args(argv)
    table = {}
    for name, source in _files(args.root, args.rev):
        code, guards = measure(source)
        row = table.setdefault(_layer(name), [0, 0, 0])
        row[0] += 1
        row[1] += code
        row[2] += guards
    print(f"\n### granalytics at {args.rev or 'the work tree'}: lines of code (no blanks, comments, docstrings)\n")
    print("| layer | modules | code lines | guard lines | guards % |")
    print("| --- | --- | --- | --- | --- |")
    total = [0, 0, 0]
    for layer in sorted(table, key=lambda k: (-table[k][1], k)):
        n, code, guards = table[layer]
        total = [a + b for a, b in zip(total, (n, code, guards))]
        print(f"| {layer} | {n} | {code} | {guards} | {100 * guards / max(code, 1):.0f} |")
    print(f"| all | {total[0]} | {total[1]} | {total[2]} | {100 * total[2] / max(total[1], 1):.0f} |")


if __name__ == "__main__":
    main()
