"""Campaigns: many closed-loop missions of the real onboard core against the real simulator, in one process
per run (``virtual`` bus, lock-step), in parallel here or on a Ray cluster, with reports and gain tuning.

This is the one package that imports both ``onboard`` and ``hil_sim`` (the bench at scale); neither of them
imports it. ``auv-hil campaign`` and ``auv-hil tune`` run ``python -m auv_campaign``.
"""
