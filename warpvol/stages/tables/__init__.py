"""Pre-integration table stages (Roettger & Ertl, Guthe, Kraus, Espinha & Celes tables), one module per stage."""
