"""Docstrings name modules and functions where they are: every ``warpvol.…`` path that a docstring or comment
of the package or its kernels writes between backticks (a Sphinx role's target or a literal) imports and
resolves, so a module that moves cannot leave its old path behind (as the kernels named
``warpvol.raycasting.thin_cells`` after it moved to ``warpvol.shared``)."""

import importlib
import inspect
import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
#: a dotted warpvol path between backticks (``:func:`~warpvol.x.y```, ````warpvol.x````)
PATH = re.compile(r"`~?(warpvol(?:\.[A-Za-z_][A-Za-z0-9_]*)+)`")


def resolves(dotted: str) -> bool:
    """Whether ``dotted`` is a module, or an attribute of one (an instance attribute that a class's code sets
    as ``self.<name>`` counts)."""
    parts = dotted.split(".")
    for k in range(len(parts), 0, -1):
        try:
            obj = importlib.import_module(".".join(parts[:k]))
        except ImportError:
            continue
        for name in parts[k:]:
            if hasattr(obj, name):
                obj = getattr(obj, name)
            elif inspect.isclass(obj) and f"self.{name} =" in inspect.getsource(obj):
                return name == parts[-1]
            else:
                return False
        return True
    return False


def test_every_warpvol_path_a_docstring_names_exists():
    files = sorted([*ROOT.glob("warpvol/**/*.py"), *ROOT.glob("kernels/*.py")])
    bad = [f"{f.relative_to(ROOT)}:{n}: {m}" for f in files
           for n, line in enumerate(f.read_text().splitlines(), 1) for m in PATH.findall(line) if not resolves(m)]
    assert bad == []
