"""Emulated GPU units: number formats (:mod:`.formats`), counters, textures, rasteriser, blending, vertex stage."""
