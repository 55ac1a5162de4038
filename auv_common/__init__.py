"""Configuration loading and CLI helpers shared by the three programs (no I/O beyond files)."""
