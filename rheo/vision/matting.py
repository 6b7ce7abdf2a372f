"""Classical matting against a clean plate (no learned weights): the change of chromaticity (which a shadow leaves
unchanged) plus a down-weighted change of lightness, an automatic (Otsu) or fixed threshold, morphological clean-up,
hole filling and the connected components that matter."""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np
from scipy import ndimage


@dataclass(frozen=True)
class MatteSettings:
    luminance_weight: float = 0.5  # weight of the Lab lightness difference (a shadow changes lightness only)
    threshold: float | None = None  # distance (Lab-like units); None: Otsu on the distance image
    min_threshold: float = 8.0  # never threshold below this (sensor noise)
    open_px: int = 0
    close_px: int = 1
    min_component_fraction: float = 0.05  # keep components at least this fraction of the largest


def _lab(image_rgb: np.ndarray) -> np.ndarray:
    return cv2.cvtColor(image_rgb.astype(np.float32) / 255.0, cv2.COLOR_RGB2LAB)


def _chromaticity(image_rgb: np.ndarray) -> np.ndarray:
    rgb = image_rgb.astype(np.float32) + 1.0
    return rgb / rgb.sum(axis=-1, keepdims=True)


def color_distance(frame_rgb: np.ndarray, plate_rgb: np.ndarray, luminance_weight: float) -> np.ndarray:
    """Per pixel: 100 x the chromaticity change, combined with ``luminance_weight`` x the Lab lightness change."""
    chroma = 100.0 * np.linalg.norm(_chromaticity(frame_rgb) - _chromaticity(plate_rgb), axis=-1)
    lightness = luminance_weight * (_lab(frame_rgb)[..., 0] - _lab(plate_rgb)[..., 0])
    return np.sqrt(chroma * chroma + lightness * lightness)


def matte(frame_rgb: np.ndarray, plate_rgb: np.ndarray, settings: MatteSettings = MatteSettings()) -> np.ndarray:
    """Boolean mask of the material in ``frame_rgb`` given the clean plate of the same view."""
    if frame_rgb.shape != plate_rgb.shape:
        raise ValueError(f"frame {frame_rgb.shape} and clean plate {plate_rgb.shape} differ in size")
    distance = color_distance(frame_rgb, plate_rgb, settings.luminance_weight)
    threshold = settings.threshold
    if threshold is None:
        scaled = np.clip(distance * (255.0 / max(distance.max(), 1e-6)), 0, 255).astype(np.uint8)
        otsu, _ = cv2.threshold(scaled, 0, 255, cv2.THRESH_BINARY + cv2.THRESH_OTSU)
        threshold = otsu * max(distance.max(), 1e-6) / 255.0
    mask = distance > max(threshold, settings.min_threshold)
    if settings.open_px > 0:
        mask = ndimage.binary_opening(mask, iterations=settings.open_px)
    if settings.close_px > 0:
        mask = ndimage.binary_closing(mask, iterations=settings.close_px, border_value=0)
    mask = ndimage.binary_fill_holes(mask)
    labels, count = ndimage.label(mask)
    if count > 1:
        sizes = ndimage.sum(mask, labels, index=np.arange(1, count + 1))
        keep = np.flatnonzero(sizes >= settings.min_component_fraction * sizes.max()) + 1
        mask = np.isin(labels, keep)
    return mask


def iou(a: np.ndarray, b: np.ndarray) -> float:
    union = np.logical_or(a, b).sum()
    return 1.0 if union == 0 else float(np.logical_and(a, b).sum() / union)
