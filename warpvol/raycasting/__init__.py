"""Ray casting: the consistent float32 walk (``raycast``, ``peel``) and hardware ray casting (HARC,
Espinha & Celes 2005; host code in :mod:`.harc`); the stages in :mod:`.stages`.
"""

#: the family's declaration (warpvol.family): a renderer family imports no other family
FAMILY = {"title": "ray casting", "renderer": True}
