"""Command-line flags that need parsing: airframes and worlds, parameters, signing, wind."""
