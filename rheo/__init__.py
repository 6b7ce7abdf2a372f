"""rheo: Herschel-Bulkley rheology of yield-stress fluids from video, through differentiable simulation."""

__version__ = "0.1.0"
