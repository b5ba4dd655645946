"""Tools that use both the simulator and the skills: calibrations recorded once per robot model."""
