"""Architecture rules of the package, checked on the source text (AST) and, for import cost, in a subprocess.

Rules (house rules of the project):

(a) the import graph of ``plant``, ``adaptive_ff`` and ``controllers`` (module-level and function-level
    imports alike) has no cycles;
(b) layering: ``plant`` imports nothing of ``adaptive_ff``/``controllers``, ``adaptive_ff`` nothing of
    ``controllers``;
(c) no module imports another module's private name (``from x import _y``, or ``m._y`` on an imported
    module ``m``);
(d) no function or method longer than 100 lines, its docstring not counted;
(e) no public function or method (no leading underscore, in a public module) with more than 12 parameters,
    ``self``/``cls`` not counted;
(f) ``import plant, adaptive_ff, controllers`` and ``adaptive-ff --help`` import none of python-control,
    ``scipy.signal`` and matplotlib (they cost about a second; commands import them when they use them).

``ALLOWED`` lists the violations that exist today outside the files of the author of this test, each with its
owner. The test fails for a violation that is not on the list *and* for a list entry that no longer occurs, so
the list can only shrink; it is meant to end empty.
"""

from __future__ import annotations

import ast
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
PACKAGES = ("plant", "adaptive_ff", "controllers")
MAX_LINES = 100
MAX_PARAMS = 12
HEAVY = ("control", "scipy.signal", "matplotlib")

#: Today's violations in files other people are changing right now: (rule, "file:function") -> owner / reason.
#: Rules: "cycle" (key: the modules of one strongly connected component, joined by " <-> "),
#: "layering" / "private" (key: "file:imported name"), "length" / "params" (key: "file:qualified name").
#: Remove an entry when its violation is fixed (the test says which entries are stale).
ALLOWED: dict[tuple[str, str], str] = {
}


# ---------------------------------------------------------------------------------------------------- source model
def _module_name(path: Path) -> str:
    parts = list(path.relative_to(ROOT).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def _sources() -> dict[str, tuple[str, ast.Module]]:
    """``{module name: (path relative to the root, parsed AST)}`` of every module of the three packages."""
    out = {}
    for pkg in PACKAGES:
        for f in sorted((ROOT / pkg).rglob("*.py")):
            out[_module_name(f)] = (f.relative_to(ROOT).as_posix(), ast.parse(f.read_text(), filename=str(f)))
    return out


SOURCES = _sources()
MODULES = frozenset(SOURCES)


def _is_package(mod: str) -> bool:
    return SOURCES[mod][0].endswith("__init__.py")


def _resolve_from(mod: str, node: ast.ImportFrom) -> str | None:
    """Absolute module name of ``from <module> import ...`` (relative imports resolved)."""
    if not node.level:
        return node.module
    base = mod.split(".") if _is_package(mod) else mod.split(".")[:-1]
    base = base[: len(base) - (node.level - 1)]
    return ".".join(base + ([node.module] if node.module else []))


def _in_package(name: str | None) -> bool:
    return name is not None and name.split(".")[0] in PACKAGES


def _imports(mod: str) -> list[tuple[str, str | None, int]]:
    """Every import in ``mod`` at any depth: ``(imported module, imported name or None, line)``.

    ``from a.b import c`` gives ``("a.b.c", None)`` when ``a.b.c`` is a module of the packages, else
    ``("a.b", "c")``.
    """
    out = []
    for node in ast.walk(SOURCES[mod][1]):
        if isinstance(node, ast.Import):
            out += [(a.name, None, node.lineno) for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            src = _resolve_from(mod, node)
            if src == "__future__":
                continue
            for a in node.names:
                sub = f"{src}.{a.name}"
                out.append((sub, None, node.lineno) if sub in MODULES else (src, a.name, node.lineno))
    return out


def _graph() -> dict[str, set[str]]:
    """Import graph between modules of the packages (module-level and function-level imports)."""
    g = {m: set() for m in MODULES}
    for m in MODULES:
        for target, _, _ in _imports(m):
            if target in MODULES and target != m:
                g[m].add(target)
    return g


def _cycles(g: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components with more than one module (Tarjan's algorithm, iterative)."""
    index, low, on_stack, stack, out = {}, {}, set(), [], []
    counter = 0
    for root in sorted(g):
        if root in index:
            continue
        work = [(root, iter(sorted(g[root])))]
        index[root] = low[root] = counter
        counter += 1
        stack.append(root)
        on_stack.add(root)
        while work:
            v, it = work[-1]
            for w in it:
                if w not in index:
                    index[w] = low[w] = counter
                    counter += 1
                    stack.append(w)
                    on_stack.add(w)
                    work.append((w, iter(sorted(g[w]))))
                    break
                if w in on_stack:
                    low[v] = min(low[v], index[w])
            else:
                work.pop()
                if work:
                    low[work[-1][0]] = min(low[work[-1][0]], low[v])
                if low[v] == index[v]:
                    comp = []
                    while True:
                        w = stack.pop()
                        on_stack.discard(w)
                        comp.append(w)
                        if w == v:
                            break
                    if len(comp) > 1:
                        out.append(sorted(comp))
    return out


def _functions(tree: ast.Module):
    """``(qualified name, node, nested in a function)`` of every function and method, at any depth."""
    def visit(node, prefix, in_function):
        for child in ast.iter_child_nodes(node):
            if isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef)):
                q = f"{prefix}{child.name}"
                yield q, child, in_function
                yield from visit(child, q + ".", True)
            elif isinstance(child, ast.ClassDef):
                yield from visit(child, f"{prefix}{child.name}.", in_function)
            else:
                yield from visit(child, prefix, in_function)

    yield from visit(tree, "", False)


def _body_lines(fn: ast.FunctionDef) -> int:
    """Lines from ``def`` to the end of the function, its docstring not counted (decorators not counted)."""
    n = fn.end_lineno - fn.lineno + 1
    first = fn.body[0]
    if isinstance(first, ast.Expr) and isinstance(first.value, ast.Constant) and isinstance(first.value.value, str):
        n -= first.end_lineno - first.lineno + 1
    return n


def _n_params(fn: ast.FunctionDef, is_method: bool) -> int:
    a = fn.args
    names = [x.arg for x in (*a.posonlyargs, *a.args)]
    n = len(names) + len(a.kwonlyargs) + (a.vararg is not None) + (a.kwarg is not None)
    static = any(isinstance(d, ast.Name) and d.id == "staticmethod" for d in fn.decorator_list)
    if is_method and not static and names and names[0] in ("self", "cls"):
        n -= 1
    return n


def _public_module(mod: str) -> bool:
    return not any(part.startswith("_") for part in mod.split("."))


# ---------------------------------------------------------------------------------------------------- violations
def _violations_cycle() -> set[str]:
    return {" <-> ".join(c) for c in _cycles(_graph())}


def _violations_layering() -> set[str]:
    rank = {"plant": 0, "adaptive_ff": 1, "controllers": 2}
    out = set()
    for m in MODULES:
        for target, name, _ in _imports(m):
            if _in_package(target) and rank[target.split(".")[0]] > rank[m.split(".")[0]]:
                out.add(f"{SOURCES[m][0]}:{target}" + (f".{name}" if name else ""))
    return out


def _module_aliases(mod: str) -> dict[str, str]:
    """Names bound to package modules in ``mod`` by ``import a.b as m``, ``import a.b`` or ``from a import b``."""
    out = {}
    for node in ast.walk(SOURCES[mod][1]):
        if isinstance(node, ast.Import):
            for a in node.names:
                if _in_package(a.name):
                    out[a.asname or a.name] = a.name  # "a.b" for "import a.b": matched as a dotted attribute chain
        elif isinstance(node, ast.ImportFrom):
            src = _resolve_from(mod, node)
            for a in node.names:
                if f"{src}.{a.name}" in MODULES:
                    out[a.asname or a.name] = f"{src}.{a.name}"
    return out


def _dotted(node: ast.AST) -> str | None:
    parts = []
    while isinstance(node, ast.Attribute):
        parts.append(node.attr)
        node = node.value
    if not isinstance(node, ast.Name):
        return None
    return ".".join([node.id, *reversed(parts)])


def _private(name: str) -> bool:
    return name.startswith("_") and not (name.startswith("__") and name.endswith("__"))


def _violations_private() -> set[str]:
    out = set()
    for m in MODULES:
        path = SOURCES[m][0]
        for target, name, _ in _imports(m):
            if _in_package(target) and target != m:
                if name is not None and _private(name):
                    out.add(f"{path}:{target}.{name}")
                elif name is None and _private(target.rsplit(".", 1)[-1]) and not _is_package(m):
                    pass  # importing a private *module* (e.g. plant._mapping) is how a package shares its helpers
        aliases = _module_aliases(m)
        for node in ast.walk(SOURCES[m][1]):
            if isinstance(node, ast.Attribute) and _private(node.attr):
                base = _dotted(node.value)
                if base is None:
                    continue
                head = base.split(".")[0]
                if head in aliases:
                    full = aliases[head] + base[len(head):]
                    if full in MODULES and full != m:
                        out.add(f"{path}:{full}.{node.attr}")
    return out


def _violations_length() -> set[str]:
    out = set()
    for m, (path, tree) in SOURCES.items():
        for q, fn, _ in _functions(tree):
            if _body_lines(fn) > MAX_LINES:
                out.add(f"{path}:{q}")
    return out


def _violations_params() -> set[str]:
    out = set()
    for m, (path, tree) in SOURCES.items():
        if not _public_module(m):
            continue
        for q, fn, nested in _functions(tree):
            if nested or any(part.startswith("_") for part in q.split(".")):
                continue
            if _n_params(fn, is_method="." in q) > MAX_PARAMS:
                out.add(f"{path}:{q}")
    return out


RULES = {
    "cycle": _violations_cycle,
    "layering": _violations_layering,
    "private": _violations_private,
    "length": _violations_length,
    "params": _violations_params,
}


@pytest.mark.parametrize("rule", list(RULES))
def test_rule(rule):
    found = RULES[rule]()
    allowed = {key for (r, key) in ALLOWED if r == rule}
    new = sorted(found - allowed)
    stale = sorted(allowed - found)
    msg = []
    if new:
        msg.append(f"{rule}: new violations (fix them; do not add them to ALLOWED):\n  " + "\n  ".join(new))
    if stale:
        msg.append(f"{rule}: fixed, remove from ALLOWED in {Path(__file__).name}:\n  " + "\n  ".join(stale))
    assert not msg, "\n".join(msg)


def test_allowlist_names_known_rules_and_owners():
    for (rule, key), why in ALLOWED.items():
        assert rule in RULES, (rule, key)
        assert isinstance(why, str) and why.strip(), (rule, key)


# ---------------------------------------------------------------------------------------------------- self-tests
def test_checkers_on_known_snippets(monkeypatch):
    """The AST helpers count what the rules say (guards the checkers themselves)."""
    tree = ast.parse(textwrap.dedent('''
        def f(a, b, /, c, *args, d, e=1, **kw):
            """Doc
            string."""
            x = 1
            return x

        class K:
            def m(self, a):
                def inner(b):
                    return b
                return inner(a)

            @staticmethod
            def s(self, a):
                return a
    '''))
    fns = {q: (fn, nested) for q, fn, nested in _functions(tree)}
    assert set(fns) == {"f", "K.m", "K.m.inner", "K.s"}
    assert fns["K.m.inner"][1] and not fns["K.m"][1]
    assert _body_lines(fns["f"][0]) == 3  # def + two statements; the docstring is not counted
    assert _n_params(fns["f"][0], is_method=False) == 7
    assert _n_params(fns["K.m"][0], is_method=True) == 1
    assert _n_params(fns["K.s"][0], is_method=True) == 2  # a staticmethod's "self" is a parameter
    assert _cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c"]]
    assert _cycles({"a": {"b"}, "b": set()}) == []


# ---------------------------------------------------------------------------------------------------- import cost
_PROBE = textwrap.dedent("""
    import sys
    import plant, adaptive_ff, controllers
    heavy = {heavy!r}
    def loaded():
        return sorted(m for m in heavy if m in sys.modules)
    print("import", loaded())
    from controllers.cli import main
    try:
        main(["--help"])
    except SystemExit:
        pass
    print("help", loaded())
    print("kernels", sorted(m for m in ("plant._cplant", "adaptive_ff._caff", "controllers._cctl") if m in sys.modules))
""")


def test_import_and_help_do_not_load_heavy_modules():
    env = {**os.environ, "MPLBACKEND": "Agg"}
    r = subprocess.run([sys.executable, "-c", _PROBE.format(heavy=HEAVY)], cwd=ROOT, env=env,
                       capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    lines = {ln.split(" ", 1)[0]: ln.split(" ", 1)[1] for ln in r.stdout.splitlines()
             if ln.split(" ", 1)[0] in ("import", "help", "kernels")}
    assert lines["import"] == "[]", f"import plant, adaptive_ff, controllers loads {lines['import']}"
    assert lines["help"] == "[]", f"adaptive-ff --help loads {lines['help']}"
    assert lines["kernels"] == "[]", f"adaptive-ff --help loads the C core ({lines['kernels']})"

