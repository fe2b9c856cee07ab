"""Airframes: one folder per airframe with ``<name>.urdf`` and ``<name>.yaml``, and their loader."""
