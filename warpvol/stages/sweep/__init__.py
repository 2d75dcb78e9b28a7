"""Sweep-plane stages (VSBUFFER, Westermann & Ertl 1997)."""
