"""Renderers: the virtual lab's surface renderer, a different model from the fit's (the lab shares its simulator)."""
