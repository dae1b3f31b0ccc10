"""The package's structure (docs/architecture.md): its modules import each other without a
cycle, none reaches into another's private (underscore) names, every import goes to the same
layer of the page's diagram or a lower one, and the page names every module. Imports are read
from the source with ``ast``, those inside functions included (a lazy import still ties the two
modules), and so are the lazy names a sub-package's ``__init__.py`` lists in ``_EXPORTS`` (name
-> its submodule, loaded through importlib on first use); those of ``lidar_sig/__init__.py`` are
not imports (a module may take ``__version__`` from it)."""
import ast
import re

from conftest import ROOT

PACKAGE = ROOT / "lidar_sig"
PAGE = ROOT / "docs" / "architecture.md"


def _module_name(path):
    parts = path.relative_to(ROOT).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


# module name -> source file; a package's __init__ is a module of its own (named like the package)
MODULES = {_module_name(p): p for p in sorted(PACKAGE.rglob("*.py"))}


def _is_package(name):
    return MODULES[name].name == "__init__.py"


def _base(module, node):
    """The absolute module name an ``ImportFrom`` node imports from."""
    if node.level == 0:
        return node.module
    package = module if _is_package(module) else module.rpartition(".")[0]
    for _ in range(node.level - 1):
        package = package.rpartition(".")[0]
    return f"{package}.{node.module}" if node.module else package


def imports(module):
    """``(target, name, bound)`` for every import of a package module in ``module``: ``name`` is
    the name taken from ``target`` (None when the import names the module itself) and ``bound``
    the name it gets in ``module`` (None unless it is bound to a module)."""
    tree = ast.parse(MODULES[module].read_text(encoding="utf-8"))
    if _is_package(module) and module != "lidar_sig":
        for name, sub in _lazy_names(tree).items():
            yield f"{module}.{sub}", name, None
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for alias in node.names:
                if alias.name in MODULES:
                    yield alias.name, None, alias.asname
        elif isinstance(node, ast.ImportFrom):
            base = _base(module, node)
            if base not in MODULES:
                continue
            for alias in node.names:
                sub = f"{base}.{alias.name}"
                if sub in MODULES:  # a submodule: ``from . import page``
                    yield sub, None, alias.asname or alias.name
                else:
                    yield base, alias.name, None


def _lazy_names(tree):
    """name -> submodule of a package's ``_EXPORTS = {...}`` (its names loaded on first use)."""
    for node in tree.body:
        if (isinstance(node, ast.Assign) and isinstance(node.value, ast.Dict)
                and any(isinstance(t, ast.Name) and t.id == "_EXPORTS" for t in node.targets)):
            return {k.value: v.value for k, v in zip(node.value.keys, node.value.values)}
    return {}


def graph():
    """module -> set of the package modules it imports (itself left out)."""
    return {m: {t for t, _, _ in imports(m) if t != m} for m in MODULES}


def find_cycle(edges):
    """A list of modules that import each other in a circle (the first again at the end), or None."""
    state = {}  # module -> "open" while on the path, "done" once every path from it is explored
    path = []

    def visit(m):
        state[m] = "open"
        path.append(m)
        for t in sorted(edges[m]):
            if state.get(t) == "open":
                return path[path.index(t):] + [t]
            if t not in state:
                found = visit(t)
                if found:
                    return found
        state[m] = "done"
        path.pop()
        return None

    for m in sorted(edges):
        if m not in state:
            found = visit(m)
            if found:
                return found
    return None


def _private(name):
    return name.startswith("_") and not (name.startswith("__") and name.endswith("__"))


def test_the_walk_finds_the_package_and_its_imports():
    # the test can fail only if it sees the package: its modules and some lazy imports among them
    assert {"lidar_sig", "lidar_sig.pipeline.flow", "lidar_sig.io", "lidar_sig.cli"} <= set(MODULES)
    edges = graph()
    assert "lidar_sig.method.signature_raster" in edges["lidar_sig.pipeline.flow"]
    assert "lidar_sig.io" in edges["lidar_sig.pipeline.flow"]  # a lazy import, inside a function
    assert "lidar_sig.io.archive" in edges["lidar_sig.io"]  # a lazy name of the package (_EXPORTS)
    assert all(t in MODULES for m in MODULES for t in edges[m])
    assert find_cycle({"a": {"b"}, "b": {"c"}, "c": {"a"}}) == ["a", "b", "c", "a"]
    assert find_cycle({"a": {"b"}, "b": set()}) is None


def test_no_import_cycle():
    cycle = find_cycle(graph())
    assert cycle is None, "modules import each other in a circle: " + " -> ".join(cycle)


def test_no_module_takes_another_modules_private_names():
    found = []
    for module in MODULES:
        bound = {}
        for target, name, as_name in imports(module):
            if target != module and name is not None and _private(name):
                found.append(f"{module} imports {name} from {target}")
            if name is None and as_name:
                bound[as_name] = target
        tree = ast.parse(MODULES[module].read_text(encoding="utf-8"))
        for node in ast.walk(tree):  # page._esc, where page is a module of the package
            if (isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name)
                    and node.value.id in bound and bound[node.value.id] != module and _private(node.attr)):
                found.append(f"{module} uses {node.value.id}.{node.attr} of {bound[node.value.id]}")
    assert not found, "\n".join(found)


def test_the_architecture_page_names_every_module():
    # the table's first column names each module by its path in lidar_sig/
    listed = set()
    for line in PAGE.read_text(encoding="utf-8").splitlines():
        if line.startswith("|"):
            listed |= set(re.findall(r"`([\w/]+\.py)`", line.split("|")[1]))
    files = {str(p.relative_to(PACKAGE)) for p in MODULES.values()}
    assert not files - listed, f"docs/architecture.md does not name {sorted(files - listed)}"
    assert not listed - files, f"docs/architecture.md names modules that do not exist: {sorted(listed - files)}"


def layers():
    """The layers of the page's diagram, top first: sets of top-level names (``cli``, ``io``,
    ``pipeline``, ...). A line lists names, then says what they do; a line starting with ``|``
    separates two layers."""
    text = PAGE.read_text(encoding="utf-8")
    diagram = text.split("```\n", 2)[1]
    tops = {m.split(".")[1] for m in MODULES if "." in m}
    out = [set()]
    for line in diagram.splitlines():
        words = line.split()
        if words and words[0] == "|":
            out.append(set())
            continue
        for word in words:
            if word == "->":
                continue
            if word.rstrip("/") not in tops:
                break
            out[-1].add(word.rstrip("/"))
    return [layer for layer in out if layer]


def test_every_import_goes_to_the_same_layer_or_below():
    found = layers()
    level = {name: i for i, layer in enumerate(found) for name in layer}
    tops = {m.split(".")[1] for m in MODULES if "." in m}
    assert set(level) == tops and sum(map(len, found)) == len(tops), "each module in one layer of the diagram"
    up = [f"{m} -> {t}" for m, targets in graph().items() for t in targets
          if t != "lidar_sig" and m != "lidar_sig" and level[t.split(".")[1]] < level[m.split(".")[1]]]
    assert not up, "imports of a higher layer: " + ", ".join(up)


#: What only the library decides: one block or tiles, sets of tiles, work folders, where tiles run.
DECIDING = {"over_budget", "points_over_budget", "tiles_asked", "is_set", "run_set", "run_in_tiles", "executor",
            "prepare_work", "remove_work", "discard_work", "work_folder", "mkdir", "rmdir", "rmtree", "unlink"}


def test_the_command_line_decides_no_block_or_tiles_and_handles_no_work_folder():
    # the command line builds an Execution from its options and calls one job, which decides
    found = []
    for module, path in MODULES.items():
        if not module.startswith("lidar_sig.cli"):
            continue
        for target, name, _ in imports(module):
            if target.startswith("lidar_sig.tiling") and target != "lidar_sig.tiling.execution":
                found.append(f"{module} imports {name or target} from {target}")
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            used = node.attr if isinstance(node, ast.Attribute) else node.id if isinstance(node, ast.Name) else None
            if used in DECIDING:
                found.append(f"{module} uses {used} (line {node.lineno})")
    assert not found, "\n".join(found)


def test_no_module_decides_by_comparing_a_metric_or_plugin_name_to_a_text():
    # a fact about a metric (direction, needs labels, screening) or a descriptor or strategy
    # (kernels, tiles, chooses a scale) lives on that object: no `key == "ssim"`, no
    # `name in ("kl", "l1")`, no `strategy.name == "optimal"`, no `out["bhattacharyya"] = ...`
    from lidar_sig.metrics import METRIC_KEYS
    from lidar_sig.plugins import available

    names = set(METRIC_KEYS) | set(available("descriptor")) | set(available("strategy"))

    def texts(node):
        if isinstance(node, ast.Constant) and isinstance(node.value, str):
            return {node.value}
        if isinstance(node, (ast.Tuple, ast.List, ast.Set)):
            return set().union(*(texts(e) for e in node.elts)) if node.elts else set()
        return set()

    found = []
    for module, path in MODULES.items():
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.Compare):
                named = set().union(*(texts(c) for c in [node.left, *node.comparators])) & names
                if named:
                    found.append(f"{module}, line {node.lineno}: compares to {sorted(named)}")
            elif (isinstance(node, ast.Subscript) and texts(node.slice) & names
                  and getattr(node.value, "id", None) != "columns"):  # an archive's columns (docs/archive.md)
                found.append(f"{module}, line {node.lineno}: looks up {sorted(texts(node.slice) & names)}")
    assert not found, "\n".join(found)
