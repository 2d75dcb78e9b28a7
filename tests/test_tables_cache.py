"""Cache keys, TF-edit rebuild rules and the table stages."""

import numpy as np
import pytest

from test_tables_common import smooth_tf
from warpvol.errors import ConfigError
from warpvol.pipeline import get_stage_class
from warpvol.scene.transfer import TransferFunction
from warpvol.stage import Context
from warpvol.tables.cache import TableCache


def test_tf_edit_rebuilds_only_dependent_tables():
    cache = TableCache()
    tf = smooth_tf()
    req = [("exact3d", dict(n_s=8, n_l=4)), ("psi", dict(n=16)), ("isocross", dict(n=16)),
           ("guthe2d", dict(n_s=8, degree=2))]
    for b, p in req:
        cache.get(b, tf, **p)
    assert len(cache.builds) == 4
    for b, p in req:
        cache.get(b, tf, **p)
    assert len(cache.builds) == 4 and cache.hits == 4
    # colour edit: positions unchanged -> exact3d and guthe2d rebuild; psi and iso do not
    pts = np.array(tf.points)
    pts[3, 1] = 0.0
    tf2 = TransferFunction(pts, tf.emission)
    for b, p in req:
        cache.get(b, tf2, **p)
    rebuilt = [k[0] for k in cache.builds[4:]]
    assert sorted(rebuilt) == ["exact3d", "guthe2d"]
    # moving a control point also rebuilds the iso table, never psi
    pts[3, 0] += 0.01
    tf3 = TransferFunction(pts, tf.emission)
    for b, p in req:
        cache.get(b, tf3, **p)
    assert sorted(k[0] for k in cache.builds[6:]) == ["exact3d", "guthe2d", "isocross"]
    assert sum(k[0] == "psi" for k in cache.builds) == 1


def test_parameters_and_format_are_part_of_the_key():
    cache = TableCache()
    tf = smooth_tf()
    a = cache.get("exact3d", tf, n_s=8, n_l=4)
    b = cache.get("exact3d", tf, n_s=8, n_l=4, format="rgba8")
    c = cache.get("exact3d", tf, n_s=8, n_l=5)
    assert a is not b and a is not c and b.format == "rgba8"
    with pytest.raises(ConfigError):
        cache.get("nope", tf)


class _Scene:
    def __init__(self, tf):
        self.transfer = tf
        self.mesh = type("M", (), {"lmax": 2.0})()


STAGE_CASES = [
    ("table_exact", dict(n_s=8, n_l=4), "table3d"),
    ("table_roettger_sw", dict(n_s=8, n_l=4), "table3d"),
    ("table_roettger_hw", dict(n_s=8, n_l=2, steps=8), "table3d"),
    ("table_pingpong", dict(n_s=8, m=8, n_slices=2), "slices"),
    ("table_incremental", dict(n_s=8, n_l=4), "table3d"),
    ("table_cylindrical", dict(n_s=8, planes="2x"), "planes"),
    ("table_guthe", dict(n_s=8, degree=4), "guthe"),
    ("table_psi", dict(n=8), "psi"),
    ("table_iso", dict(n=8), "iso"),
]


@pytest.mark.parametrize("name,params,out", STAGE_CASES)
def test_stage_builds_into_buffers(name, params, out):
    ctx = Context(scene=_Scene(smooth_tf()), quiet=True)
    st = get_stage_class(name)(**params)
    st.run(ctx)
    t = ctx.buffers[out]
    assert np.isfinite(t.data).all()
    assert ctx.stats["tables"][out]["built"]
    if "lmax" in st.config:
        assert t.meta.get("lmax") == 2.0  # lmax = 0 -> the mesh's longest edge
    st.run(ctx)
    assert not ctx.stats["tables"][out]["built"]  # cached
    assert name in st.doc_table()


def test_stage_rejects_bad_parameters():
    with pytest.raises(ConfigError, match="bits"):
        get_stage_class("table_roettger_hw")(bits=10)
    with pytest.raises(ConfigError, match="bits"):
        get_stage_class("table_roettger_hw")(variant="geforce3", bits=12)
    with pytest.raises(ConfigError, match="unknown key"):
        get_stage_class("table_psi")(n=8, foo=1)


def test_pipeline_keeps_its_table_cache_across_renders_and_tf_edits():
    # the table stages of one pipeline (a Pipeline itself must also write an image)
    stages = [get_stage_class("table_exact")(n_s=8, n_l=2), get_stage_class("table_iso")(n=8),
              get_stage_class("table_psi")(n=8)]
    persistent = {}

    def render(tf):
        ctx = Context(scene=_Scene(tf), quiet=True, persistent=persistent)
        for st in stages:
            st.run(ctx)
        return {k: v["built"] for k, v in ctx.stats["tables"].items()}

    tf = smooth_tf()
    assert render(tf) == {"table3d": True, "iso": True, "psi": True}
    assert render(tf) == {"table3d": False, "iso": False, "psi": False}  # second render: all cached
    recoloured = TransferFunction(np.column_stack([tf.points[:, 0], tf.points[:, 1:4][::-1], tf.points[:, 4]]),
                                  tf.emission)
    # a colour edit keeps the control-point positions: only the TF-dependent 3D table is rebuilt
    assert render(recoloured) == {"table3d": True, "iso": False, "psi": False}
