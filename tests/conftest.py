"""Shared test settings: Warp's kernel cache and quiet start-up."""

import warp as wp

wp.config.quiet = True
