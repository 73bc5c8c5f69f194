"""Layer 0: SI objects, physics, the segment and its grid, kinematic profiles, simulation and the
stepping plant. numpy and scipy only; imports nothing else from ecostudy."""
