"""Renderers: the virtual lab's splat renderer, a different model from the fit's (the lab shares its simulator)."""
