"""Seed 000's T_compress: choose the compression level of the next image from bandwidth and energy.

Seed 000 (ARCog-NET, Sec. 3.2) lists T_compress, "adjust compression level", among the tasks a
node allocates, and sends images from edge to fog to cloud over constrained links; it gives no
rule. This module is ours, a pure function of what a node knows:

- the link's bandwidth (bytes/s: the link model's rate or a measured throughput) and the image
  period: the bytes one image may take are ``link_share x bandwidth x period``;
- the energy the node may still spend on images and the time left: with the link's J per byte
  (``LinkBudget.j_per_byte``, radio power x airtime as in seed 000 Table I) and the encode energy
  of one image, the bytes one image may take are ``(energy per image - encode J) / (J/byte)``;
- the expected size of each level: ``bits_per_pixel[level] x pixels / 8`` plus the per-image
  overhead (the codec's ``compression.level_bits_per_pixel(level)``, the mean over its held-out
  set; injected as a mapping so the policy is testable without the codec).

The level is the highest whose expected size fits the smaller of the two budgets. The codec's
mean bits per pixel are a forecast; :class:`LevelController` corrects it by the ratio of the sizes
it measured to the sizes it expected (a moving average over the images sent), since a scene far
from the codec's held-out set compresses to more or fewer bits at every level alike. Hysteresis
keeps it from flapping: a level that no longer fits is left at once (down), but a higher level is
taken only when it fits within ``up_headroom`` of the budget and the current level has been kept
for ``min_hold_images`` images.

Assumptions (the paper is silent): images may take half the link (``link_share`` 0.5; the rest
is status, control and the other nodes); the mean bpp of a level is a fair forecast of the next
image's size (a level's size varies with the scene, so the headroom also absorbs that spread);
when nothing fits the lowest level is still sent (an image is the edge's purpose; the caller may
count it as over budget).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass


@dataclass(frozen=True)
class LevelPolicyParams:
    """Tuning of the T_compress policy."""

    link_share: float = 0.5
    """Fraction of the link's bandwidth images may take, 0..1 (assumption)."""
    up_headroom: float = 0.8
    """A higher level is taken only if its expected size is <= this fraction of the budget."""
    min_hold_images: int = 3
    """Images sent at a level before the policy may step up again."""
    overhead_bytes: int = 200
    """Per image: codec header, chunk and envelope headers, bytes."""
    size_learning_rate: float = 0.3
    """Weight of the newest image in the moving average of measured / expected size, 0..1
    (0: trust the codec's bits per pixel as they are)."""

    def __post_init__(self) -> None:
        if not 0 < self.link_share <= 1:
            raise ValueError(f"link_share: must be within (0, 1], got {self.link_share}")
        if not 0 < self.up_headroom <= 1:
            raise ValueError(f"up_headroom: must be within (0, 1], got {self.up_headroom}")
        if self.min_hold_images < 0:
            raise ValueError(f"min_hold_images: must be >= 0, got {self.min_hold_images}")
        if self.overhead_bytes < 0:
            raise ValueError(f"overhead_bytes: must be >= 0, got {self.overhead_bytes}")
        if not 0 <= self.size_learning_rate <= 1:
            raise ValueError(
                f"size_learning_rate: must be within [0, 1], got {self.size_learning_rate}"
            )


def expected_bytes(
    level: int, pixels: int, bits_per_pixel: Mapping[int, float], overhead_bytes: int = 0
) -> float:
    """Expected size of an image of ``pixels`` at ``level``, bytes."""
    return bits_per_pixel[level] * pixels / 8.0 + overhead_bytes


def energy_per_image_j(
    remaining_j: float | None, remaining_s: float, image_period_s: float
) -> float:
    """Energy one image may spend: what is left spread over the images still to send, J.

    ``remaining_j`` None means no energy limit (inf). At least one image is assumed left.
    """
    if remaining_j is None:
        return math.inf
    if not image_period_s > 0:
        raise ValueError(f"image_period_s: must be > 0, got {image_period_s}")
    images_left = max(1.0, remaining_s / image_period_s)
    return max(0.0, remaining_j) / images_left


def budget_bytes(
    bandwidth_bytes_s: float,
    image_period_s: float,
    j_per_byte: float,
    energy_per_image_j: float,
    encode_j: float,
    params: LevelPolicyParams,
) -> float:
    """Bytes one image may take: the smaller of the bandwidth and the energy budget."""
    if not bandwidth_bytes_s >= 0:
        raise ValueError(f"bandwidth_bytes_s: must be >= 0, got {bandwidth_bytes_s}")
    if not image_period_s > 0:
        raise ValueError(f"image_period_s: must be > 0, got {image_period_s}")
    if not j_per_byte >= 0:
        raise ValueError(f"j_per_byte: must be >= 0, got {j_per_byte}")
    by_bandwidth = params.link_share * bandwidth_bytes_s * image_period_s
    tx_j = energy_per_image_j - encode_j
    unlimited = j_per_byte == 0 or math.isinf(tx_j)
    by_energy = math.inf if unlimited else max(0.0, tx_j) / j_per_byte
    return min(by_bandwidth, by_energy)


def highest_fitting(
    limit_bytes: float, pixels: int, bits_per_pixel: Mapping[int, float], overhead_bytes: int
) -> int:
    """Highest level whose expected size is <= ``limit_bytes`` (else the lowest level)."""
    if not bits_per_pixel:
        raise ValueError("bits_per_pixel: no levels")
    levels = sorted(bits_per_pixel)
    fitting = [
        lv
        for lv in levels
        if expected_bytes(lv, pixels, bits_per_pixel, overhead_bytes) <= limit_bytes
    ]
    return fitting[-1] if fitting else levels[0]


def choose_level(
    current: int | None,
    held_images: int,
    budget: float,
    pixels: int,
    bits_per_pixel: Mapping[int, float],
    params: LevelPolicyParams,
) -> int:
    """The level of the next image (pure; see the module docstring for the rule).

    Args:
        current: level of the previous image, None for the first.
        held_images: images sent at ``current`` since it was chosen.
        budget: bytes the image may take (:func:`budget_bytes`).
        pixels: width x height of the image.
        bits_per_pixel: expected bits per pixel of each level.
        params: the policy's tuning.
    """
    if pixels <= 0:
        raise ValueError(f"pixels: must be > 0, got {pixels}")
    fits = highest_fitting(budget, pixels, bits_per_pixel, params.overhead_bytes)
    if current is None or current not in bits_per_pixel:
        return fits
    if fits < current:
        return fits  # the current level no longer fits: step down at once
    if held_images < params.min_hold_images:
        return current
    comfortable = highest_fitting(
        params.up_headroom * budget, pixels, bits_per_pixel, params.overhead_bytes
    )
    return max(current, comfortable)


class LevelController:
    """T_compress for one outgoing stream of images: the policy with its state (level, hold)."""

    def __init__(
        self,
        bits_per_pixel: Mapping[int, float],
        params: LevelPolicyParams | None = None,
        max_level: int | None = None,
    ) -> None:
        if not bits_per_pixel:
            raise ValueError("bits_per_pixel: no levels")
        self.bits_per_pixel = dict(bits_per_pixel)
        self.params = params or LevelPolicyParams()
        self.level: int | None = None
        """Level of the last image."""
        self.held_images = 0
        """Images sent at ``level`` since it was chosen."""
        self.changes = 0
        """Times the level changed (after the first choice)."""
        self.last_budget_bytes = math.inf
        """Budget of the last choice, bytes."""
        self.size_ratio = 1.0
        """Moving average of measured / expected image size (the forecast's correction)."""

    def next_level(
        self,
        pixels: int,
        bandwidth_bytes_s: float,
        image_period_s: float,
        j_per_byte: float,
        energy_per_image_j: float = math.inf,
        encode_j: float = 0.0,
        cap: int | None = None,
    ) -> int:
        """Choose and commit the level of the next image; ``cap`` bounds it from above.

        A fog re-compressing an image passes the level it arrived at as ``cap``: decoding and
        encoding again at a higher level spends bits on the first codec's artefacts.
        """
        budget = budget_bytes(
            bandwidth_bytes_s, image_period_s, j_per_byte, energy_per_image_j, encode_j, self.params
        )
        self.last_budget_bytes = budget
        forecast = {lv: bpp * self.size_ratio for lv, bpp in self.bits_per_pixel.items()}
        level = choose_level(self.level, self.held_images, budget, pixels, forecast, self.params)
        if cap is not None:
            allowed = [lv for lv in self.bits_per_pixel if lv <= cap]
            level = min(level, max(allowed) if allowed else min(self.bits_per_pixel))
        if level == self.level:
            self.held_images += 1
        else:
            self.changes += self.level is not None
            self.level = level
            self.held_images = 1
        return level

    def observe(self, level: int, pixels: int, size_bytes: int) -> None:
        """Learn from an encoded image's real size (its codec stream, without overhead)."""
        expected = self.bits_per_pixel.get(level, 0.0) * pixels / 8.0
        if expected <= 0 or size_bytes <= 0:
            return
        ratio = min(10.0, max(0.1, size_bytes / expected))
        rate = self.params.size_learning_rate
        self.size_ratio = (1 - rate) * self.size_ratio + rate * ratio
