"""Reproduction of the papers\x27 tables and figures as importable functions, one module per paper."""
