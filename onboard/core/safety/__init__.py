"""Failsafes: pure checks and the abort command."""
