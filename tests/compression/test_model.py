"""The ONNX transforms the companion runs agree with the torch model they were exported from."""

import numpy as np
import torch

import compression
from compression.bundle import DEFAULT_MODEL_DIR
from compression.model import Autoencoder, FactorizedPrior, ModelConfig


def _torch_model() -> Autoencoder:
    codec = compression.default_codec()
    model = Autoencoder(
        ModelConfig(
            **{
                k: tuple(v) if isinstance(v, list) else v
                for k, v in codec.bundle.meta["config"].items()
            }
        )
    )
    model.load_state_dict(torch.load(DEFAULT_MODEL_DIR / "model.pt", weights_only=True))
    return model.eval()


def test_onnx_and_torch_agree_on_latent_and_decoded_image(scene_images):
    codec = compression.default_codec()
    model = _torch_model()
    image = scene_images[3]
    for level in (1, 3, 5):
        latent = codec.latent(image, level)
        x = torch.from_numpy(image).permute(2, 0, 1)[None].float() / 255.0
        with torch.no_grad():
            y = model.g_a(x) * model.gains(level - 1)[None, :, None, None]
        torch_latent = torch.round(y)[0].numpy().astype(np.int64)
        # Rounding may differ only where a value sits on a .5 boundary to float precision.
        assert np.mean(torch_latent != latent) < 1e-3
        with torch.no_grad():
            y_hat = (
                torch.from_numpy(latent).float()[None] / model.gains(level - 1)[None, :, None, None]
            )
            torch_image = model.g_s(y_hat).clamp(0, 1)[0].permute(1, 2, 0).numpy() * 255
        onnx_image = codec.synthesize(latent, level)
        assert np.max(np.abs(np.rint(torch_image) - onnx_image)) <= 1


def test_stored_tables_are_the_priors_of_the_torch_model():
    codec = compression.default_codec()
    model = _torch_model()
    for index, tables in enumerate(codec.bundle.tables):
        values = torch.arange(
            tables.low[0], tables.low[0] + tables.lengths[0] - 1, dtype=torch.float64
        )
        pmf = model.priors[index].double().integer_pmf(values).numpy()[0]
        np.testing.assert_allclose(tables.pmf[0, : values.numel()], pmf, rtol=1e-9, atol=1e-12)


def test_prior_is_a_distribution_and_noise_likelihood_matches_integer_pmf():
    torch.manual_seed(0)
    prior = FactorizedPrior(4)
    values = torch.arange(-300, 301, dtype=torch.float32)
    pmf = prior.integer_pmf(values)
    assert torch.allclose(pmf.sum(dim=1), torch.ones(4), atol=1e-4)
    y = values[None, None, None, 280:320].expand(1, 4, 1, 40).contiguous()
    assert torch.allclose(
        prior.likelihood(y)[0, :, 0, :], pmf[:, 280:320].clamp_min(1e-9), atol=1e-6
    )
