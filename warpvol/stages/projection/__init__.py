"""Cell-projection stages: vertex stage, visibility sorting, projected-tetrahedra classification and fragment programs."""
