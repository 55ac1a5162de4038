"""The onboard program: configuration, the control loop (time and bus) and start-up."""
