"""The ISiMI100 bus contract: the DBC file, its codec, E2E protection, conventions and bus configuration.

This is the only part of ``onboard`` that ``hil_sim`` may import. Keep this ``__init__`` free of imports so
that pure code can use ``onboard.protocol.conventions`` without pulling in python-can or cantools.
"""
