"""Lotion's laws that several studies compare, as their stores label them (docs/real-data.md): its joint fit at the
default settings, rounded, and three laws of that fit's flow-index profile."""

BINGHAM = (14.5, 0.978, 1.0)
SHAPES = {"n 0.55": (2.4576, 6.5717, 0.55), "n 1": (14.4528, 0.97793, 1.0), "n 1.4": (17.2573, 0.20308, 1.4)}
