import numpy as np
import pytest

from compression.bitstream import Payload
from compression.entropy import LatentCoder, tables_from_pmf
from compression.errors import StreamError

VALUES = np.arange(-200, 201)


def _laplace_tables(scales):
    pmf = np.stack([np.exp(-np.abs(VALUES) / s) for s in scales])
    return tables_from_pmf(VALUES, pmf / pmf.sum(axis=1, keepdims=True))


def test_tables_keep_the_mass_and_leave_the_tails_to_the_escape():
    tables = _laplace_tables([0.5, 4.0])
    assert tables.lengths[0] < tables.lengths[1]  # a wider prior keeps more integers
    for c in range(2):
        row = tables.pmf[c, : tables.lengths[c]]
        assert row.sum() == pytest.approx(1.0, abs=2e-6)  # escape floor: TAIL_MASS
        assert 0 < row[-1] < 1e-5  # escape: the trimmed tails
        assert tables.low[c] < 0 < tables.low[c] + tables.lengths[c] - 2


def test_latent_round_trip_with_escaped_values_and_near_ideal_length():
    rng = np.random.default_rng(1)
    scales = [0.7, 2.0, 6.0]
    coder = LatentCoder(_laplace_tables(scales))
    latent = np.stack([np.rint(rng.laplace(0, s, (15, 20))) for s in scales]).astype(np.int64)
    latent[1, 3, 4] = 5000  # far outside every table
    latent[2, 0, 0] = -(2**35)
    payload = coder.encode(latent)
    assert payload.escapes.tolist() == [5000, -(2**35)]
    back = coder.decode(payload, latent.shape)
    np.testing.assert_array_equal(back, latent)
    # The code length is close to the information content under the tables.
    inside = np.ones_like(latent, dtype=bool)
    inside[1, 3, 4] = inside[2, 0, 0] = False
    bits = 0.0
    for c in range(3):
        t = coder.tables
        probs = t.pmf[c, latent[c][inside[c]] - t.low[c]]
        bits += -np.log2(probs).sum()
    assert 32 * payload.words.size == pytest.approx(bits, rel=0.05, abs=64)


def test_leftover_or_missing_data_raises():
    coder = LatentCoder(_laplace_tables([1.0, 1.0]))
    latent = np.zeros((2, 3, 3), dtype=np.int64)
    payload = coder.encode(latent)
    with pytest.raises(StreamError):
        coder.decode(Payload(np.array([7]), payload.words), latent.shape)
    with pytest.raises(StreamError):
        coder.decode(payload, (3, 3, 3))
