"""Cameras and images: checkerboard calibration, matting."""
