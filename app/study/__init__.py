"""Speed against accuracy: how fast each integrator reaches a given accuracy, where it
stops being stable, and how well the lattice reproduces the continuum wave equation.

Functions return plain data (dataclasses with ``as_dict``) so that the CLI, the docs and the web
app can all use them:

* ``accuracy.accuracy_study(scene, ...)``: error at time T against a reference solution, wall time,
  work-precision data, convergence orders and a recommendation for a tolerance;
* ``stability.stability_study(cases, ...)``: largest stable dt found by bisection on real runs,
  next to the theoretical limit;
* ``dispersion.dispersion_study(...)``: wave speed and dispersion measured from long chains.

``linear`` holds the exact normal-mode solution of a linearised lattice used as the reference.
"""
