"""Speed against accuracy: how fast each integrator reaches a given accuracy, where it
stops being stable, and how well the lattice reproduces the continuum wave equation.

Functions return plain data (dataclasses with ``as_dict``) so that the CLI, the docs and the web
app can all use them:

* ``accuracy.accuracy_study(scene, ...)``: error at time T against a reference solution, wall time,
  work-precision data, convergence orders and a recommendation for a tolerance
  (``accuracy_reference``: the reference solution; ``accuracy_runs``: one measured run;
  ``accuracy_report``: the table and the picture);
* ``stability.stability_study(cases, ...)``: largest stable dt found by bisection on real runs,
  next to the theoretical limit;
* ``dispersion.dispersion_study(...)``: wave speed and dispersion measured from long chains;
* ``response.response_curve(scene, ...)``: the steady amplitude of a driven lattice against the
  drive frequency (``response_modes``: the normal modes' theory; ``response_report``: the table
  and the picture);
* ``reflection.reflection_study(...)``: how much of a wave the absorbing walls send back.

``linear`` holds the exact normal-mode solution of a linearised lattice used as the reference.
"""
