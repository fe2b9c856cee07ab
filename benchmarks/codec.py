"""The codec's benchmark: bits at equal MS-SSIM against JPEG and WebP, and encode+decode time.

It is the evaluation of ``python -m compression.evaluate`` (docs/compression.md, "Evaluation")
written to a scratch folder instead of docs/images/compression/, so that running the benchmark
leaves the committed curves alone:

    python benchmarks/codec.py
    python benchmarks/codec.py --timing-repeats 100 --levels 1,3,5

Arguments are passed through to ``compression.evaluate``. The last line is
``RESULT bits_vs_jpeg=... bits_vs_webp=... encode_decode_ms_320x240=...`` (bits ratios at equal
MS-SSIM, median over levels; encode+decode of a 320x240 frame on one ONNX Runtime thread).
"""

from __future__ import annotations

import sys
import tempfile

from compression.evaluate import main

if __name__ == "__main__":
    args = sys.argv[1:]
    with tempfile.TemporaryDirectory(prefix="swarmsitl-codec-") as scratch:
        if "--out" not in args:
            args = [*args, "--out", scratch]
        sys.exit(main(args))
