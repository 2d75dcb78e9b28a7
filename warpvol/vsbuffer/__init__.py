"""VSBUFFER sweep planes (Westermann & Ertl 1997): host code (:mod:`.vsbuffer`), convex cells
(:mod:`.cells`), the octree of cells (:mod:`.octree`) and the stages (:mod:`.stages`).
"""

#: the family's declaration (warpvol.family): a renderer family imports no other family
FAMILY = {"title": "sweep planes", "renderer": True}
