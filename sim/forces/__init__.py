"""The force terms' numba kernels: the springs (the one place a particle's forces are summed), the
drive table, the driver, and the absorbing layer's kicks and relaxation."""
