"""Where a dam break's simulation and recording disagree: residual maps, and the mismatch located in time (which
frames) and in space (inside the container, the front, the contact line on the floor, the free surface), said in
plain words.

The regions are drawn in the image: the container is the material's initial cuboid seen by the camera; outside it,
the front is the far tenth of the material's reach along the channel, the contact line the lower third (at least a
few pixels) of each column of what the silhouettes show there (where the material meets the floor nearest the
camera), and the free surface the rest.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rheo.experiments.virheometry import Setup, container_silhouette

REGIONS = ("inside the container", "front", "contact line", "free surface")
CONTACT_BAND = 4  # px: the least height of the contact line's band
FRONT_SHARE = 0.1  # the far tenth of the reach along the channel


def region_masks(setup: Setup, silhouettes: list[np.ndarray]) -> dict[str, np.ndarray]:
    """The image regions of ``REGIONS`` (H, W bool, disjoint), from the setup and the silhouettes of both sides
    (simulated and recorded, all frames): the front lies beyond the material's farthest reach less a tenth of
    its reach outside the container."""
    container = container_silhouette(setup)
    height, width = container.shape
    rows, columns = np.mgrid[:height, :width]
    outside = np.logical_or.reduce(silhouettes) & ~container
    container_columns = np.flatnonzero(container.any(axis=0))
    gate = container_columns.max() if len(container_columns) else 0
    reach_columns = np.flatnonzero(outside.any(axis=0))
    reach = reach_columns.max() if len(reach_columns) else gate
    front = columns >= reach - FRONT_SHARE * max(reach - gate, 1)
    # per column, the lower third of what any silhouette shows outside the container (at least CONTACT_BAND px):
    # where the material meets the floor nearest the camera
    shown = outside.any(axis=0)
    lowest = np.where(shown, height - 1 - np.argmax(outside[::-1], axis=0), -1)
    highest = np.where(shown, np.argmax(outside, axis=0), height)
    band = np.maximum(CONTACT_BAND, (lowest - highest) / 3)
    contact = shown[None, :] & (rows >= (lowest - band)[None, :])
    regions = {"inside the container": container,
               "front": ~container & front,
               "contact line": ~container & ~front & contact}
    regions["free surface"] = ~(regions["inside the container"] | regions["front"] | regions["contact line"])
    return regions


@dataclass
class Location:
    """The mismatch over frames and regions: pixel counts (frames, regions) of extra and missing material."""

    extra: np.ndarray
    missing: np.ndarray
    frame_labels: list[str]

    @property
    def total(self) -> np.ndarray:
        return self.extra + self.missing

    def by_frame(self) -> np.ndarray:
        return self.total.sum(axis=1)

    def by_region(self) -> dict[str, float]:
        share = self.total.sum(axis=0) / max(float(self.total.sum()), 1.0)
        return dict(zip(REGIONS, share.tolist(), strict=True))

    def words(self) -> str:
        """The mismatch in plain words: when, where, and which way."""
        if self.total.sum() == 0:
            return "The simulation matches every frame."
        per_frame = self.by_frame()
        heavy = list(np.flatnonzero(per_frame >= 0.5 * per_frame.max()))  # frames with at least half the worst's
        third = len(per_frame) / 3
        when = ("early" if max(heavy) < third else "late" if min(heavy) >= 2 * third
                else "in the middle" if min(heavy) >= third and max(heavy) < 2 * third else "throughout")
        runs = np.split(np.array(heavy), np.flatnonzero(np.diff(heavy) > 1) + 1)
        frames = ", ".join(self.frame_labels[r[0]] if len(r) == 1 else
                           f"{self.frame_labels[r[0]]}-{self.frame_labels[r[-1]]}" for r in runs)
        shares = self.by_region()
        where = max(shares, key=shares.get)
        k = REGIONS.index(where)
        extra, missing = self.extra[:, k].sum(), self.missing[:, k].sum()
        wording = {"front": ("at the front", "the simulated front runs ahead of the recording",
                             "the simulated front lags behind"),
                   "contact line": ("at the contact line", "the simulation spreads more along the floor",
                                    "the recording spreads more along the floor"),
                   "free surface": ("at the free surface", "the simulated surface stands higher",
                                    "the simulated surface lies lower"),
                   "inside the container": ("inside the container",
                                            "the simulation leaves more material in the container",
                                            "the simulation drains the container more")}
        place, if_extra, if_missing = wording[where]
        direction = if_extra if extra >= missing else if_missing
        return (f"The mismatch is largest in frames {frames} ({when}); {100 * shares[where]:.0f} % of it {place}, "
                f"where {direction} ({100 * max(extra, missing) / max(extra + missing, 1):.0f} % "
                f"{'extra' if extra >= missing else 'missing'} material).")


def locate(setup: Setup, simulated: list[np.ndarray], observed: list[np.ndarray],
           frame_labels: list[str] | None = None) -> Location:
    """Pixel counts of the mismatch per frame and region; frames labelled 1, 2, ... unless ``frame_labels``."""
    regions = region_masks(setup, [*simulated, *observed])
    extra = np.zeros((len(observed), len(REGIONS)))
    missing = np.zeros_like(extra)
    for f, (s, o) in enumerate(zip(simulated, observed, strict=True)):
        for k, name in enumerate(REGIONS):
            extra[f, k] = (s & ~o & regions[name]).sum()
            missing[f, k] = (o & ~s & regions[name]).sum()
    return Location(extra, missing, frame_labels or [str(k + 1) for k in range(len(observed))])
