"""Emulated GPU units: number formats live in warpvol.formats; textures, rasteriser, blending, vertex stage here."""
