"""The fuzz suite (issue 32): hundreds of bad inputs across the public API, each run in its own process and
classed by what mechnet did with it (tests/fuzz/runner.py)."""
