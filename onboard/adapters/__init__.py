"""The edges of the onboard program: the CAN bus and the MAVLink link."""
