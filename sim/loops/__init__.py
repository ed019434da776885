"""The compiled loop shapes that carry an integrator over the lattice: the one-thread row sweep,
row blocks on threads, the streaming wavefront, the fused leapfrog, the per-row stage updates,
and the per-host choice of kernel variants."""
