"""Monte Carlo sweeps: a grid of scenario parameters x seeds, one scenario run per trial, on Dask.

``spec`` reads and checks the sweep file (nothing is submitted before every trial's scenario
parsed), ``params`` resolves dotted parameter names against the scenario schema, ``trial`` runs
one trial into one table row, ``table`` keeps the rows in Parquet, ``runner`` schedules the
trials on a Dask cluster, ``plots`` draws means with confidence intervals. docs/sweeps.md.
"""
