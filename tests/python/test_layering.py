"""The layers import one way (docs/architecture.md): the add-on and the pipeline use
volpath's public API only (no native module, no loader plugins, no private names); the
pipeline and volpath know no Blender; volpath knows neither the add-on nor the pipeline."""

import ast
import os

import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def imports(package):
    """(file, line, module, name) for every import in the package's sources; name is None
    for `import module`."""
    found = []
    for base, _, files in os.walk(os.path.join(ROOT, package)):
        for f in sorted(files):
            if not f.endswith(".py"):
                continue
            path = os.path.join(base, f)
            with open(path, encoding="utf-8") as src:
                tree = ast.parse(src.read(), path)
            where = os.path.relpath(path, ROOT)
            for node in ast.walk(tree):
                if isinstance(node, ast.Import):
                    found += [(where, node.lineno, a.name, None) for a in node.names]
                elif isinstance(node, ast.ImportFrom) and node.level == 0:
                    found += [(where, node.lineno, node.module, a.name) for a in node.names]
    return found


def private_volpath(module, name):
    """Whether an import reaches into volpath's private parts."""
    if module is None or module.split(".")[0] != "volpath":
        return False
    parts = module.split(".")[1:] + ([name] if name else [])
    return any(p.startswith("_") and not p.endswith("__") for p in parts) or "plugins" in parts


@pytest.mark.parametrize("package", ["addon", "pipeline"])
def test_front_ends_use_public_volpath_only(package):
    leaks = [f"{w}:{n}: {m}{'.' + a if a else ''}" for w, n, m, a in imports(package) if private_volpath(m, a)]
    assert not leaks, leaks


@pytest.mark.parametrize(
    "package, forbidden", [("volpath", {"bpy", "addon", "pipeline"}), ("pipeline", {"bpy", "addon"})]
)
def test_lower_layers_know_nothing_above(package, forbidden):
    leaks = [f"{w}:{n}: {m}" for w, n, m, _ in imports(package) if m.split(".")[0] in forbidden]
    assert not leaks, leaks


def test_the_check_sees_a_leak():
    assert private_volpath("volpath", "_core") and private_volpath("volpath.plugins.media", "X")
    assert private_volpath("volpath.volume", "_check_values") and not private_volpath("volpath.volume", "VolumeGrid")
    assert not private_volpath("volpath", "__version__")


def test_the_native_map_names_every_file():
    """native/README.md's map of the core stays the folder's: every source file is in it."""
    with open(os.path.join(ROOT, "native", "README.md"), encoding="utf-8") as f:
        text = f.read()
    missing = []
    for folder in ("native/src", "native/include/volpath", "native/bindings"):
        for _, _, files in os.walk(os.path.join(ROOT, folder)):
            missing += [f for f in files if f.endswith((".cpp", ".h")) and f not in text]
    assert not missing, f"native/README.md does not name {missing}"
