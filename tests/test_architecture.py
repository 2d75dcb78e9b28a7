"""The package's layers: a module imports only from its own layer or below, and no modules import each
other in a circle (docs/architecture.md draws the layers).

Every import of every module under ``warpvol/`` (and ``kernels/``, installed as ``warpvol.kernels``)
is read with ``ast``, those inside functions too; imports of other packages (warp, pyvista, dask,
matplotlib, ...) are not looked at.
"""

import ast
from pathlib import Path

import pytest

from warpvol.family import family_declaration, family_packages

ROOT = Path(__file__).resolve().parents[1]

#: the layer of the pipeline families (a family found by warpvol.family gets it with no line here)
FAMILY_LAYER = 7
#: module prefix -> layer; a module takes the layer of its longest matching prefix
LAYERS = {
    # 0 base: errors, helpers for threads, timing, progress, files and image errors
    "warpvol.errors": 0, "warpvol.parallel": 0, "warpvol.timing": 0, "warpvol.progress": 0, "warpvol.io": 0,
    "warpvol.metrics": 0,
    # 1 Warp kernels, one module per unit
    "warpvol.kernels": 1,
    # 2 the scene data model
    "warpvol.scene": 2,
    # 3 emulated GPU units (formats, counters), the exact reference, the performance model, conditioning
    "warpvol.gpu": 3, "warpvol.reference": 3, "warpvol.model": 3, "warpvol.conditioning.conditioning": 3,
    "warpvol.conditioning.reorder": 3, "warpvol.conditioning.visibility": 3,
    # segments (per-entry ray pieces) and their deep OpenEXR files, beside the reference they come from
    "warpvol.segments": 3, "warpvol.deep": 3,
    # 4 pre-integration tables
    "warpvol.tables": 4,
    # 5 the stage framework
    "warpvol.stage": 5,
    # 6 code several renderer families share (entry bins, thin-cell and pixel marks, visibility and skipping,
    #   the integration set-up and table textures)
    "warpvol.shared": 6,
    # 7 the pipeline families: host code and stages (every family's "stages" package, all of a renderer
    #   family): added from their declarations by layers_with_families(); conditioning's stages import its host
    "warpvol.conditioning": 7,
    # 8 the stage catalog, family discovery and pipelines (presets)
    "warpvol.stages": 8, "warpvol.family": 8, "warpvol.pipeline": 8, "warpvol.presets": 8, "warpvol.profiles": 8,
    # 9 the Python API, the session caches, the reference in bands
    "warpvol.api": 9, "warpvol.cache": 9, "warpvol.bands": 9, "warpvol.figures": 9,
    "warpvol.pieces": 9, "warpvol.raycast_segments": 9,
    # 10 tools and the reproduction of the papers
    "warpvol.tools": 10, "warpvol.reproduce": 10,
    # 11 the command line and the package's face
    "warpvol.cli": 11, "warpvol": 11,
}


def module_name(path: Path, root: Path = ROOT) -> str:
    rel = path.relative_to(root).with_suffix("")
    parts = list(rel.parts)
    if parts[0] == "kernels":
        parts = ["warpvol", "kernels"] + parts[1:]
    if parts[-1] == "__init__":
        parts = parts[:-1]
    return ".".join(parts)


def all_modules() -> dict[str, Path]:
    paths = sorted(ROOT.glob("warpvol/**/*.py")) + sorted(ROOT.glob("kernels/*.py"))
    return {module_name(p): p for p in paths}


MODULES = all_modules()


def package_modules(folder: Path, name: str) -> dict[str, Path]:
    """The modules of a package outside warpvol (a family an entry point declares), by dotted name."""
    return {name + ("." + module_name(p, folder) if module_name(p, folder) else ""): p
            for p in sorted(folder.glob("**/*.py"))}


#: the families (warpvol.family finds them: a scan of warpvol/, then entry points) and what they declare
FAMILY_DECLARATIONS = {pkg: family_declaration(pkg) for pkg in family_packages()}


def layers_with_families(declarations: dict[str, dict]) -> dict[str, int]:
    """:data:`LAYERS` with every family found: a family's stages sit at the families' layer, and so does
    all of a renderer family (its host code too)."""
    out = dict(LAYERS)
    for pkg, decl in declarations.items():
        out.setdefault(f"{pkg}.stages", FAMILY_LAYER)
        if decl.get("renderer"):
            out.setdefault(pkg, FAMILY_LAYER)
    return out


LAYERS = layers_with_families(FAMILY_DECLARATIONS)
#: the renderer families: none imports another (what two of them need lives in ``warpvol.shared``)
RENDERER_FAMILIES = sorted(pkg for pkg, decl in FAMILY_DECLARATIONS.items() if decl.get("renderer"))


def layer(mod: str, layers: dict[str, int] | None = None) -> int:
    layers = LAYERS if layers is None else layers
    best = max((k for k in layers if mod == k or mod.startswith(k + ".")), key=len)
    return layers[best]


def imports(mod: str, path: Path, modules: dict[str, Path] | None = None) -> list[tuple[str, int]]:
    """The modules of ``modules`` (warpvol's by default) that ``mod`` imports, with the line (a name imported
    from a package that is a module of it counts as that module)."""
    modules = MODULES if modules is None else modules
    roots = {m.split(".")[0] for m in modules}
    is_pkg = path.name == "__init__.py"
    pkg = mod.split(".") if is_pkg else mod.split(".")[:-1]
    out = []
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            out += [(a.name, node.lineno) for a in node.names if a.name.split(".")[0] in roots]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = ".".join(pkg[:len(pkg) - node.level + 1] + ([node.module] if node.module else []))
            else:
                base = node.module or ""
            if base.split(".")[0] not in roots:
                continue
            for a in node.names:
                sub = f"{base}.{a.name}"
                out.append((sub if sub in modules else base, node.lineno))
    return [(t, line) for t, line in out if t != mod]


GRAPH = {m: imports(m, p) for m, p in MODULES.items()}


def layer_violations(graph: dict[str, list[tuple[str, int]]], layers: dict[str, int] | None = None) -> list[str]:
    return [f"{m} (layer {layer(m, layers)}) imports {t} (layer {layer(t, layers)}), line {line}"
            for m, ts in graph.items() for t, line in ts if layer(t, layers) > layer(m, layers)]


def test_every_module_has_a_layer_and_every_import_resolves():
    assert "warpvol.scene.mesh" in MODULES and "warpvol.kernels.raycast" in MODULES
    missing = [(m, t, line) for m, ts in GRAPH.items() for t, line in ts if t not in MODULES]
    assert not missing, f"imports of modules that do not exist: {missing}"


def test_a_module_imports_only_from_its_layer_or_below():
    up = layer_violations(GRAPH)
    assert not up, "imports that run up a layer:\n" + "\n".join(up)


def find_cycle(graph: dict[str, list[str]]) -> list[str] | None:
    state: dict[str, int] = {}
    stack: list[str] = []

    def visit(m):
        state[m] = 1
        stack.append(m)
        for t in graph.get(m, ()):
            if state.get(t) == 1:
                return stack[stack.index(t):] + [t]
            if t not in state:
                c = visit(t)
                if c:
                    return c
        stack.pop()
        state[m] = 2
        return None

    for m in sorted(graph):
        if m not in state:
            c = visit(m)
            if c:
                return c
    return None


def family(mod: str, families=None) -> str | None:
    return next((f for f in (RENDERER_FAMILIES if families is None else families)
                 if mod == f or mod.startswith(f + ".")), None)


def cross_family_imports(graph: dict[str, list[tuple[str, int]]], families=None) -> list[str]:
    return [f"{m}:{line} imports {t}" for m, ts in graph.items() for t, line in ts
            if family(m, families) and family(t, families) and family(m, families) != family(t, families)]


def test_the_renderer_families_are_found_from_their_declarations():
    assert RENDERER_FAMILIES == ["warpvol.projection", "warpvol.raycasting", "warpvol.vsbuffer"]


def test_no_renderer_family_imports_another():
    cross = cross_family_imports(GRAPH)
    assert not cross, "a renderer family imports another (move what both need to warpvol/shared/):\n" + \
        "\n".join(cross)


def test_the_family_check_finds_an_import_across_families():
    graph = {"warpvol.vsbuffer.x": [("warpvol.raycasting.y", 12)], "warpvol.raycasting.y": [("warpvol.shared.z", 3)]}
    assert cross_family_imports(graph) == ["warpvol.vsbuffer.x:12 imports warpvol.raycasting.y"]


def test_no_import_circle():
    graph = {m: sorted({t for t, _ in ts if t in MODULES}) for m, ts in GRAPH.items()}
    cycle = find_cycle(graph)
    assert cycle is None, "modules that import each other in a circle: " + " -> ".join(cycle)


@pytest.mark.parametrize("graph, circle", [({"a": ["b"], "b": ["c"], "c": ["a"]}, True),
                                           ({"a": ["b", "c"], "b": ["c"], "c": []}, False)])
def test_the_circle_finder_finds_circles(graph, circle):
    assert (find_cycle(graph) is not None) == circle


def test_the_layer_check_sees_imports_inside_functions():
    src = MODULES["warpvol.pipeline"]
    found = [t for t, _ in imports("warpvol.pipeline", src)]
    assert "warpvol.stages" in found  # imported on first use, inside a function


def test_no_package_is_listed_by_hand():
    """pyproject.toml names no package: setup.py finds every folder of ``warpvol/`` by a scan, so a new
    family's folder is installed with no line added (``kernels/`` -> ``warpvol.kernels`` is the one mapping)."""
    import tomllib

    from setuptools import find_namespace_packages

    setuptools_cfg = tomllib.loads((ROOT / "pyproject.toml").read_text()).get("tool", {}).get("setuptools", {})
    assert "packages" not in setuptools_cfg and "package-dir" not in setuptools_cfg
    setup_py = (ROOT / "setup.py").read_text()
    assert "find_namespace_packages(" in setup_py and '"warpvol.kernels": "kernels"' in setup_py
    found = set(find_namespace_packages(str(ROOT), include=["warpvol", "warpvol.*"], exclude=["*.__pycache__"]))
    python_folders = {module_name(p.parent / "__init__.py") for p in ROOT.glob("warpvol/**/*.py")}
    assert python_folders <= found, sorted(python_folders - found)


def internal_import_counts() -> tuple[int, int]:
    """(internal imports, those inside functions) over every module of the package and the kernels."""
    total = inside = 0
    for mod, path in MODULES.items():
        tree = ast.parse(path.read_text(), str(path))
        in_function = {id(n) for f in ast.walk(tree) if isinstance(f, (ast.FunctionDef, ast.AsyncFunctionDef))
                       for n in ast.walk(f) if n is not f}
        for node in ast.walk(tree):
            if isinstance(node, ast.ImportFrom):
                internal = node.level > 0 or (node.module or "").split(".")[0] == "warpvol"
            elif isinstance(node, ast.Import):
                internal = any(a.name.split(".")[0] == "warpvol" for a in node.names)
            else:
                continue
            if internal:
                total += 1
                inside += id(node) in in_function
    return total, inside


def test_most_internal_imports_are_at_the_top_of_their_module():
    """A module's dependencies are read from its top. What stays inside functions, each for a reason: the
    package's face and the command line's dispatch (``import warpvol`` and ``warpvol --help`` load no
    renderer), heavy optional dependencies (pyvista/VTK, matplotlib, Dask, Playwright, OpenImageIO), Warp's
    kernels in modules that do not otherwise start Warp, and the imports that would close a circle through a
    family's ``stages`` package (which imports every stage module in it)."""
    total, inside = internal_import_counts()
    assert total > 500 and inside <= 0.25 * total, f"{inside} of {total} internal imports inside functions"
