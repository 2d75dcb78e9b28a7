"""Ray-casting stages: the consistent float32 walk (`raycast`, `peel`) and hardware ray casting (HARC)."""
