"""Reading a run afterwards: flight logs, checks, the run report, replays."""
