"""Scene conditioning: the scene centred, scaled and checked for float32 precision
(:mod:`.conditioning`); the ``condition`` stage in :mod:`.stages`.
"""

#: the family's declaration (warpvol.family): a renderer family imports no other family
FAMILY = {"title": "scene conditioning", "renderer": False}
