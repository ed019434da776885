"""Theory of the lattice: normal modes and the exact solution, plane waves and their dispersion,
slit fringes, predicted errors, and the observables of a state (energies, strains, stability)."""
