"""Scene conditioning: the scene centred, scaled and checked for float32 precision
(:mod:`.conditioning`); the ``condition`` stage in :mod:`.stages`.
"""
