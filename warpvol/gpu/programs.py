"""Fragment programs of the ray-casting walks as instruction listings, for the throughput model.

Each listing is the per-iteration body of a HARC fragment-program loop written out in
NV_fragment_program2 (fp40) instructions, one line per instruction, translated from what the
emulated step in :mod:`warpvol.kernels.harc` computes (vector operations packed four-wide as the
card did). A stage counts ``combiner_ops`` as (instructions of the listing) x (iterations run), and
the texture fetches of the listing (``TEX`` lines) by texture under their own counter names; the
model (:mod:`warpvol.model`) prices a loop's issue slots, ALU and TEX together.

The listings are hand translations (no driver compiled them): they fix what differs between the
integration methods -- the plane walk is shared, full pre-integration adds one 3D lookup and four
instructions, partial pre-integration adds the TF, psi and iso lookups and the Moreland & Angel
arithmetic per sub-step -- rather than the exact count a 2005 compiler emitted.

>>> n_alu(WALK), n_tex(WALK)
(30, 6)
>>> n_alu(FULL), n_tex(FULL), n_alu(PARTIAL_SUB), n_tex(PARTIAL_SUB)
(4, 1, 37, 4)

A fragment processor of the NV4x generation runs a program on batches of about a thousand pixels
in lock-step: a loop runs until the batch's longest ray is done, and the pixels that finished
earlier idle (:func:`batched_slots`).
"""

from __future__ import annotations

#: Espinha & Celes 2005 Fig. 6 lines 1-12: one cell of the plane walk (per loop iteration)
WALK = """
TEX n0, cell, MESH0        # face planes (rgba32f, nearest)
TEX n1, cell, MESH1
TEX n2, cell, MESH2
TEX n3, cell, MESH3
TEX nb, cell, NEIGHBOURS   # neighbour indices
TEX g, cell, GRADIENT      # scalar gradient and offset
DP4 sf, g, x               # scalar at the entry from this cell's gradient (Fig. 6 line 10; x: the last exit)
DP3 dn.x, d, n0            # d . n_i
DP3 dn.y, d, n1
DP3 dn.z, d, n2
DP3 dn.w, d, n3
DP3 on.x, o, n0            # o . n_i
DP3 on.y, o, n1
DP3 on.z, o, n2
DP3 on.w, o, n3
ADD on, on, offsets        # + o_i (the planes' w, gathered)
RCP r.x, dn.x
RCP r.y, dn.y
RCP r.z, dn.z
RCP r.w, dn.w
MUL lam, -on, r            # lambda_i
CMP lam, -dn, lam, BIG     # faces with d . n_i > 0 only
MIN t.xy, lam.xy, lam.zw
MIN t.x, t.x, t.y          # smallest lambda
SEQ sel, lam, t.x          # exit face mask
DP4 cell, sel, nb          # next cell across it
MAD x, d, t.x, o           # exit point
DP4 sb, g, x               # scalar at the exit (w = 1)
ADD l, t.x, -lam_in        # segment length
MUL y, cell, inv_width     # next cell's texel: row
FLR y, y
MAD tc.x, y, -width, cell  # column
ADD tc, tc, 0.5            # texel centre
MOV lam_in, t.x            # carry the exit to the next entry
BRK (cell < 0)             # left the mesh
ENDLOOP
"""

#: full pre-integration (Fig. 6 line 22 with the 3D table): normalise, look up, composite under
FULL = """
MAD st.xy, sfsb, s_inv, s_off   # (sf, sb) over the table's scalar axis
MUL st.z, l, l_inv              # l over lmax
TEX c, st, TABLE3D              # (C, alpha), trilinear
MAD acc, 1-acc.w, c, acc        # front-to-back under (with the SUB below)
SUB one_a, 1, acc.w
"""

#: partial pre-integration, one sub-step (Fig. 6 lines 13-24 with Moreland & Angel's psi table)
PARTIAL_SUB = """
MAD n.xy, sfsb, s_inv, s_off    # normalised (nf, nb)
TEX e, n, ISO                   # first control point crossed and the next one (nearest)
SNE hit, e.x, -1
SEQ same, n.x, e.x              # nf == s_iso: take the next one
CMP s_iso, -same, e.y, e.x
SUB a, s_iso, n.x
SUB b, n.y, n.x
MUL ab, a, b
SLE behind, ab, 0               # s_iso behind nf: ignored (paper's rule)
CMP s_iso, -behind, -1, s_iso
SGT nearer, |b|, |a|
MUL split, hit, nearer
CMP n1, -split, n.y, s_iso      # end of this sub-segment
SUB num, n1, n.x
RCP den, b
MUL frac, num, den
MUL h, l_left, frac             # sub-segment length
MAD s1, n1, s_scale, s_off      # back scalar of the sub-segment
ADD l_left, l_left, -h
MOV n.x, n1
BRK (!split)                    # last sub-step of the cell
TEX vf, s0, TF                  # TF at the front (colour, tau)
TEX vb, s1, TF                  # TF at the back
MUL x.xy, tau.xy, h             # tau l, front and back
ADD x1.xy, x.xy, 1
RCP r.x, x1.x
RCP r.y, x1.y
MUL gam.xy, x.xy, r.xy          # gamma = tau l / (tau l + 1)
MAD pc.xy, gam.xy, p_a, p_b     # psi texel coordinates
TEX p, pc, PSI                  # psi (fp16, bilinear)
ADD z, x.x, x.y
MUL z, z, -0.5log2e
EX2 zeta, z                     # zeta = exp(-l (tau_f + tau_b) / 2)
SUB w, p.x, zeta
MAX w, w, 0
SUB v, 1, p.x
MUL cb, vb, w
MAD c.rgb, vf, v, cb            # Cb (psi - zeta) + Cf (1 - psi)
SUB c.a, 1, zeta
SUB one_a, 1, acc.w
MAD acc, one_a, c, acc          # front-to-back under
"""


def _lines(listing: str) -> list[str]:
    return [ln.split("#")[0].strip() for ln in listing.strip().splitlines() if ln.split("#")[0].strip()]


def n_tex(listing: str) -> int:
    """Texture fetches (``TEX`` lines) of a listing."""
    return sum(1 for ln in _lines(listing) if ln.startswith("TEX"))


def n_alu(listing: str) -> int:
    """Arithmetic and flow-control instructions (every line that is not a ``TEX``) of a listing."""
    return sum(1 for ln in _lines(listing) if not ln.startswith("TEX"))


#: pixels per lock-step batch of an NV4x fragment processor, taken as 32 x 32 screen tiles ("NV4x ~1K pixels":
#: AnandTech, "NVIDIA's GeForce 8800 (G80)", 2006, branch-granularity table; the tile shape is an estimate)
BATCH_TILE = 32


def batched_slots(slots, ran, tile: int = BATCH_TILE) -> tuple[int, int]:
    """Issue slots of a fragment-program loop run per pixel (``slots``, ``(H, W)``; ``ran``: the pixels
    whose program ran) when ``tile x tile`` screen tiles run in lock-step: ``(sum of slots, sum over
    tiles of (pixels that ran) x (the tile's largest slots))``. The second is what the processor
    spends; their ratio is the loop's divergence.

    >>> import numpy as np
    >>> s = np.array([[1, 3], [2, 0]]); batched_slots(s, s > 0, tile=2)
    (6, 9)
    """
    import numpy as np

    s = np.asarray(slots, dtype=np.int64)
    r = np.asarray(ran, dtype=bool)
    h, w = s.shape
    hp, wp_ = -(-h // tile) * tile, -(-w // tile) * tile
    sp = np.zeros((hp, wp_), np.int64)
    rp = np.zeros((hp, wp_), bool)
    sp[:h, :w] = np.where(r, s, 0)
    rp[:h, :w] = r
    tiles_s = sp.reshape(hp // tile, tile, wp_ // tile, tile).swapaxes(1, 2).reshape(-1, tile * tile)
    tiles_r = rp.reshape(hp // tile, tile, wp_ // tile, tile).swapaxes(1, 2).reshape(-1, tile * tile)
    return int(sp.sum()), int((tiles_s.max(axis=1) * tiles_r.sum(axis=1)).sum())
