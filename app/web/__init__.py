"""The web app: a viser page showing the lattice live, with controls, picking and dragging.

Modules:

* ``control``: ``LatticeRunner`` (the ``sim.runner.Runner`` plus particles held by a drag) and
  ``SimulationControl``, the commands the page sends (no viser here; unit-tested directly);
* ``colors``: strain and field colour maps;
* ``view``: draws frames into a viser scene (particles, springs, walls, selection);
* ``panel``: the GUI folders (run, scene and its walls, integrator, physics, selection, view,
  energy plot); ``accuracy``, ``spectrum`` (Modes), ``probes`` and ``drive`` are folders of their
  own;
* ``app``: ``WebApp`` ties server, runner, view and panel together;
* ``serve``: the ``oscillators serve`` subcommand.
"""
