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


def test_a_private_module_is_imported_only_inside_its_own_package():
    # scikit-image's convention: a leading underscore marks a module as the package's own
    # (``change_map/_lod.py``); other packages take its names from the package's public modules
    found = []
    for module, targets in graph().items():
        for target in targets:
            leaf = target.rpartition(".")[2]
            owner = target.rpartition(".")[0]
            if leaf.startswith("_") and not leaf.startswith("__") and not (module == owner
                                                                           or module.startswith(owner + ".")):
                found.append(f"{module} imports {target}")
    assert not found, "\n".join(found)


def test_no_two_modules_share_a_name_but_a_command_and_its_job():
    # a reader never meets two `result.py`: a name (its leading underscore aside) is one module's,
    # except a command of cli/ and the job of jobs/ it asks for (and an old path kept for user code)
    by_name = {}
    for module in MODULES:
        if module == "lidar_sig" or module in DEPRECATED_PATHS:
            continue
        by_name.setdefault(module.rpartition(".")[2].lstrip("_"), []).append(module)
    shared = {name: found for name, found in by_name.items()
              if len(found) > 1 and name != "" and not (
                  sorted(m.rpartition(".")[0] for m in found) == ["lidar_sig.cli", "lidar_sig.jobs"])}
    shared.pop("init", None)
    assert not shared, shared


#: Old public module paths kept for user code, each with a DeprecationWarning: the module it
#: moved to. Such a module stands in its target's layer and imports nothing but its target.
DEPRECATED_PATHS = {"lidar_sig.errors": "lidar_sig.base.errors"}


def _top(module):
    """The top-level name of ``module`` whose layer it is in (a deprecated path: its target's)."""
    return DEPRECATED_PATHS.get(module, module).split(".")[1]


def test_the_root_holds_the_public_entry_the_command_entry_and_subpackages():
    root = sorted(p.name for p in PACKAGE.glob("*.py"))
    kept = sorted(m.split(".")[1] + ".py" for m in DEPRECATED_PATHS)
    assert root == sorted(["__init__.py", "__main__.py", *kept]), root


def test_a_deprecated_module_path_imports_only_its_new_module_and_warns():
    for old, new in DEPRECATED_PATHS.items():
        assert graph()[old] == {new}, old
        assert "DeprecationWarning" in MODULES[old].read_text(encoding="utf-8"), old


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
    ``pipeline``, ...). A line lists names, then says what they do; a ``|`` among the names (or
    alone, or before a line's words) separates two layers, wherever it stands."""
    text = PAGE.read_text(encoding="utf-8")
    diagram = text.split("```\n", 2)[1]
    tops = {_top(m) for m in MODULES if "." in m}
    out = [set()]
    for line in diagram.splitlines():
        for word in line.split():
            if word == "|":
                if out[-1]:
                    out.append(set())
            elif word == "->":
                continue
            elif word.rstrip("/") in tops:
                out[-1].add(word.rstrip("/"))
            else:
                break
    return [layer for layer in out if layer]


def test_the_layers_are_read_as_the_page_draws_them():
    # a separator at the end of a line of names splits the layer there, as one on a line of its own
    found = layers()
    assert len(found) >= 7
    index = {name: i for i, layer in enumerate(found) for name in layer}
    assert index["cli"] < index["jobs"] < index["change_map"] < index["pipeline"] < index["tiling"] < index["io"]
    assert index["reporting"] < index["io"] < index["method"]  # io writes a signature's picture: no arrow up
    assert index["method"] < index["numerics"] < index["base"]


def test_every_import_goes_to_the_same_layer_or_below():
    found = layers()
    level = {name: i for i, layer in enumerate(found) for name in layer}
    tops = {_top(m) for m in MODULES if "." in m}
    assert set(level) == tops and sum(map(len, found)) == len(tops), "each module in one layer of the diagram"
    up = [f"{m} -> {t}" for m, targets in graph().items() for t in targets
          if t != "lidar_sig" and m != "lidar_sig" and level[_top(t)] < level[_top(m)]]
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


def _texts(node):
    """The str constants ``node`` is, or holds as a tuple, list or set."""
    if isinstance(node, ast.Constant) and isinstance(node.value, str):
        return {node.value}
    if isinstance(node, (ast.Tuple, ast.List, ast.Set)):
        return set().union(*(_texts(e) for e in node.elts)) if node.elts else set()
    return set()


def test_no_module_decides_by_comparing_a_metric_or_plugin_name_to_a_text():
    # a fact about a metric (direction, needs labels, screening) or a descriptor or strategy
    # (kernels, tiles, chooses a scale) lives on that object: no `key == "ssim"`, no
    # `name in ("kl", "l1")`, no `strategy.name == "optimal"`, no `out["bhattacharyya"] = ...`
    from lidar_sig.metrics import METRIC_KEYS
    from lidar_sig.plugins import available

    names = set(METRIC_KEYS) | set(available("descriptor")) | set(available("strategy"))
    found = []
    for module, path in MODULES.items():
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.Compare):
                named = set().union(*(_texts(c) for c in [node.left, *node.comparators])) & names
                if named:
                    found.append(f"{module}, line {node.lineno}: compares to {sorted(named)}")
            elif (isinstance(node, ast.Subscript) and _texts(node.slice) & names
                  and getattr(node.value, "id", None) != "columns"):  # an archive's columns (docs/archive.md)
                found.append(f"{module}, line {node.lineno}: looks up {sorted(_texts(node.slice) & names)}")
    assert not found, "\n".join(found)


#: The texts of the kinds of scales and of the area weights (lidar_sig.method.scales.ScaleKind,
#: lidar_sig.numerics.neighbors.Weights): only method/scales.py, where Scales are made from them,
#: may compare anything to them; elsewhere the objects say (``scales.by_count``,
#: ``pipeline.weights.by_area``, ``recorded_kind(metadata)``).
KIND_TEXTS = {"knn", "radius", "area"}


def kind_text_decisions(source):
    """``(line, text)`` of each comparison in ``source`` that decides a scale kind or the weights by
    a text: a text of :data:`KIND_TEXTS`, or any text compared with something named ``weights``,
    ``scale_kind`` or ``scale_units``."""
    found = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Compare):
            operands = [node.left, *node.comparators]
            said = set().union(*(_texts(o) for o in operands))
            about = any(not _texts(o) and re.search(r"\b(weights|scale_kind|scale_units)\b", ast.unparse(o))
                        for o in operands)
            if said & KIND_TEXTS or (said and about):
                found.append((node.lineno, ast.unparse(node)))
    return found


def test_the_check_of_kind_texts_sees_what_it_refuses():
    assert [t for _, t in kind_text_decisions('if m.get("scale_kind") == "knn": pass')] == [
        "m.get('scale_kind') == 'knn'"]
    assert kind_text_decisions("x = pipeline.weights == 'none'")
    assert kind_text_decisions("x = kind in ('radius', 'other')")
    assert not kind_text_decisions("x = scales.by_count and pipeline.weights.by_area or 'scale_kind' in m")


def test_no_module_decides_a_scale_kind_or_the_weights_by_comparing_a_text():
    found = [f"{module}, line {line}: {text}" for module, path in MODULES.items()
             if module != "lidar_sig.method.scales"
             for line, text in kind_text_decisions(path.read_text(encoding="utf-8"))]
    assert not found, "\n".join(found)


def test_no_module_lists_metric_keys_or_counts_the_metrics_by_hand():
    # the metrics are those registered (lidar_sig.metrics.METRICS, from the entry-point group
    # lidar_sig.metrics): a table of some of them, or "the seven metrics", goes stale when one is added
    from lidar_sig.metrics import METRIC_KEYS

    keys = set(METRIC_KEYS)
    found = []
    for module, path in MODULES.items():
        tree = ast.parse(path.read_text(encoding="utf-8"))
        exported = {id(n.value) for n in tree.body if isinstance(n, ast.Assign)
                    and any(getattr(t, "id", None) == "__all__" for t in n.targets)}  # names of functions
        for node in ast.walk(tree):
            if id(node) in exported:
                continue
            listed = (_texts(node) if isinstance(node, (ast.Tuple, ast.List, ast.Set))
                      else {k.value for k in node.keys if isinstance(k, ast.Constant)} if isinstance(node, ast.Dict)
                      else set())
            if len(listed & keys) >= 2:
                found.append(f"{module}, line {node.lineno}: lists {sorted(listed & keys)}")
    words = r"(two|three|four|five|six|seven|eight|nine)"
    counted = re.compile(rf"\b(({words}|\d+) (semantic |image |screening )?metrics|all {words})\b", re.IGNORECASE)
    for path in [*MODULES.values(), *sorted((ROOT / "qgis").rglob("*.py"))]:
        for number, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
            if counted.search(line) and "metric" in line.lower():
                found.append(f"{path.relative_to(ROOT)}, line {number}: {line.strip()}")
    assert not found, "\n".join(found)


#: Longest function, in lines from its ``def`` to its end (docstring and comments included).
LONGEST = 80
#: Functions being rewritten, still longer than LONGEST (none: the change map at survey scale
#: split the last two).
LONG_FUNCTIONS_BEING_REWRITTEN: set[str] = set()


def long_functions(source):
    """``(name, lines, kernel_says_why)`` of each function of ``source`` longer than LONGEST:
    ``kernel_says_why`` when it is compiled by numba (``@njit``) and a comment just above it says
    why it stays long (``# ... stays long ...``)."""
    lines = source.splitlines()
    found = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)) and node.end_lineno - node.lineno + 1 > LONGEST:
            first = min([node.lineno, *(d.lineno for d in node.decorator_list)])
            above = []
            for line in reversed(lines[:first - 1]):
                if not line.lstrip().startswith("#"):
                    break
                above.append(line)
            compiled = any("njit" in ast.unparse(d) or "numba" in ast.unparse(d) for d in node.decorator_list)
            found.append((node.name, node.end_lineno - node.lineno + 1,
                          compiled and "stays long" in " ".join(above)))
    return found


def test_the_count_of_long_functions_sees_what_it_refuses():
    body = "\n".join(f"    x{i} = {i}" for i in range(LONGEST))
    assert long_functions(f"def f():\n{body}\n") == [("f", LONGEST + 1, False)]
    assert long_functions(f"@njit(cache=True)\ndef f():\n{body}\n") == [("f", LONGEST + 1, False)]
    said = f"# one loop: it stays long, as splitting it costs speed\n@njit(cache=True)\ndef f():\n{body}\n"
    assert long_functions(said) == [("f", LONGEST + 1, True)]
    assert long_functions(f"# it stays long\ndef f():\n{body}\n") == [("f", LONGEST + 1, False)]  # not numba
    assert not long_functions(f"def f():\n{body[:-20]}\n")


def test_no_function_is_longer_than_80_lines_but_numba_kernels_that_say_why():
    found, still = [], set()
    for path in [*MODULES.values(), *sorted((ROOT / "qgis").rglob("*.py"))]:
        where = str(path.relative_to(ROOT))
        for name, n, why in long_functions(path.read_text(encoding="utf-8")):
            if f"{where}:{name}" in LONG_FUNCTIONS_BEING_REWRITTEN:
                still.add(f"{where}:{name}")
            elif not why:
                found.append(f"{where}: {name} is {n} lines long")
    assert not found, "\n".join(found)
    assert still == LONG_FUNCTIONS_BEING_REWRITTEN, "no longer long: empty the set of " + \
        ", ".join(sorted(LONG_FUNCTIONS_BEING_REWRITTEN - still))


def test_the_old_errors_path_still_imports_with_a_deprecation_warning():
    # user code written against `lidar_sig.errors` keeps working, told where the names went
    import importlib
    import sys

    import pytest

    from lidar_sig.base import errors

    sys.modules.pop("lidar_sig.errors", None)
    with pytest.warns(DeprecationWarning, match="lidar_sig.base.errors"):
        old = importlib.import_module("lidar_sig.errors")
    assert old.LidarSigError is errors.LidarSigError and old.arg is errors.arg
