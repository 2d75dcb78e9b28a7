"""A new paper is its own folder: a toy family, written into a temporary package that warpvol has never
seen, is listed by ``warpvol pipelines``, renders, passes the architecture test, and its tolerance row, docs
page and table rows come from its declaration (``FAMILY`` in its ``__init__``), with nothing of warpvol edited.

The discovery mechanism is an **entry point** in the group ``warpvol.families`` (the toy's
``*.dist-info/entry_points.txt``, what ``pip install`` writes from a ``pyproject.toml``'s
``[project.entry-points."warpvol.families"]``); the built-in families are found by a scan of ``warpvol/``
(:mod:`warpvol.family`).
"""

import os
import subprocess
import sys
from pathlib import Path

import pytest

import test_architecture as arch

STAGE = '''"""Stage ``toy_fill``: every pixel one colour (premultiplied RGBA)."""

import numpy as np

from warpvol.stage import Context, Param, Stage, register_stage


@register_stage
class ToyFill(Stage):
    """Fill the image with one grey."""

    name = "toy_fill"
    summary = "fill the image with one grey"
    needs = ()
    provides = ("image",)
    params = (Param("grey", float, 0.25, "the grey, premultiplied with alpha 1", lo=0.0, hi=1.0),)

    def run(self, ctx: Context) -> None:
        cam = ctx.scene.camera
        ctx.image = np.full((cam.height_px, cam.width_px, 4), [self.grey, self.grey, self.grey, 1.0], np.float32)
'''

STAGES_INIT = '''"""The toy family's stages: importing this package registers every stage module in it."""

import importlib
import pkgutil

for _m in pkgutil.walk_packages(__path__, prefix=f"{__name__}."):
    importlib.import_module(_m.name)
'''

#: the toy's declaration: its paper (presets, docs page, files) and its tolerance row, all in its folder
INIT = '''"""Toy family."""

FAMILY = {
    "title": "Toy 2026",
    "renderer": True,
    "papers": (
        {"title": "Toy 2026", "presets": {"toy_grey": "the image filled with one grey"},
         "table": "one grey", "page": "papers/toy2026.md", "nav": "Toy et al. 2026",
         "code": {"stages": ["toyfam/stages/toy_fill.py"]}},
    ),
    "tolerances": {"toy_grey": {"max_abs": 0.0, "why": "every pixel is the grey it is given"}},
}
'''

PRESET = '''description = "Toy 2026: the image filled with one grey"

[[stages]]
stage = "toy_fill"
grey = 0.5
'''


def write_toy_family(root: Path) -> Path:
    """The toy family as a distribution would install it: its package and its entry point."""
    pkg = root / "toyfam"
    (pkg / "stages").mkdir(parents=True)
    (pkg / "presets").mkdir()
    (pkg / "__init__.py").write_text(INIT)
    (pkg / "stages" / "__init__.py").write_text(STAGES_INIT)
    (pkg / "stages" / "toy_fill.py").write_text(STAGE)
    (pkg / "presets" / "toy_grey.toml").write_text(PRESET)
    info = root / "toyfam-0.1.dist-info"
    info.mkdir()
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: toyfam\nVersion: 0.1\n")
    (info / "entry_points.txt").write_text("[warpvol.families]\ntoy = toyfam\n")
    return pkg


def warpvol_cmd(args: list[str], root: Path, cwd: Path) -> subprocess.CompletedProcess:
    env = {**os.environ, "PYTHONPATH": str(root)}
    exe = Path(sys.executable).with_name("warpvol")
    return subprocess.run([str(exe), *args], cwd=cwd, env=env, capture_output=True, text=True, timeout=600)


@pytest.fixture(scope="module")
def toy(tmp_path_factory):
    root = tmp_path_factory.mktemp("toy")
    return root, write_toy_family(root)


def test_the_toy_family_is_listed_by_warpvol_pipelines(toy):
    root, _ = toy
    r = warpvol_cmd(["pipelines"], root, root)
    assert r.returncode == 0, r.stderr
    assert "Toy 2026" in r.stdout and "toy_grey" in r.stdout and "the image filled with one grey" in r.stdout
    r = warpvol_cmd(["pipelines", "--stages"], root, root)
    assert r.returncode == 0 and "toy_fill" in r.stdout, r.stderr


def test_the_toy_family_renders(toy, tmp_path):
    root, _ = toy
    code = ("import numpy as np, warpvol\n"
            "sc = warpvol.builtin_scene('box').with_camera(width_px=8, height_px=8)\n"
            "r = warpvol.render(sc, pipeline='toy_grey', quiet=True)\n"
            "print(r.image.shape, np.unique(r.image).tolist(), r.report['pipeline'])\n")
    r = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, env={**os.environ, "PYTHONPATH": str(root)},
                       capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stderr
    assert r.stdout.split("\n")[-2] == "(8, 8, 4) [0.5, 1.0] toy_grey", r.stdout
    r = warpvol_cmd(["render", "builtin:box", "--pipeline", "toy_grey", "--width", "8", "--height", "8",
                     "-o", "toy.png", "--quiet"], root, tmp_path)
    assert r.returncode == 0 and (tmp_path / "toy.png").is_file(), r.stderr


def test_the_toy_familys_tolerance_row_docs_page_and_tables_come_from_its_declaration(toy):
    """The toy's tolerance row is in tests/tolerances.py's table, its page in the site's Papers section, its
    paper in the architecture page's table and the preset tables, with nothing of warpvol edited."""
    root, _ = toy
    repo = Path(__file__).resolve().parents[1]
    code = ("import sys\n"
            f"sys.path[:0] = [{str(repo / 'tests')!r}, {str(repo / 'docs')!r}, {str(repo / 'scripts')!r}]\n"
            "from tolerances import TOLERANCES, preset_tolerance\n"
            "import hooks, preset_tables\n"
            "print(preset_tolerance('toy_grey'), TOLERANCES['raycast/fp32'])\n"
            "print(hooks.papers_nav()[-1])\n"
            "print([r for r in preset_tables.architecture_table().splitlines() if 'toy' in r])\n"
            "print([r for r in preset_tables.table(None).splitlines() if 'toy' in r])\n")
    r = subprocess.run([sys.executable, "-c", code], cwd=root, env={**os.environ, "PYTHONPATH": str(root)},
                       capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stderr
    tol, nav, arch_rows, table_rows = r.stdout.splitlines()
    assert tol == "{'max_abs': 0.0} {'rmse': 2e-06, 'max_abs': 0.0001}"
    assert nav == "{'Toy et al. 2026': 'papers/toy2026.md'}"
    assert arch_rows == "['| Toy 2026 (`toy_grey`) | `toyfam/` |  | `toyfam/stages/toy_fill.py` |  |  |']"
    assert table_rows == "['| Toy 2026 | `toy_grey` | one grey |']"


def test_the_toy_family_is_accepted_by_the_architecture_test(toy):
    root, pkg = toy
    modules = {**arch.MODULES, **arch.package_modules(pkg, "toyfam")}
    layers = arch.layers_with_families({**arch.FAMILY_DECLARATIONS, "toyfam": {"renderer": True}})
    graph = {m: arch.imports(m, p, modules) for m, p in modules.items()}
    assert {"toyfam", "toyfam.stages", "toyfam.stages.toy_fill"} <= set(graph)
    assert arch.layer_violations(graph, layers) == []
    assert arch.cross_family_imports(graph, [*arch.RENDERER_FAMILIES, "toyfam"]) == []


def test_the_architecture_test_would_refuse_a_toy_that_reaches_into_another_family(toy, tmp_path):
    _, pkg = toy
    bad = tmp_path / "toybad"
    (bad / "stages").mkdir(parents=True)
    (bad / "__init__.py").write_text('FAMILY = {"renderer": True}\n')
    (bad / "stages" / "__init__.py").write_text("")
    (bad / "stages" / "peek.py").write_text("def f():\n    from warpvol.raycasting.harc import march_pass\n")
    modules = {**arch.MODULES, **arch.package_modules(bad, "toybad")}
    graph = {m: arch.imports(m, p, modules) for m, p in modules.items()}
    assert arch.cross_family_imports(graph, [*arch.RENDERER_FAMILIES, "toybad"]) == [
        "toybad.stages.peek:2 imports warpvol.raycasting.harc"]
