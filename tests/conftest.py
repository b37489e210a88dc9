"""Shared test set-up: plots are written to files only, never shown."""
import matplotlib

matplotlib.use("Agg")
