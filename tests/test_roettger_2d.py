"""Roettger & Ertl 2002 §4, the 2D path as the paper's hardware ran it.

* The cylindrical planes resample the very table the 3D presets draw from (``roettger2000_3d``'s
  software table in ``roettger2002_cylindrical``; ``roettger2002_hw``'s hardware table when its table
  stage is put first): checked against a float64 trilinear resampling of that table (eq. 9), and
  against the planes of an exact table, which differ.
* The weight between the two planes is an 8-bit colour value (the combiner interpolates with the
  primary colour's alpha): with planes of constant 0 and 1 the result is the weight itself, and it
  only takes values k / 255.
* The SGI path of Fig. 8 draws one texture: the nearest plane, its nearest texel, one 2D nearest
  fetch per fragment and no combiner step; modelled on the Octane MXI, which has one texture unit.
"""

from __future__ import annotations

import dataclasses
import tomllib

import numpy as np
import pytest

from test_tables_common import smooth_tf
from warpvol.errors import ConfigError
from warpvol.pipeline import Pipeline, _read_pipeline_text
from warpvol.tables.base import Axis
from warpvol.tables.cylindrical import build_cylindrical, from_cylinder, reconstruct
from warpvol.tables.exact import build_exact3d
from warpvol.tables.roettger_hw import build_roettger_hw
from warpvol.tables.roettger_sw import build_roettger_sw

RGBA8_HALF = 0.5 / 255


def preset(name, **overrides):
    cfg = tomllib.loads(_read_pipeline_text(name)[0])
    for st in cfg["stages"]:
        st.update(overrides.get(st["stage"], {}))
    return Pipeline.from_config(cfg)


def small_scene(n=48):
    from warpvol.scene.builtin import builtin_scene

    sc = builtin_scene("sphere")
    return type(sc)(mesh=sc.mesh, transfer=sc.transfer, camera=sc.camera.replace(width_px=n, height_px=n),
                    name="sphere_small")


def index_of(ax: Axis, x):
    """Continuous texel index of normalised ``x`` on a linear axis (clamped), as the texture reads it."""
    x = np.clip(np.asarray(x, np.float64), 0.0, 1.0)
    i = x * ax.n - 0.5 if ax.kind == "centred" else x * (ax.n - 1)
    return np.clip(i, 0.0, ax.n - 1)


def trilinear64(t, sf, sb, l):
    """float64 trilinear filtering of ``t.data[l, sb, sf]`` (clamp to edge)."""
    d = t.data.astype(np.float64)
    idx = [index_of(t.axes[2], sf), index_of(t.axes[1], sb), index_of(t.axes[0], l)]
    lo = [np.minimum(np.floor(i).astype(int), max(ax.n - 2, 0)) for i, ax in zip(idx, t.axes[::-1])]
    fr = [(i - a)[..., None] for i, a in zip(idx, lo)]
    out = 0.0
    for df in (0, 1):
        for db in (0, 1):
            for dl in (0, 1):
                w = (fr[0] if df else 1 - fr[0]) * (fr[1] if db else 1 - fr[1]) * (fr[2] if dl else 1 - fr[2])
                out = out + w * d[np.minimum(lo[2] + dl, t.axes[0].n - 1), np.minimum(lo[1] + db, t.axes[1].n - 1),
                                  np.minimum(lo[0] + df, t.axes[2].n - 1)]
    return out


def planes_from(t, cyl):
    """What the planes of ``cyl`` should hold when they resample ``t`` (eq. 9 at the planes' nodes)."""
    a = cyl.axes[0].nodes[:, None, None]
    s = cyl.axes[2].nodes[None, None, :]
    tt = cyl.axes[1].nodes[None, :, None]
    q = from_cylinder(*np.broadcast_arrays(a, s, tt))
    return trilinear64(t, q[..., 0], q[..., 1], q[..., 2])


@pytest.mark.parametrize("which", ["software", "hardware"])
def test_planes_resample_the_3d_presets_table(which):
    tf = smooth_tf(emission="emission_density", rho_max=3.0)
    if which == "software":
        src = build_roettger_sw(tf, n_s=16, n_l=16, m=32, format="rgba8")
    else:
        src = build_roettger_hw(tf, n_s=16, n_l=16, steps=32, bits=12)
    cyl = build_cylindrical(tf, table=src, planes="1x", format="rgba8")
    assert cyl.meta["source_key"] == src.key and cyl.meta["source_table"] == src.name
    want = planes_from(src, cyl)
    d = np.abs(cyl.data - want)
    # the planes are that table resampled (fp32 in the kernel) and stored at 8 bits: half a code
    assert d.max() <= RGBA8_HALF + 1e-5, d.max()
    # an exact table's planes (what the preset resampled before) are a different set of numbers
    ex = build_cylindrical(tf, n_s=16, n_l=16, lmax=src.axes[0].scale, planes="1x", format="rgba8")
    assert np.abs(ex.data - want).max() > 4 * RGBA8_HALF
    with pytest.raises(ValueError, match="source"):
        build_cylindrical(tf, table=src, source="exact")


def test_preset_planes_come_from_roettger2000_3d_table():
    sc = small_scene(32)
    p3 = Pipeline.load("roettger2000_3d")
    p2 = Pipeline.load("roettger2002_cylindrical")
    p3.render(sc, quiet=True)
    r2 = p2.render(sc, quiet=True)
    sw3 = [t for t in p3.persistent["table_cache"]._store.values() if t.name == "roettger_sw"]
    sw2 = [t for t in p2.persistent["table_cache"]._store.values() if t.name == "roettger_sw"]
    cyl = [t for t in p2.persistent["table_cache"]._store.values() if t.name == "cylindrical"]
    assert len(sw3) == len(sw2) == len(cyl) == 1
    assert sw2[0].key == sw3[0].key and np.array_equal(sw2[0].data, sw3[0].data)
    assert cyl[0].meta["source_key"] == sw3[0].key
    assert r2.report["stats"]["pt_cylindrical"]["source_table"] == "roettger_sw"
    # the hardware table of roettger2002_hw, named by the same mechanism (small for speed)
    cfg = tomllib.loads(_read_pipeline_text("roettger2002_cylindrical")[0])
    hw = next(s for s in tomllib.loads(_read_pipeline_text("roettger2002_hw")[0])["stages"]
              if s["stage"] == "table_roettger_hw")
    cfg["stages"] = [dict(hw, n_s=16, n_l=8, steps=16) if s["stage"] == "table_roettger_sw" else s
                     for s in cfg["stages"]]
    ph = Pipeline.from_config(cfg)
    ph.render(sc, quiet=True)
    store = ph.persistent["table_cache"]._store.values()
    hwt = next(t for t in store if t.name == "roettger_hw")
    assert next(t for t in store if t.name == "cylindrical").meta["source_key"] == hwt.key
    # a table name that no stage provides is an error naming the field
    with pytest.raises(ConfigError, match="table_cylindrical.*table"):
        preset("roettger2002_cylindrical", table_cylindrical={"table": "nope"}).render(sc, quiet=True)


def two_level_planes(P=8, n=8):
    """Planes alternating between all-0 and all-1 texels (exact in RGBA8): between planes p and p + 1
    the reconstruction is the weight (p even) or 1 - weight (p odd)."""
    tf = smooth_tf()
    cyl = build_cylindrical(tf, n_s=n, planes="1x", format="rgba8")
    data = np.zeros((n, n, n, 4), np.float32)
    data[1::2] = 1.0
    return dataclasses.replace(cyl, data=data[:P] if P < n else data, extra={})


def test_plane_weight_takes_only_8_bit_values():
    cyl = two_level_planes()
    P = cyl.data.shape[0]
    rng = np.random.default_rng(3)
    alpha = rng.uniform(0.0, 0.25, 3000)     # (t + s, t, 4 alpha s): sf - sb = s, l = 4 alpha s
    s = rng.uniform(0.2, 0.6, alpha.size)
    sb = rng.uniform(0.1, 0.3, alpha.size)
    sf, l = sb + s, 4 * alpha * s
    pa = alpha * (P - 1)
    w = pa - np.floor(pa)
    w = np.where(np.floor(pa).astype(int) % 2 == 0, w, 1 - w)   # value between a 0 plane and a 1 plane
    v8 = reconstruct(cyl, sf, sb, l, plane_weight="unorm8")[:, 3].astype(np.float64)
    v32 = reconstruct(cyl, sf, sb, l, plane_weight="fp32")[:, 3].astype(np.float64)
    codes = v8 * 255
    np.testing.assert_allclose(codes, np.round(codes), atol=2e-4)          # only k / 255
    np.testing.assert_allclose(v8, w, atol=RGBA8_HALF + 1e-5)              # the weight, rounded
    np.testing.assert_allclose(v32, w, atol=1e-5)                          # fp32: the weight itself
    assert np.abs(v32 * 255 - np.round(v32 * 255)).max() > 0.3             # which is not 8-bit
    assert len(np.unique(np.round(codes))) > 100


def test_preset_draws_with_the_8_bit_weight():
    sc = small_scene(40)
    img8 = preset("roettger2002_cylindrical").render(sc, quiet=True)
    img32 = preset("roettger2002_cylindrical", pt_cylindrical={"plane_weight": "fp32"}).render(sc, quiet=True)
    assert img8.report["stats"]["pt_cylindrical"]["plane_weight"] == "unorm8"
    d = np.abs(np.asarray(img8.image, np.float64) - np.asarray(img32.image, np.float64))
    assert d.max() > 0                       # the weight's rounding reaches the image
    assert d.max() <= 4 / 255                # and is a rounding, not another method


def test_sgi_path_is_one_texture_nearest_plane_nearest_texel():
    tf = smooth_tf(rho_max=2.0)
    cyl = build_cylindrical(tf, table=build_exact3d(tf, n_s=16, n_l=16), planes="1x", format="rgba8")
    rng = np.random.default_rng(5)
    p = rng.random((3000, 3))
    got = reconstruct(cyl, p[:, 0], p[:, 1], p[:, 2], path="sgi")
    from warpvol.tables.cylindrical import to_cylinder

    c = to_cylinder(np.float32(p[:, 0]), np.float32(p[:, 1]), np.float32(p[:, 2]))
    P = cyl.data.shape[0]
    plane = np.clip(np.floor(np.clip(c[:, 0], 0, 1) * (P - 1) + 0.5), 0, P - 1).astype(int)
    i = np.floor(index_of(cyl.axes[2], c[:, 1]) + 0.5).astype(int)
    j = np.floor(index_of(cyl.axes[1], c[:, 2]) + 0.5).astype(int)
    want = cyl.data[plane, j, i]
    ok = np.all(got == want, axis=1)
    assert ok.mean() > 0.995, ok.mean()      # ties at texel / plane midpoints may round either way
    lin = reconstruct(cyl, p[:, 0], p[:, 1], p[:, 2])
    assert np.abs(lin - want).max() > 0.01   # the multi-texture path filters

    sc = small_scene(40)
    res = preset("roettger2002_cylindrical", pt_cylindrical={"path": "sgi"}).render(sc, quiet=True)
    c = res.report["counters"]["pt_cylindrical"]
    n = c["fragments"]
    assert n > 0 and c["texture_lookups"] == n and c["tex_2d_rgba8_nearest"] == n
    assert not c.get("tex_2d_rgba8_linear") and not c.get("combiner_ops")
    assert res.report["stats"]["pt_cylindrical"]["path"] == "sgi"
    m = preset("roettger2002_cylindrical").render(sc, quiet=True).report["counters"]["pt_cylindrical"]
    assert m["tex_2d_rgba8_linear"] == 2 * m["fragments"] and m["combiner_ops"] == m["fragments"]
    # the one-texture path runs on the Octane MXI's single texture unit; the two-texture path does not
    from warpvol import model

    mxi = model.load_profile("octane_mxi")
    model.check_caps(mxi, "pt_cylindrical", {"texture_units": 1})
    for stg in preset("roettger2002_cylindrical", pt_cylindrical={"path": "sgi"}).stages:
        if stg.name == "pt_cylindrical":
            model.check_caps(mxi, stg.where, stg.requires_caps())
    two = [s for s in preset("roettger2002_cylindrical").stages if s.name == "pt_cylindrical"][0]
    with pytest.raises(ConfigError, match="texture units"):
        model.check_caps(mxi, two.where, two.requires_caps())
    r = model.model_counters(c, mxi)
    assert r["s"] is not None and r["s"] > 0
