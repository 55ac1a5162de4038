"""The pure onboard core: nav, planner, guidance, control, mission, safety and the composed step.

No pymavlink, python-can, sockets, threads or clock: an import contract in ``make lint`` keeps it so."""
