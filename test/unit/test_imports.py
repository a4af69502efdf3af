"""Every import in the package resolves, including those inside functions (which importing a
module does not run): after a module moves, a stale relative import fails here, not at the
first call in a running node."""
import ast
import importlib
import importlib.util
import os

SRC = os.path.join(os.path.dirname(__file__), "..", "..", "src")


def _imports():
    for dirpath, _, files in os.walk(os.path.join(SRC, "bullet_floor_sim")):
        for name in sorted(files):
            if not name.endswith(".py"):
                continue
            path = os.path.join(dirpath, name)
            module = os.path.relpath(path, SRC)[:-3].replace(os.sep, ".")
            package = module[:-len(".__init__")] if name == "__init__.py" \
                else module.rsplit(".", 1)[0]
            for node in ast.walk(ast.parse(open(path).read())):
                if not isinstance(node, ast.ImportFrom):
                    continue
                if node.level:
                    parts = package.split(".")
                    parts = parts[:len(parts) - (node.level - 1)]
                    target = ".".join(parts + ([node.module] if node.module else []))
                else:
                    target = node.module or ""
                if target.startswith("bullet_floor_sim"):
                    yield "%s:%d" % (module, node.lineno), target, [a.name for a in node.names]


def test_every_import_in_the_package_resolves():
    seen, problems = 0, []
    for where, target, names in _imports():
        seen += 1
        try:
            module = importlib.import_module(target)
        except ImportError as e:
            problems.append("%s: %s" % (where, e))
            continue
        problems += ["%s: %s has no %s" % (where, target, n) for n in names
                     if not hasattr(module, n) and not importlib.util.find_spec(target + "." + n)]
    assert seen > 150       # the walk found the package's imports
    assert problems == []
