"""Code several renderer families use, one layer below them: the entry bins of the boundary faces rays
enter through (:mod:`.entry_bins`), the pixels float32 cannot draw right -- thin cells, open edges,
silhouettes (:mod:`.thin_cells`, :mod:`.pixel_marks`) -- and the cells the transfer function makes
visible, with what skipping leaves out (:mod:`.visible`). A family imports from here, never from
another family.
"""
