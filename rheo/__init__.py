"""rheo: Herschel-Bulkley rheology of yield-stress fluids from video, by fitting a material-point simulation to it."""

__version__ = "0.1.0"
