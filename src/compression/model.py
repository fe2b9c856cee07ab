"""The learned codec's networks: analysis and synthesis transforms and a factorised entropy model.

Transform coding as Ballé, Laparra and Simoncelli (ICLR 2017, "End-to-end optimized image
compression") define it: an analysis transform ``g_a`` maps the image to a latent ``y``, ``y`` is
quantised to integers and entropy coded with a learned per-channel ("factorised") prior, and a
synthesis transform ``g_s`` maps the quantised latent back to pixels. The rate term of the loss
is that prior's negative log-likelihood; during training quantisation is replaced by additive
uniform noise so that the loss has gradients.

Sized for a Raspberry Pi rather than for the best rate-distortion: 4x4 pixel unshuffle, one 1x1
and three 3x3 convolutions each way, 16x down-sampling to ``latent_channels`` channels, and the
simplified GDN of Johnston et al. (CVPR 2019, ``x / (beta + gamma |x|)``), which costs one 1x1
convolution. One network serves every level: a per-level positive gain vector scales the latent
before quantisation ("gained" variable-rate coding, Cui et al., CVPR 2021), so a level is a
choice of quantisation step per channel, and each level has its own prior.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import torch
from torch import nn
from torch.nn import functional as F


@dataclass(frozen=True)
class ModelConfig:
    """The architecture's sizes; stored with the trained weights (``meta.json``)."""

    channels: int = 48
    latent_channels: int = 32
    levels: int = 5
    prior_filters: tuple[int, ...] = (3, 3, 3)

    def __post_init__(self) -> None:
        for name in ("channels", "latent_channels", "levels"):
            if getattr(self, name) < 1:
                raise ValueError(f"ModelConfig.{name} must be >= 1, got {getattr(self, name)}")

    @property
    def downsampling(self) -> int:
        """Pixels per latent position along each axis."""
        return 16


class SimplifiedGDN(nn.Module):
    """Simplified generalised divisive normalisation, ``x / (beta + conv1x1(|x|))``, or inverse.

    Johnston et al. 2019; beta and gamma are kept non-negative by re-parametrising through their
    square, with a small floor so that the division stays defined.
    """

    def __init__(self, channels: int, *, inverse: bool = False) -> None:
        super().__init__()
        self.inverse = inverse
        self.beta_root = nn.Parameter(torch.ones(channels))
        self.gamma_root = nn.Parameter(torch.sqrt(0.1 * torch.eye(channels) + 1e-6))

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        """Normalise ``x`` (N, C, H, W)."""
        beta = self.beta_root.square() + 1e-6
        gamma = self.gamma_root.square()
        norm = F.conv2d(x.abs(), gamma[:, :, None, None], beta)
        return x * norm if self.inverse else x / norm


def analysis_transform(config: ModelConfig) -> nn.Sequential:
    """``g_a``: RGB in [0, 1], (N, 3, H, W), H and W multiples of 16 -> (N, C, H/16, W/16)."""
    n, m = config.channels, config.latent_channels
    return nn.Sequential(
        nn.PixelUnshuffle(4),
        nn.Conv2d(48, n, 1),
        SimplifiedGDN(n),
        nn.Conv2d(n, n, 3, stride=2, padding=1),
        SimplifiedGDN(n),
        nn.Conv2d(n, n, 3, padding=1),
        SimplifiedGDN(n),
        nn.Conv2d(n, m, 3, stride=2, padding=1),
    )


def synthesis_transform(config: ModelConfig) -> nn.Sequential:
    """``g_s``: latent (N, C, h, w) -> RGB (N, 3, 16 h, 16 w), not clipped."""
    n, m = config.channels, config.latent_channels
    return nn.Sequential(
        nn.ConvTranspose2d(m, n, 4, stride=2, padding=1),
        SimplifiedGDN(n, inverse=True),
        nn.Conv2d(n, n, 3, padding=1),
        SimplifiedGDN(n, inverse=True),
        nn.ConvTranspose2d(n, n, 4, stride=2, padding=1),
        SimplifiedGDN(n, inverse=True),
        nn.Conv2d(n, 48, 1),
        nn.PixelShuffle(4),
    )


class FactorizedPrior(nn.Module):
    """A learned univariate density per latent channel (Ballé et al., ICLR 2018, appendix 6.1).

    The cumulative distribution c(x) is a small monotone network per channel: layers
    ``x <- softplus(H_k) x + b_k`` with ``x <- x + tanh(a_k) * tanh(x)`` between them, and a
    sigmoid at the end. The probability of an integer ``q`` is ``c(q + 1/2) - c(q - 1/2)``;
    convolving with the unit box this way is what makes the training-time noisy latent and the
    coded integer latent share one model.
    """

    def __init__(
        self, channels: int, filters: tuple[int, ...] = (3, 3, 3), init_scale: float = 10.0
    ) -> None:
        super().__init__()
        dims = (1, *filters, 1)
        scale = init_scale ** (1.0 / (len(filters) + 1))
        self.matrices = nn.ParameterList()
        self.biases = nn.ParameterList()
        self.factors = nn.ParameterList()
        for i in range(len(filters) + 1):
            init = float(torch.log(torch.expm1(torch.tensor(1.0 / scale / dims[i + 1]))))
            self.matrices.append(nn.Parameter(torch.full((channels, dims[i + 1], dims[i]), init)))
            self.biases.append(nn.Parameter(torch.rand(channels, dims[i + 1], 1) - 0.5))
            if i < len(filters):
                self.factors.append(nn.Parameter(torch.zeros(channels, dims[i + 1], 1)))

    def logits_cumulative(self, x: torch.Tensor) -> torch.Tensor:
        """The pre-sigmoid cumulative at ``x`` (C, 1, K): a row of K points per channel."""
        for i, matrix in enumerate(self.matrices):
            x = torch.matmul(F.softplus(matrix), x) + self.biases[i]
            if i < len(self.factors):
                x = x + torch.tanh(self.factors[i]) * torch.tanh(x)
        return x

    def likelihood(self, y: torch.Tensor) -> torch.Tensor:
        """Probability mass of the unit interval around each value of ``y`` (N, C, H, W)."""
        n, c, h, w = y.shape
        x = y.permute(1, 0, 2, 3).reshape(c, 1, -1)
        lower = self.logits_cumulative(x - 0.5)
        upper = self.logits_cumulative(x + 0.5)
        # Subtract in the tail where both sigmoids are nearest to 0 (numerically exact there).
        sign = -torch.sign(lower + upper).detach()
        mass = torch.abs(torch.sigmoid(sign * upper) - torch.sigmoid(sign * lower))
        return mass.reshape(c, n, h, w).permute(1, 0, 2, 3).clamp_min(1e-9)

    @torch.no_grad()
    def integer_pmf(self, values: torch.Tensor) -> torch.Tensor:
        """Probability of each integer in ``values`` (K,) for every channel: (C, K)."""
        channels = self.matrices[0].shape[0]
        x = values.to(self.biases[0].dtype).reshape(1, 1, -1).expand(channels, 1, -1)
        lower = self.logits_cumulative(x - 0.5)
        upper = self.logits_cumulative(x + 0.5)
        sign = -torch.sign(lower + upper)
        return torch.abs(torch.sigmoid(sign * upper) - torch.sigmoid(sign * lower))[:, 0, :]


class Autoencoder(nn.Module):
    """The whole codec for training: transforms, per-level gains and one prior per level."""

    def __init__(self, config: ModelConfig) -> None:
        super().__init__()
        self.config = config
        self.g_a = analysis_transform(config)
        self.g_s = synthesis_transform(config)
        # The analysis transform starts with outputs of about 0.04: gains of 10-80 put the first
        # latents above the quantisation noise, or the decoder would first learn from noise only.
        self.log_gains = nn.Parameter(
            torch.linspace(math.log(10.0), math.log(80.0), config.levels)[:, None].repeat(
                1, config.latent_channels
            )
        )
        self.priors = nn.ModuleList(
            FactorizedPrior(config.latent_channels, config.prior_filters)
            for _ in range(config.levels)
        )

    def gains(self, level_index: int) -> torch.Tensor:
        """The positive per-channel gain of a level (0-based), shape (C,)."""
        return torch.exp(self.log_gains[level_index])

    def forward(self, images: torch.Tensor, level_index: int) -> tuple[torch.Tensor, torch.Tensor]:
        """Reconstruction and bits per image of a training batch at one level (noise for rounding).

        Returns the reconstruction (N, 3, H, W) and the total bits of each image (N,).
        """
        gain = self.gains(level_index)[None, :, None, None]
        y = self.g_a(images) * gain
        noise = torch.empty_like(y).uniform_(-0.5, 0.5)
        y_tilde = y + noise if self.training else torch.round(y)
        bits = -torch.log2(self.priors[level_index].likelihood(y_tilde)).sum(dim=(1, 2, 3))
        return self.g_s(y_tilde / gain), bits
