"""VSBUFFER sweep planes (Westermann & Ertl 1997): host code (:mod:`.vsbuffer`), convex cells
(:mod:`.cells`), the octree of cells (:mod:`.octree`) and the stages (:mod:`.stages`).
"""
