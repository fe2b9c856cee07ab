"""Camera images on the companion: seed 000's T_compress level policy, chunked image transfer.

See docs/compression_pipeline_part.md. ``compress_level`` is the pure policy,
``link_budget`` the bandwidth and energy per byte of a link, ``chunks`` the splitting of one
encoded image over datagrams, ``image_source`` where frames come from, ``relay`` the sender and
receiver the edge, fog and cloud roles use.
"""
