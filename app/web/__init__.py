"""The web app: a viser page showing the lattice live, with controls, picking and dragging.

Modules:

* ``control``: ``LatticeRunner`` (the ``sim.runtime.runner.Runner`` plus particles held by a drag) and
  ``SimulationControl``, the commands the page sends (no viser here; unit-tested directly);
* ``view``: draws frames into a viser scene (particles, springs, walls, selection), coloured with
  the maps of ``app.colours``;
* ``inputs``: checks for every value a page sends, and safe display of text;
* ``host``: what a folder of the page receives (``PanelHost``) and gives back (``Folder``);
* ``widgets``: what the folders share to show things (messages, numbers, download names);
* ``folders``: one module per folder of the page (run, scene and its walls and files,
  integrator, accuracy, physics, selection, modes, probes, drive, view, recording, speed vs
  accuracy, energy);
* ``panel``: ``ControlPanel``, the folders built from one list and kept in step with the app;
* ``recording``, ``scene_files``, ``security``: one recording at a time into one directory,
  scene files opened by name from one directory, and the Host/Origin check of every request;
* ``app``: ``WebApp`` ties server, runner, view and panel together;
* ``serve``: the ``oscillators serve`` subcommand.
"""
