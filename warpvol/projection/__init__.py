"""Projected tetrahedra: host code (:mod:`.pt`, :mod:`.sort`, :mod:`.pt_thin`) and the stages
(:mod:`.stages`) of Shirley & Tuchman, Roettger & Ertl, Guthe et al., Kraus et al. and ``pt_best``.
"""

#: the family's declaration (warpvol.family): a renderer family imports no other family
FAMILY = {"title": "cell projection", "renderer": True}
