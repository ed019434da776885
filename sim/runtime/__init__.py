"""Running a simulation: the ``Simulation``, the runner that views subscribe to, the blow-up rule,
the error measures of a run, and the kernel cache and vector width set before any kernel."""
